//! Procedural scenes: test shapes and aerial sites with materials, deterministic by seed.
//!
//! - [`shapes`]: small meshes for unit tests ([`plane`], [`box_mesh`],
//!   [`sphere`], [`heightfield`], [`cylinder`]).
//! - [`generate_site`]: a rock-art site like the paper's Val Camonica
//!   experiments: terrain, one large smooth rock (the object of interest),
//!   trees with see-through canopies, grass tufts and flat markers on posts,
//!   every face tagged with its [`Material`].
//!
//! Determinism: every part draws from its own ChaCha8 stream derived from the
//! seed and a part constant (hashed, not XORed), so changing the number of trees
//! does not move the terrain; parallel work (rayon) only evaluates pure
//! functions per vertex or per tree and collects in order, so the output is
//! bit-identical for any thread count.

pub mod noise;
pub mod shapes;

mod grass;
mod markers;
mod meadow;
mod rock;
mod site;
mod terrain;
mod vegetation;

#[cfg(test)]
mod site_tests;

pub use markers::{MarkerInfo, MARKER_SIZE};
pub use noise::{Fbm, GradientNoise};
pub use rock::Rock;
pub use shapes::{box_mesh, cylinder, heightfield, plane, sphere, with_material};
pub use site::{
    generate_site, Site, SiteParams, SiteSummary, FLIGHT_CEILING, FLIGHT_FLOOR_CLEARANCE,
};
pub use terrain::{Terrain, TerrainGrid};
pub use vegetation::TreeInfo;

use nalgebra::Point3;
use rand::SeedableRng;
use rand_chacha::ChaCha8Rng;

use crate::hash::mix64;
use crate::mesh::{Material, Mesh};

pub use crate::plan::GeodeticOrigin;

/// Seed constants of the site's parts: one independent random stream each.
pub(crate) mod part {
    pub(crate) const TERRAIN: u64 = 0x7465_7272_6169_6e00;
    pub(crate) const ROCK: u64 = 0x726f_636b_0000_0000;
    pub(crate) const TREES: u64 = 0x7472_6565_7300_0000;
    pub(crate) const TREES_AT_ROCK: u64 = 0x726f_636b_7472_6565;
    pub(crate) const GRASS: u64 = 0x6772_6173_7300_0000;
    pub(crate) const MARKERS: u64 = 0x6d61_726b_6572_7300;
    pub(crate) const MEADOW: u64 = 0x6d65_6164_6f77_0000;
}

/// The seed of stream `index` of `part` for a site seed. Hashing (rather than
/// `seed ^ part ^ index`) keeps streams of different parts and indices apart.
pub(crate) fn part_seed(seed: u64, part: u64, index: u64) -> u64 {
    mix64(seed ^ mix64(part ^ mix64(index)))
}

/// A ChaCha8 stream for `index` of `part` (see [`part_seed`]).
pub(crate) fn part_rng(seed: u64, part: u64, index: u64) -> ChaCha8Rng {
    ChaCha8Rng::seed_from_u64(part_seed(seed, part, index))
}

/// Accumulates vertices and faces with materials; cheaper than repeated
/// [`Mesh::append`] and keeps materials always present.
#[derive(Debug, Default)]
pub(crate) struct Builder {
    pub vertices: Vec<Point3<f64>>,
    pub faces: Vec<[u32; 3]>,
    pub materials: Vec<Material>,
}

impl Builder {
    /// Adds a vertex and returns its index.
    pub(crate) fn vertex(&mut self, p: Point3<f64>) -> u32 {
        self.vertices.push(p);
        (self.vertices.len() - 1) as u32
    }

    /// Adds a face over existing vertex indices.
    pub(crate) fn face(&mut self, f: [u32; 3], m: Material) {
        self.faces.push(f);
        self.materials.push(m);
    }

    /// Adds a free triangle (three new vertices).
    pub(crate) fn triangle(&mut self, t: [Point3<f64>; 3], m: Material) {
        let a = self.vertex(t[0]);
        let b = self.vertex(t[1]);
        let c = self.vertex(t[2]);
        self.face([a, b, c], m);
    }

    /// Appends a mesh, giving all its faces material `m`.
    pub(crate) fn append(&mut self, mesh: &Mesh, m: Material) {
        let base = self.vertices.len() as u32;
        self.vertices.extend_from_slice(&mesh.vertices);
        self.faces
            .extend(mesh.faces.iter().map(|f| f.map(|i| i + base)));
        self.materials
            .extend(std::iter::repeat_n(m, mesh.faces.len()));
    }

    /// Appends another builder's geometry (indices shifted).
    pub(crate) fn extend(&mut self, other: Builder) {
        let base = self.vertices.len() as u32;
        self.vertices.extend(other.vertices);
        self.faces
            .extend(other.faces.into_iter().map(|f| f.map(|i| i + base)));
        self.materials.extend(other.materials);
    }

    /// Number of faces so far.
    #[cfg(test)]
    pub(crate) fn n_faces(&self) -> usize {
        self.faces.len()
    }

    /// The finished mesh (not validated: callers validate once at the end).
    pub(crate) fn finish(self) -> Mesh {
        Mesh {
            vertices: self.vertices,
            faces: self.faces,
            materials: Some(self.materials),
        }
    }
}

/// Keeps only the faces for which `keep` is true and drops the vertices no
/// kept face uses, preserving order (deterministic).
pub(crate) fn filter_faces(
    vertices: &[Point3<f64>],
    faces: &[[u32; 3]],
    keep: impl Fn(&[u32; 3]) -> bool,
) -> (Vec<Point3<f64>>, Vec<[u32; 3]>) {
    let mut remap = vec![u32::MAX; vertices.len()];
    let mut out_v = Vec::new();
    let mut out_f = Vec::new();
    for f in faces.iter().filter(|f| keep(f)) {
        out_f.push(f.map(|i| {
            let slot = &mut remap[i as usize];
            if *slot == u32::MAX {
                *slot = out_v.len() as u32;
                out_v.push(vertices[i as usize]);
            }
            *slot
        }));
    }
    (out_v, out_f)
}
