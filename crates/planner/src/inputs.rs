//! What a planning call takes and gives: the acquired views, the region of
//! interest, the inputs and the result, and the safety rules of a call.

use std::collections::BTreeMap;

use nalgebra::{Point3, Vector3};
use vp_scene::plan::{AltitudeLimits, GeodeticOrigin, IterationStatistics, Plan};
use vp_scene::raster::ConfidenceImage;
use vp_scene::raycast::RayCaster;
use vp_scene::roi::Roi;
use vp_scene::roi_file::GeoPolygon;
use vp_scene::{Aabb, Camera, Mesh};

use crate::config::PlannerConfig;
use crate::error::{PlannerError, Result};
use crate::free_space::Observation;
use crate::safety::Safety;

/// Height of the default flight volume above the highest mesh point, metres.
const DEFAULT_CEILING_M: f64 = 60.0;

/// An acquired image: its camera and, when predicted, its confidence image.
#[derive(Debug, Clone)]
pub struct AcquiredView {
    /// The posed camera.
    pub camera: Camera,
    /// Predicted MVS confidence; `None` means no prediction (confidence 1).
    pub confidence: Option<ConfidenceImage>,
}

/// Which faces the quality requirements apply to.
#[derive(Debug, Clone, PartialEq)]
pub enum RoiSpec {
    /// Every face of the mesh.
    All,
    /// These face indices.
    Faces(Vec<u32>),
    /// A region (box, ground polygon, image polygon).
    Region(Roi),
    /// An area drawn on a map in longitude/latitude (`--roi-polygon`),
    /// placed in the plan's ENU frame through its geodetic origin when the
    /// plan is made ([`RoiSpec::resolve`]).
    Geographic {
        /// The polygon, as read from its file.
        polygon: GeoPolygon,
        /// Height range of the prism over the polygon (ENU metres); `None`:
        /// every height of the mesh, from the ground to the top.
        heights: Option<(f64, f64)>,
    },
}

/// Inputs of one planning call.
pub struct PlanInputs<'a> {
    /// The scene mesh (obstacles and surface to reconstruct).
    pub mesh: &'a Mesh,
    /// Acquired images, in capture order (the last is where the path starts).
    pub acquired: &'a [AcquiredView],
    /// Region of interest.
    pub roi: RoiSpec,
    /// Parameters.
    pub config: &'a PlannerConfig,
    /// Geodetic origin written into the plan.
    pub origin: Option<GeodeticOrigin>,
    /// Observation rays (camera centre, observed point) that carve the
    /// observed-free space (`unknown_space = "occupied"`); `None`: rays from
    /// the acquired cameras to the mesh ([`crate::free_space`]).
    pub observations: Option<&'a [Observation]>,
    /// The take-off point on the ground (ENU), where every flight starts and
    /// ends; `None`: the plan's flights leave out the legs to and from home.
    pub home: Option<Point3<f64>>,
}

/// One sampled triangle and its final fulfillment.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct SampledFulfillment {
    /// Face of the input mesh it was split from.
    pub parent: u32,
    /// Centroid.
    pub centroid: Point3<f64>,
    /// Unit normal.
    pub normal: Vector3<f64>,
    /// f(t) with the acquired and planned cameras.
    pub f: f64,
    /// Whether it belonged to the selected set T.
    pub selected: bool,
}

/// Everything a planning call produced.
#[derive(Debug, Clone)]
pub struct PlanResult {
    /// The plan (also carries statistics and the cut-short flag).
    pub plan: Plan,
    /// Per-iteration figures of the triplets flown (same as
    /// `plan.statistics.iterations`): a dropped triplet is not among them,
    /// and those after it are replayed without it.
    pub iterations: Vec<IterationStatistics>,
    /// Wall time per module over the whole call, seconds.
    pub module_time_s: BTreeMap<String, f64>,
    /// Input-mesh faces of the selected triangles T.
    pub selected_faces: Vec<u32>,
    /// Every sampled triangle with its final f(t).
    pub sampled: Vec<SampledFulfillment>,
    /// Gains g(c3) of the triplets flown, when M3 chose them, in planning order.
    pub triplet_gains: Vec<f64>,
    /// Surrogates visited by each M3 search (those of dropped triplets and
    /// of the searches for their replacements too).
    pub visited: Vec<usize>,
    /// Waypoint indices of images that could not be bridged to o_min overlap.
    pub unbridged: Vec<usize>,
    /// Triplets chosen but left out of the path: one of their images is
    /// unsafe or no climb-traverse-descend route reaches it
    /// (`plan.dropped_triplets` has them with their replacements).
    pub dropped_triplets: Vec<u32>,
    /// Why each of `dropped_triplets` was left out, naming waypoints of
    /// `plan`, and the triplet that replaced it ("...; replaced by triplet
    /// 4") or "...; not replaced" (then `cut_short_reason` says why).
    pub dropped_reasons: Vec<String>,
    /// True when fewer than k triplets are flown.
    pub cut_short: bool,
    /// Why.
    pub cut_short_reason: Option<String>,
}

