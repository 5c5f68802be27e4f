//! The simulated world: a procedural site with its ray caster, clearance and
//! region of interest, and the images acquired in it (true and
//! SfM-estimated poses, features, predicted confidence). What SfM gives of
//! the images is [`crate::sfm`]; the campaign's initial flight and its
//! renders are `campaign::images`.

use nalgebra::Point3;
use rayon::prelude::*;
use vp_scene::clearance::Clearance;
use vp_scene::procedural::{generate_site, Site};
use vp_scene::raster::ConfidenceImage;
use vp_scene::raycast::RayCaster;
use vp_scene::{Aabb, Camera, Intrinsics, Material, Mesh};

use crate::config::CampaignConfig;
use crate::error::Result;
use crate::sfm::{FeatureMask, SparseCandidates};

/// [`World::home`]'s `source` for an open spot and for the fallback.
const OPEN_SPOT: &str =
    "the simulated take-off point, on open ground at the edge of the region of interest";
const BELOW_ORIGIN: &str = "the simulated take-off point, on the ground below the site's origin \
     (no open ground at the edge of the region of interest)";

/// A held-out site with its ray caster and region of interest.
pub struct World {
    /// The true site.
    pub site: Site,
    /// Ray caster of the true mesh.
    pub caster: RayCaster,
    /// Distance queries to the true mesh (the crash check).
    pub clearance: Clearance,
    /// The region of interest: the rock's box grown by the margin, all heights.
    pub roi: Aabb,
    /// Camera of every flight.
    pub intrinsics: Intrinsics,
    /// The surface points SfM may triangulate (one SfM simulator for the
    /// planning geometry and every reconstruction's depth range).
    pub candidates: SparseCandidates,
}

impl World {
    /// Generates the site of `seed` and its ROI.
    pub fn new(cfg: &CampaignConfig, seed: u64) -> Result<Self> {
        let mut params = cfg.site.clone();
        params.seed = seed;
        let site = generate_site(&params)?;
        let caster = RayCaster::new(&site.mesh);
        let rb = site.rock_bounds;
        let m = cfg.roi_margin_m;
        let b = site.mesh.bounds();
        let roi = Aabb {
            min: Point3::new(rb.min.x - m, rb.min.y - m, b.min.z - 1.0),
            max: Point3::new(rb.max.x + m, rb.max.y + m, b.max.z + 1.0),
        };
        let candidates = SparseCandidates::of_site(&site.mesh, cfg, seed);
        Ok(World {
            candidates,
            clearance: Clearance::new(&site.mesh),
            site,
            caster,
            roi,
            intrinsics: cfg.planner.camera.intrinsics(),
        })
    }

