//! The site generator: terrain, rock, trees, grass and markers within a face
//! budget, deterministic by seed.
//!
//! Longer than most files because the budget split, the placement rules and
//! the parameter validation read as one story; the shapes themselves live in
//! the sibling modules.

use std::fmt;

use nalgebra::Point3;
use rand::Rng;
use rayon::prelude::*;
use serde::{Deserialize, Serialize};

use super::grass::{self, MEAN_BLADES};
use super::markers::{self, MarkerInfo, MARKER_FACES};
use super::meadow;
use super::noise::Fbm;
use super::rock::Rock;
use super::terrain::{fit_grid, Terrain, TerrainGrid};
use super::vegetation::{place_trees, tree_mesh, TreeInfo, WOOD_FACES};
use super::{part, part_rng, part_seed, Builder, GeodeticOrigin};
use crate::error::{Result, SceneError};
use crate::mesh::{Aabb, Material, Mesh};

/// Share of the face budget given to the rock, the object of interest: it
/// gets a much finer mesh than the terrain.
pub(super) const ROCK_SHARE: f64 = 0.25;
/// Share of the face budget given to tree leaves (if there are trees).
pub(super) const LEAF_SHARE: f64 = 0.22;
/// Share of the face budget given to grass when the tuft count is automatic.
pub(super) const GRASS_SHARE: f64 = 0.12;
/// The terrain takes what is left, but at least this share.
pub(super) const MIN_TERRAIN_SHARE: f64 = 0.1;
/// Smallest and largest supported face budgets.
const TARGET_RANGE: (usize, usize) = (5_000, 20_000_000);
/// Largest tree count accepted (placement is quadratic in it).
const MAX_TREES: usize = 2000;
/// Largest marker count accepted.
const MAX_MARKERS: usize = 500;
/// The flight volume's floor is this far above the highest point of ground
/// and rock (metres): nothing underground passes a distance-only clearance test.
pub const FLIGHT_FLOOR_CLEARANCE: f64 = 2.0;
/// The flight volume's ceiling is this far above the lowest ground point
/// (metres), above the paper's 50 m initial grid flight.
pub const FLIGHT_CEILING: f64 = 60.0;

/// Parameters of [`generate_site`]. Serialisable with defaults for missing
/// fields, so a config file may name only what it changes.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct SiteParams {
    /// Seed of every random choice.
    pub seed: u64,
    /// Face count to aim at (within about 10 %), 5k to 20M.
    pub target_faces: usize,
    /// Side of the square site, metres, centred on the origin.
    pub size: f64,
    /// Number of trees in the open, clear of the rock.
    pub n_trees: usize,
    /// Number of trees fringing the rock, their canopies overhanging its
    /// edge (none by default).
    pub n_trees_at_rock: usize,
    /// Number of grass tufts; `None` sizes grass to about 12 % of the faces.
    pub n_grass_tufts: Option<usize>,
    /// Share of the ground within 6 m of the rock's footprint box covered by
    /// a meadow, a dense carpet of grass blades (0 to 1, none by default).
    /// Its blades (about 1100 per square metre) come on top of
    /// `target_faces`.
    pub meadow: f64,
    /// Number of markers on posts around the rock.
    pub n_markers: usize,
    /// Rock footprint length along its long axis, metres.
    pub rock_length: f64,
    /// Rock footprint width, metres.
    pub rock_width: f64,
    /// Nominal rock height above the terrain, metres (the crest reaches about
    /// 1.45 times this).
    pub rock_height: f64,
    /// Direction of the rock's long axis, degrees counter-clockwise from east.
    pub rock_yaw_deg: f64,
    /// WGS84 position of the world origin.
    pub origin: GeodeticOrigin,
}

impl Default for SiteParams {
    /// A 60 m site with a 17 m x 13 m rock like the paper's Seradina rock,
    /// 6 trees, 6 markers, about 200k faces.
    fn default() -> Self {
        SiteParams {
            seed: 0,
            target_faces: 200_000,
            size: 60.0,
            n_trees: 6,
            n_trees_at_rock: 0,
            n_grass_tufts: None,
            meadow: 0.0,
            n_markers: 6,
            rock_length: 17.0,
            rock_width: 13.0,
            rock_height: 2.5,
            rock_yaw_deg: 0.0,
            origin: GeodeticOrigin::default(),
        }
    }
}

/// `vpctl scene generate --config`: the `[site]` section of a campaign
/// config; missing keys take [`SiteParams::default`].
impl crate::config_file::ConfigSection for SiteParams {
    type Error = SceneError;

    fn check(&self, place: &str) -> Result<()> {
        self.validate().map_err(|e| match e {
            SceneError::InvalidArgument(m) => SceneError::InvalidArgument(format!("{place}: {m}")),
            other => other,
        })
    }
}