/// The mesh's safety rules of a call: volume, altitude and geofence from
/// the config or, by default, from the mesh bounds (the free-space rule is
/// added by [`crate::plan`], which has the observations).
pub fn safety_for(mesh: &Mesh, cfg: &PlannerConfig) -> Safety {
    let b = mesh.bounds();
    let volume = cfg.flight_volume_aabb().unwrap_or(Aabb {
        min: b.min,
        max: Point3::new(b.max.x, b.max.y, b.max.z + DEFAULT_CEILING_M),
    });
    let altitude = cfg.altitude_limits.unwrap_or(AltitudeLimits {
        min_m: volume.min.z,
        max_m: volume.max.z,
    });
    Safety::new(
        mesh,
        cfg.clearance_m(),
        volume,
        cfg.geofence.clone(),
        altitude,
    )
}

impl RoiSpec {
    /// The area drawn on a map in the file at `path` (`.kml`, `.kmz`,
    /// `.geojson`, `.json`; [`GeoPolygon::load`]), the polygon named `name`
    /// when the file holds several, as a prism over `heights` (ENU metres,
    /// min <= max) or over every height of the mesh: what `vpctl plan
    /// --roi-polygon` and Python's `roi_polygon=` both build.
    pub fn from_area_file(
        path: &std::path::Path,
        name: Option<&str>,
        heights: Option<(f64, f64)>,
    ) -> Result<RoiSpec> {
        if let Some((lo, hi)) = heights {
            if !(lo.is_finite() && hi.is_finite() && lo <= hi) {
                return Err(PlannerError::Input(format!(
                    "area heights {lo},{hi}: expected finite MIN,MAX (metres in the plan's \
                     frame) with MIN <= MAX"
                )));
            }
        }
        Ok(RoiSpec::Geographic {
            polygon: GeoPolygon::load(path, name)?,
            heights,
        })
    }

    /// The region in the mesh's frame: a [`RoiSpec::Geographic`] area placed
    /// through the plan's geodetic `origin` (refused without one, or when it
    /// misses the mesh's ground extent); any other region as it is.
    pub fn resolve(&self, mesh: &Mesh, origin: Option<GeodeticOrigin>) -> Result<RoiSpec> {
        let RoiSpec::Geographic { polygon, heights } = self else {
            return Ok(self.clone());
        };
        let file = polygon.source.display();
        let Some(origin) = origin else {
            return Err(PlannerError::Input(format!(
                "{file}: the area is in latitude/longitude, and the plan has no geodetic origin \
                 to place it: plan on a model aligned by `vpctl colmap align --colmap DIR \
                 --positions positions.csv --out DIR` (its frame.json), or pass --origin LAT,LON,ALT"
            )));
        };
        let b = mesh.bounds();
        let (z_min, z_max) = heights.unwrap_or((b.min.z - 1.0, b.max.z + 1.0));
        let roi = polygon.to_roi(origin, z_min, z_max)?;
        if let Roi::Polygon { polygon: xy, .. } = &roi {
            let mut p = Aabb::empty();
            for [x, y] in xy {
                p.grow(&Point3::new(*x, *y, 0.0));
            }
            if p.max.x < b.min.x || p.min.x > b.max.x || p.max.y < b.min.y || p.min.y > b.max.y {
                return Err(PlannerError::Input(format!(
                    "{file}: the area (x {:.1}..{:.1}, y {:.1}..{:.1} m from the origin) does \
                     not overlap the model (x {:.1}..{:.1}, y {:.1}..{:.1} m): draw it over the \
                     site the model covers",
                    p.min.x, p.max.x, p.min.y, p.max.y, b.min.x, b.max.x, b.min.y, b.max.y
                )));
            }
        }
        Ok(RoiSpec::Region(roi))
    }

    /// The faces of `mesh` the region selects (`caster` built from `mesh`,
    /// `origin` the plan's, for a geographic area); an empty selection or a
    /// face index out of range is an input error.
    pub fn faces(
        &self,
        mesh: &Mesh,
        caster: &RayCaster,
        origin: Option<GeodeticOrigin>,
    ) -> Result<Vec<u32>> {
        let faces = match self {
            RoiSpec::Geographic { polygon, .. } => {
                let resolved = self.resolve(mesh, origin)?;
                return resolved.faces(mesh, caster, origin).map_err(|e| match e {
                    PlannerError::Input(_) => PlannerError::Input(format!(
                        "{}: the area holds no face of the mesh (no face centroid inside the \
                         polygon and its height range): draw it over the part of the site the \
                         model covers",
                        polygon.source.display()
                    )),
                    e => e,
                });
            }
            RoiSpec::All => (0..mesh.n_faces() as u32).collect(),
            RoiSpec::Faces(f) => {
                if let Some(bad) = f.iter().find(|&&f| f as usize >= mesh.n_faces()) {
                    return Err(PlannerError::Input(format!(
                        "region of interest: face {bad} does not exist (the mesh has {} faces)",
                        mesh.n_faces()
                    )));
                }
                f.clone()
            }
            RoiSpec::Region(r) => r.select(mesh, caster)?,
        };
        if faces.is_empty() {
            return Err(PlannerError::Input(
                "the region of interest selects no face of the mesh (empty, or outside the mesh)"
                    .into(),
            ));
        }
        Ok(faces)
    }
}