    /// The true world as the matcher sees it.
    pub fn scene(&self) -> Scene<'_> {
        Scene {
            mesh: &self.site.mesh,
            caster: &self.caster,
            texture_seed: self.site.params.seed,
            candidates: &self.candidates,
        }
    }

    /// Where the simulated vehicle takes off: the first of the spots
    /// [`World::takeoff_spot`] tries that an operator could stand on, or,
    /// on a site with none, the ground straight below the site's origin.
    pub fn home(&self) -> vp_scene::plan::Home {
        let (enu, source) = self.takeoff_spot().map_or_else(
            || {
                let below = self.ground_below(0.0, 0.0, self.above_site());
                (below.map_or(Point3::origin(), |(p, _)| p), BELOW_ORIGIN)
            },
            |spot| (spot, OPEN_SPOT),
        );
        let frame = vp_scene::geodesy::LocalFrame::new(self.site.origin);
        let position = frame.map_or(self.site.origin, |f| f.to_geodetic([enu.x, enu.y, enu.z]));
        vp_scene::plan::Home {
            position,
            source: source.into(),
        }
    }

    /// An open take-off spot, as an operator chooses one: on bare ground or
    /// grass (not on the rock, under a tree or on a marker's post), with
    /// nothing overhanging it (the planner's take-off column, from
    /// `COLUMN_CHECK_FROM_M` up to above the site, keeps twice
    /// `TAKEOFF_CLEARANCE_M` from the mesh, as `vpctl plan` checks it with
    /// half that), close to the rock: on the region of interest's edge
    /// (the rock's footprint grown by `roi_margin_m`), the middle of each
    /// side, then each corner, south side first. The ground straight below
    /// the origin, the spot before, lay on the rock's top on most sites
    /// (the rock stands at the origin).
    pub fn takeoff_spot(&self) -> Option<Point3<f64>> {
        use vp_planner::home_way::{COLUMN_CHECK_FROM_M, TAKEOFF_CLEARANCE_M};
        let (lo, hi) = (self.roi.min, self.roi.max);
        let mid = nalgebra::center(&lo, &hi);
        let sides = [(mid.x, lo.y), (hi.x, mid.y), (mid.x, hi.y), (lo.x, mid.y)];
        let corners = [(lo.x, lo.y), (hi.x, lo.y), (hi.x, hi.y), (lo.x, hi.y)];
        let top = self.above_site();
        sides.into_iter().chain(corners).find_map(|(x, y)| {
            let (ground, material) = self.ground_below(x, y, top)?;
            let open = matches!(material, Some(Material::Ground | Material::Grass));
            let base = ground + nalgebra::Vector3::z() * COLUMN_CHECK_FROM_M;
            let column = Point3::new(x, y, top.max(base.z));
            let clear =
                self.clearance.segment_distance(&base, &column) >= 2.0 * TAKEOFF_CLEARANCE_M;
            (open && clear).then_some(ground)
        })
    }

    /// A height above every face of the site (the mesh's bounds are a
    /// pass over its vertices: taken once per query, not per ray).
    fn above_site(&self) -> f64 {
        self.site.mesh.bounds().max.z + 1.0
    }

    /// The first surface straight below (x, y), looking down from height
    /// `from` (above the site), and its material.
    fn ground_below(&self, x: f64, y: f64, from: f64) -> Option<(Point3<f64>, Option<Material>)> {
        let hit = self.caster.closest_hit(
            &Point3::new(x, y, from),
            &-nalgebra::Vector3::z(),
            f64::INFINITY,
        )?;
        Some((hit.point, self.site.mesh.material(hit.face as usize)))
    }

    /// Lowest ground point of the site (flight heights refer to it).
    pub fn ground_min_z(&self) -> f64 {
        self.site.mesh.bounds().min.z
    }
}

/// An acquired image: where it really was, where SfM thinks it was, where
/// a feature detector fires on it, and its predicted confidence (for F
/// strategies).
#[derive(Debug, Clone)]
pub struct Acquired {
    /// The true camera (renders, virtual MVS).
    pub truth: Camera,
    /// The camera as SfM estimated it (the planner's, the matcher's and
    /// labelgen's input).
    pub sfm: Camera,
    /// Where FAST fires on the rendered image (which sparse points SfM
    /// gets from it).
    pub features: FeatureMask,
    /// Predicted confidence, when the strategy predicts.
    pub confidence: Option<ConfidenceImage>,
}

/// The world a reconstruction looks at: the true mesh, its caster, the
/// texture seed of its renders and the points SfM may triangulate.
#[derive(Clone, Copy)]
pub struct Scene<'a> {
    /// The true mesh.
    pub mesh: &'a Mesh,
    /// Ray caster of `mesh`.
    pub caster: &'a RayCaster,
    /// Texture seed of the world.
    pub texture_seed: u64,
    /// SfM's candidate points on `mesh`.
    pub candidates: &'a SparseCandidates,
}

/// Faces of `mesh` whose centroid lies inside `roi`, and whether each is rock.
pub fn roi_faces(mesh: &Mesh, roi: &Aabb) -> Vec<u32> {
    (0..mesh.n_faces())
        .into_par_iter()
        .filter(|&f| roi.contains(&mesh.face_centroid(f)))
        .map(|f| f as u32)
        .collect()
}