impl SiteParams {
    /// Checks the ranges; the error names the parameter and its value.
    pub fn validate(&self) -> Result<()> {
        let bad = |msg: String| Err(SceneError::InvalidArgument(msg));
        let (lo, hi) = TARGET_RANGE;
        if !(lo..=hi).contains(&self.target_faces) {
            return bad(format!(
                "target_faces = {} is outside {lo}..={hi}",
                self.target_faces
            ));
        }
        for (name, v) in [
            ("rock_length", self.rock_length),
            ("rock_width", self.rock_width),
            ("rock_height", self.rock_height),
        ] {
            if !(v.is_finite() && (0.5..=200.0).contains(&v)) {
                return bad(format!("{name} = {v} m is outside 0.5..=200"));
            }
        }
        if self.rock_width > self.rock_length {
            return bad(format!(
                "rock_width = {} m exceeds rock_length = {} m",
                self.rock_width, self.rock_length
            ));
        }
        let min_size = self.rock_length + 20.0;
        if !(self.size.is_finite() && self.size >= min_size && self.size <= 5000.0) {
            return bad(format!(
                "size = {} m: must be between rock_length + 20 = {min_size} m and 5000 m",
                self.size
            ));
        }
        if self.n_trees.saturating_add(self.n_trees_at_rock) > MAX_TREES {
            return bad(format!(
                "n_trees + n_trees_at_rock = {} + {} exceeds {MAX_TREES}",
                self.n_trees, self.n_trees_at_rock
            ));
        }
        if self.n_markers > MAX_MARKERS {
            return bad(format!(
                "n_markers = {} exceeds {MAX_MARKERS}",
                self.n_markers
            ));
        }
        if let Some(n) = self.n_grass_tufts {
            // Each tuft has at least 5 blades: more cannot fit the budget.
            if n.saturating_mul(5) > self.target_faces {
                return bad(format!(
                    "n_grass_tufts = {n} needs more faces than target_faces = {}: raise \
                     target_faces or lower the counts",
                    self.target_faces
                ));
            }
        }
        if !(0.0..=1.0).contains(&self.meadow) {
            return bad(format!("meadow = {} is outside 0..=1", self.meadow));
        }
        if !self.rock_yaw_deg.is_finite() {
            return bad(format!(
                "rock_yaw_deg = {} is not finite",
                self.rock_yaw_deg
            ));
        }
        let o = &self.origin;
        if !((-90.0..=90.0).contains(&o.lat_deg)
            && (-180.0..=180.0).contains(&o.lon_deg)
            && o.alt_m.is_finite())
        {
            return bad(format!(
                "origin ({}, {}, {}) is not a valid latitude/longitude/altitude",
                o.lat_deg, o.lon_deg, o.alt_m
            ));
        }
        Ok(())
    }
}

/// A generated site.
#[derive(Debug, Clone)]
pub struct Site {
    /// The scene; every face has a material. Order: terrain, rock, trees
    /// (each: trunk, branches, leaves), grass tufts, markers (each: plate,
    /// post), the meadow's blades.
    pub mesh: Mesh,
    /// The parameters it was made from.
    pub params: SiteParams,
    /// Bounds of the rock's faces: the object of interest and a natural
    /// default region of interest.
    pub rock_bounds: Aabb,
    /// Where cameras may fly: the site square in x and y; z from
    /// [`FLIGHT_FLOOR_CLEARANCE`] above the highest ground or rock point to
    /// [`FLIGHT_CEILING`] above the lowest ground point. Trees reach into it:
    /// keeping clear of them is the clearance test's job.
    pub flight_volume: Aabb,
    /// WGS84 position of the world origin.
    pub origin: GeodeticOrigin,
    /// Analytic terrain the ground mesh samples.
    pub terrain: Terrain,
    /// The meshed ground (for heights above ground).
    pub ground: TerrainGrid,
    /// Analytic rock shape.
    pub rock: Rock,
    /// The trees, in mesh order.
    pub trees: Vec<TreeInfo>,
    /// The markers, in mesh order (usable as ground control points).
    pub markers: Vec<MarkerInfo>,
}

/// Face and vertex counts of a site, per material.
#[derive(Debug, Clone, PartialEq)]
pub struct SiteSummary {
    /// Total faces.
    pub n_faces: usize,
    /// Total vertices.
    pub n_vertices: usize,
    /// Faces per material, indexed by material id.
    pub faces_per_material: [usize; Material::ALL.len()],
    /// Size of the rock bounds (x, y, z), metres.
    pub rock_extent: [f64; 3],
    /// Number of trees.
    pub n_trees: usize,
    /// Number of markers.
    pub n_markers: usize,
}

