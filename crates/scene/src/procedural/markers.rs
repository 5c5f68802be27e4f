//! Flat square markers on posts, ringed around the rock like ground control
//! points. The plate (material Marker) is a thin closed box facing up; the
//! wooden post is material Tree (the closest material to wood).

use nalgebra::{Point3, Rotation3, Vector3};
use rand::Rng;
use rand_chacha::ChaCha8Rng;
use serde::{Deserialize, Serialize};

use super::rock::Rock;
use super::shapes::box_mesh;
use super::terrain::TerrainGrid;
use super::Builder;
use crate::mesh::{Material, Mesh};

/// Side of a marker plate, metres.
pub const MARKER_SIZE: f64 = 0.5;
/// Plate thickness, metres.
const PLATE_THICKNESS: f64 = 0.02;
/// Post cross-section side, metres.
const POST_SIDE: f64 = 0.06;
/// Post buried below the ground, metres.
const POST_BURY: f64 = 0.2;
/// Markers per ring around the rock; more markers go to wider rings.
const PER_RING: usize = 12;
/// Faces of one marker: plate box and post box.
pub(crate) const MARKER_FACES: usize = 24;

/// Where a marker is.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct MarkerInfo {
    /// Centre of the plate's top face (x, y, z), metres.
    pub center: [f64; 3],
    /// Rotation of the plate about z, radians.
    pub yaw: f64,
    /// Side of the square plate, metres.
    pub size: f64,
}

/// Marker positions (x, y) and yaws: rings around the rock, 1.5-3 m beyond
/// its nominal outline, evenly spread with jitter.
pub(crate) fn place(rng: &mut ChaCha8Rng, rock: &Rock, n: usize) -> Vec<(f64, f64, f64)> {
    (0..n)
        .map(|k| {
            let ring = k / PER_RING;
            let in_ring = (n - ring * PER_RING).min(PER_RING);
            let slot = (k % PER_RING) as f64;
            let step = std::f64::consts::TAU / in_ring as f64;
            let angle = (slot + rng.random_range(-0.25..0.25)) * step + 0.3 * ring as f64;
            let margin = 1.5 + 3.0 * ring as f64 + rng.random_range(0.0..1.5);
            let (x, y) = rock.ring_point(angle, margin);
            (x, y, rng.random_range(0.0..std::f64::consts::FRAC_PI_2))
        })
        .collect()
}

/// Box from `min` to `max` turned by `yaw` about the vertical through (x, y).
fn turned_box(min: Point3<f64>, max: Point3<f64>, x: f64, y: f64, yaw: f64) -> Mesh {
    let mut m = box_mesh(min, max);
    let r = Rotation3::from_axis_angle(&Vector3::z_axis(), yaw);
    let c = Vector3::new(x, y, 0.0);
    for p in &mut m.vertices {
        *p = r * (*p - c) + c;
    }
    m
}

/// Plate and post of a marker at (x, y) with the plate top `height` above
/// the ground; returns its info and geometry.
pub(crate) fn marker(
    x: f64,
    y: f64,
    yaw: f64,
    height: f64,
    ground: &TerrainGrid,
) -> (MarkerInfo, Builder) {
    let z0 = ground.height(x, y);
    let top = z0 + height;
    let h = 0.5 * MARKER_SIZE;
    let plate = turned_box(
        Point3::new(x - h, y - h, top - PLATE_THICKNESS),
        Point3::new(x + h, y + h, top),
        x,
        y,
        yaw,
    );
    let p = 0.5 * POST_SIDE;
    let post = turned_box(
        Point3::new(x - p, y - p, z0 - POST_BURY),
        Point3::new(x + p, y + p, top - PLATE_THICKNESS),
        x,
        y,
        yaw,
    );
    let mut out = Builder::default();
    out.append(&plate, Material::Marker);
    out.append(&post, Material::Tree);
    let info = MarkerInfo {
        center: [x, y, top],
        yaw,
        size: MARKER_SIZE,
    };
    (info, out)
}

#[cfg(test)]
mod tests {
    use super::super::terrain::Terrain;
    use super::*;
    use rand::SeedableRng;

    #[test]
    fn markers_ring_the_rock_outside_its_footprint() {
        let rock = Rock::new(1, 17.0, 13.0, 2.5, 0.3);
        let mut rng = ChaCha8Rng::seed_from_u64(2);
        let spots = place(&mut rng, &rock, 20);
        assert_eq!(spots.len(), 20);
        for &(x, y, _) in &spots {
            assert!(rock.bump(x, y) < -0.5, "marker on the rock at ({x}, {y})");
        }
        for (i, a) in spots.iter().enumerate() {
            for b in &spots[i + 1..] {
                assert!((a.0 - b.0).hypot(a.1 - b.1) > MARKER_SIZE * 1.5);
            }
        }
    }

    #[test]
    fn marker_plate_is_flat_square_and_up() {
        let g = TerrainGrid::new(&Terrain::new(3), 10.0, 10, 10);
        let (info, b) = marker(1.0, 2.0, 0.4, 0.6, &g);
        assert_eq!(b.n_faces(), MARKER_FACES);
        let m = b.finish();
        m.validate().unwrap();
        let top: Vec<usize> = (0..m.n_faces())
            .filter(|&f| m.material(f) == Some(Material::Marker) && m.face_normal(f).z > 0.99)
            .collect();
        let area: f64 = top.iter().map(|&f| m.face_area(f)).sum();
        assert!((area - MARKER_SIZE * MARKER_SIZE).abs() < 1e-9);
        assert!(top
            .iter()
            .all(|&f| (m.face_centroid(f).z - info.center[2]).abs() < 1e-9));
        assert!((info.center[2] - g.height(1.0, 2.0) - 0.6).abs() < 1e-12);
    }
}