impl fmt::Display for SiteSummary {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        writeln!(f, "faces {}, vertices {}", self.n_faces, self.n_vertices)?;
        for m in Material::ALL {
            let n = self.faces_per_material[m as usize];
            let share = 100.0 * n as f64 / self.n_faces.max(1) as f64;
            writeln!(f, "  {:<7} {n:>9} faces ({share:.1} %)", m.name())?;
        }
        let [x, y, z] = self.rock_extent;
        write!(
            f,
            "rock {x:.1} m x {y:.1} m x {z:.1} m, {} trees, {} markers",
            self.n_trees, self.n_markers
        )
    }
}

impl Site {
    /// Height of bare ground or rock at (x, y) (vegetation and markers
    /// ignored), from the meshes.
    pub fn surface_height(&self, x: f64, y: f64) -> f64 {
        let g = self.ground.height(x, y);
        let b = self.rock.bump(x, y) - super::rock::SINK;
        if b > 0.0 {
            g + b
        } else {
            g
        }
    }

    /// Counts per material and the rock's size.
    pub fn summary(&self) -> SiteSummary {
        let e = self.rock_bounds.extent();
        SiteSummary {
            n_faces: self.mesh.n_faces(),
            n_vertices: self.mesh.n_vertices(),
            faces_per_material: self.mesh.material_counts().unwrap_or_default(),
            rock_extent: [e.x, e.y, e.z],
            n_trees: self.trees.len(),
            n_markers: self.markers.len(),
        }
    }
}

/// Face counts of the parts, decided before any geometry is built.
struct Budget {
    rock: usize,
    leaves: Vec<usize>,
    terrain: usize,
}

/// Splits `total` over weights, rounding cumulatively so the parts sum to it.
fn split(total: usize, weights: &[f64]) -> Vec<usize> {
    let sum: f64 = weights.iter().sum();
    let mut acc = 0.0;
    let mut given = 0usize;
    weights
        .iter()
        .map(|w| {
            acc += w;
            let upto = if sum > 0.0 {
                (total as f64 * acc / sum).round() as usize
            } else {
                0
            };
            let n = upto - given;
            given = upto;
            n
        })
        .collect()
}

fn budget(p: &SiteParams, trees: &[TreeInfo], n_blades: usize) -> Result<Budget> {
    let target = p.target_faces as f64;
    let rock = (ROCK_SHARE * target).round() as usize;
    let leaf_total = if trees.is_empty() {
        0
    } else {
        (LEAF_SHARE * target).round() as usize
    };
    let areas: Vec<f64> = trees.iter().map(TreeInfo::footprint_area).collect();
    let leaves = split(leaf_total, &areas);
    let fixed =
        rock + leaf_total + trees.len() * WOOD_FACES + n_blades + p.n_markers * MARKER_FACES;
    let floor = (MIN_TERRAIN_SHARE * target) as usize;
    if fixed + floor > p.target_faces {
        return Err(SceneError::InvalidArgument(format!(
            "{} trees, {n_blades} grass blades and {} markers leave too few of {} faces for \
             the terrain: raise target_faces or lower the counts",
            trees.len(),
            p.n_markers,
            p.target_faces
        )));
    }
    Ok(Budget {
        rock,
        leaves,
        terrain: p.target_faces - fixed,
    })
}

/// Where markers, trees and grass go, decided in the plane before any
/// geometry: it fixes the face counts of everything but rock, leaves and
/// terrain.
struct Layout {
    /// Marker (x, y, yaw).
    spots: Vec<(f64, f64, f64)>,
    trees: Vec<TreeInfo>,
    /// The tufts' blades, within the face budget.
    blades: Vec<grass::Blade>,
    /// The meadow's blades, on top of it.
    meadow: Vec<grass::Blade>,
}

fn layout(params: &SiteParams, rock: &Rock) -> Result<Layout> {
    let seed = params.seed;
    let half = 0.5 * params.size;
    let spots = markers::place(
        &mut part_rng(seed, part::MARKERS, 0),
        rock,
        params.n_markers,
    );
    if let Some(&(x, y, _)) = spots
        .iter()
        .find(|s| s.0.abs() > half - 1.0 || s.1.abs() > half - 1.0)
    {
        return Err(SceneError::InvalidArgument(format!(
            "{} markers do not fit around the rock on a {} m site (one at ({x:.1}, {y:.1}))",
            params.n_markers, params.size
        )));
    }
    let marker_xy: Vec<(f64, f64)> = spots.iter().map(|s| (s.0, s.1)).collect();
    let trees = place_trees(
        &mut part_rng(seed, part::TREES, 0),
        &mut part_rng(seed, part::TREES_AT_ROCK, 0),
        (params.n_trees, params.n_trees_at_rock),
        half,
        rock,
        &marker_xy,
    )?;
    let n_tufts = params.n_grass_tufts.unwrap_or_else(|| {
        (GRASS_SHARE * params.target_faces as f64 / MEAN_BLADES as f64).round() as usize
    });
    let density = Fbm::new(part_seed(seed, part::GRASS, 1), 14.0, 1.0, 3);
    let bare = |x: f64, y: f64| {
        rock.bump(x, y) <= -0.3
            && !trees
                .iter()
                .any(|t| (t.position[0] - x).hypot(t.position[1] - y) < t.trunk_radius + 0.15)
            && !marker_xy
                .iter()
                .any(|&(mx, my)| (mx - x).hypot(my - y) < 0.3)
    };
    let blades = grass::plan(
        &mut part_rng(seed, part::GRASS, 0),
        &density,
        n_tufts,
        half,
        |x, y| !bare(x, y),
    )?;
    let meadow = meadow::plan(
        &mut part_rng(seed, part::MEADOW, 0),
        &Fbm::new(part_seed(seed, part::MEADOW, 1), 6.0, 1.0, 2),
        rock,
        params.meadow,
        half,
        bare,
    );
    Ok(Layout {
        spots,
        trees,
        blades,
        meadow,
    })
}

/// Generates the site of `params`: same parameters, bit-identical mesh,
/// whatever the thread count.
///
/// # Performance
/// Linear in the face count: about 0.4 s per million faces on 2 cores with
/// the dev profile (opt-level 1).
pub fn generate_site(params: &SiteParams) -> Result<Site> {
    params.validate()?;
    let seed = params.seed;
    let half = 0.5 * params.size;
    let terrain = Terrain::new(seed);
    let rock = Rock::new(
        seed,
        params.rock_length,
        params.rock_width,
        params.rock_height,
        params.rock_yaw_deg.to_radians(),
    );

    let Layout {
        spots,
        trees,
        blades,
        meadow,
    } = layout(params, &rock)?;
    let budget = budget(params, &trees, blades.len())?;

    // Terrain, then everything that stands on it.
    let (nx, ny) = fit_grid(half, budget.terrain, |x, y| rock.covers(x, y));
    let ground = TerrainGrid::new(&terrain, half, nx, ny);
    let mut out = Builder::default();
    let (v, f) = ground.mesh(|x, y| rock.covers(x, y));
    push(&mut out, v, f, Material::Ground);
    let (v, f) = rock.mesh(&ground, rock.fit_cell(budget.rock));
    let rock_start = out.vertices.len();
    push(&mut out, v, f, Material::Rock);
    let mut rock_bounds = Aabb::empty();
    for p in &out.vertices[rock_start..] {
        rock_bounds.grow(p);
    }

    let tree_meshes: Vec<Builder> = trees
        .par_iter()
        .zip(&budget.leaves)
        .enumerate()
        .map(|(i, (t, &n))| {
            tree_mesh(
                t,
                n,
                &ground,
                &mut part_rng(seed, part::TREES, i as u64 + 1),
            )
        })
        .collect();
    for b in tree_meshes {
        out.extend(b);
    }
    out.extend(grass::mesh(&blades, &ground));
    let mut heights = part_rng(seed, part::MARKERS, 1);
    let mut marker_infos = Vec::with_capacity(spots.len());
    for &(x, y, yaw) in &spots {
        let (info, b) = markers::marker(x, y, yaw, heights.random_range(0.4..0.8), &ground);
        marker_infos.push(info);
        out.extend(b);
    }
    out.extend(grass::mesh(&meadow, &ground));

    let mesh = out.finish();
    mesh.validate()?;
    let flight_volume = flight_volume(&mesh, half);
    Ok(Site {
        mesh,
        params: params.clone(),
        rock_bounds,
        flight_volume,
        origin: params.origin,
        terrain,
        ground,
        rock,
        trees,
        markers: marker_infos,
    })
}

fn push(out: &mut Builder, v: Vec<Point3<f64>>, f: Vec<[u32; 3]>, m: Material) {
    out.extend(Builder {
        materials: vec![m; f.len()],
        vertices: v,
        faces: f,
    });
}

/// See [`Site::flight_volume`].
fn flight_volume(mesh: &Mesh, half: f64) -> Aabb {
    let (mut low, mut high) = (f64::INFINITY, f64::NEG_INFINITY);
    let mats = mesh.materials.as_deref().unwrap_or_default();
    for (face, m) in mesh.faces.iter().zip(mats) {
        if matches!(m, Material::Ground | Material::Rock) {
            for &i in face {
                let z = mesh.vertices[i as usize].z;
                high = high.max(z);
                if *m == Material::Ground {
                    low = low.min(z);
                }
            }
        }
    }
    let floor = high + FLIGHT_FLOOR_CLEARANCE;
    Aabb {
        min: Point3::new(-half, -half, floor),
        max: Point3::new(half, half, (low + FLIGHT_CEILING).max(floor + 10.0)),
    }
}
