//! Trees: trunks and branches as tubes, canopies as clouds of small
//! irregular leaves in leaf clusters, so that views (and rays) pass through
//! the gaps as they do through real foliage.

use nalgebra::{Point3, Vector3};
use rand::Rng;
use rand_chacha::ChaCha8Rng;
use serde::{Deserialize, Serialize};

use super::rock::Rock;
use super::shapes::cylinder;
use super::terrain::TerrainGrid;
use super::Builder;
use crate::error::{Result, SceneError};
use crate::mesh::Material;

/// One-sided leaf area per square metre of canopy footprint (a leaf area
/// index). With clumped, outward-tilted leaves a vertical view through the
/// canopy still finds a good share of gaps.
pub(crate) const LEAF_AREA_INDEX: f64 = 1.5;
/// Sides of a trunk tube.
const TRUNK_SIDES: usize = 8;
/// Rings of quads along a trunk.
const TRUNK_SEGMENTS: usize = 3;
/// Branches per tree.
const BRANCHES: usize = 5;
/// Sides of a branch tube (one ring of quads).
const BRANCH_SIDES: usize = 5;
/// Trunk buried below the ground so it joins the terrain.
const TRUNK_BURY: f64 = 0.3;

/// Faces of a tree that do not depend on the face budget: trunk and branches.
pub(crate) const WOOD_FACES: usize = 2 * TRUNK_SIDES * TRUNK_SEGMENTS + BRANCHES * 2 * BRANCH_SIDES;

/// Where a tree stands and how big it is.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct TreeInfo {
    /// Trunk position (x, y) at the ground, metres.
    pub position: [f64; 2],
    /// Trunk radius at the ground, metres.
    pub trunk_radius: f64,
    /// Height of the canopy centre above the ground, metres.
    pub canopy_height: f64,
    /// Canopy ellipsoid semi-axes (x, y, z), metres.
    pub canopy_radii: [f64; 3],
}

impl TreeInfo {
    /// Random tree dimensions at (x, y).
    pub(crate) fn random(rng: &mut ChaCha8Rng, x: f64, y: f64) -> Self {
        let rx = rng.random_range(1.8..3.2);
        let ry = rx * rng.random_range(0.8..1.2);
        let rz = rng.random_range(1.5..3.0);
        let trunk = rng.random_range(2.0..4.0); // clear trunk below the canopy
        TreeInfo {
            position: [x, y],
            trunk_radius: rng.random_range(0.12..0.25),
            canopy_height: trunk + rz,
            canopy_radii: [rx, ry, rz],
        }
    }

    /// Largest horizontal canopy radius.
    pub fn reach(&self) -> f64 {
        self.canopy_radii[0].max(self.canopy_radii[1])
    }

    /// Canopy footprint area (ellipse), square metres.
    pub fn footprint_area(&self) -> f64 {
        std::f64::consts::PI * self.canopy_radii[0] * self.canopy_radii[1]
    }
}

/// Places `n_at_rock` trees fringing the rock, then `n` trees in the open,
/// all inside the square |x|, |y| <= `half` with their canopies inside it,
/// 1 m from every marker's canopy-free circle and not overlapping each other
/// by much (trunk distance >= 0.8 x the sum of reaches).
///
/// Trees in the open stand at least 2 m (plus canopy reach) from the rock's
/// nominal outline. Trees at the rock stand 0.5 to 2 m outside it, so their
/// canopies overhang its edge and the ground around it, as around the
/// paper's rock: what is under them a nadir flight cannot see. They draw
/// from `rng_at_rock`, so sites without them keep their bytes.
pub(crate) fn place_trees(
    rng: &mut ChaCha8Rng,
    rng_at_rock: &mut ChaCha8Rng,
    (n, n_at_rock): (usize, usize),
    half: f64,
    rock: &Rock,
    markers: &[(f64, f64)],
) -> Result<Vec<TreeInfo>> {
    let mut trees: Vec<TreeInfo> = Vec::with_capacity(n_at_rock + n);
    let fits = |t: &TreeInfo, trees: &[TreeInfo]| {
        let [x, y] = t.position;
        let reach = t.reach();
        let inside = x.abs() + reach + 0.5 <= half && y.abs() + reach + 0.5 <= half;
        let clear_of_markers = markers
            .iter()
            .all(|&(mx, my)| (mx - x).hypot(my - y) > reach + 1.0);
        let clear_of_trees = trees
            .iter()
            .all(|o| (o.position[0] - x).hypot(o.position[1] - y) > 0.8 * (reach + o.reach()));
        inside && clear_of_markers && clear_of_trees
    };
    let mut place = |rng: &mut ChaCha8Rng,
                     count: usize,
                     what: &str,
                     candidate: &dyn Fn(&mut ChaCha8Rng) -> Option<TreeInfo>|
     -> Result<()> {
        let goal = trees.len() + count;
        let max_attempts = 500 * count + 1000;
        let mut attempts = 0;
        while trees.len() < goal {
            attempts += 1;
            if attempts > max_attempts {
                return Err(SceneError::InvalidArgument(format!(
                    "could place only {} of {count} {what}: the site is too crowded",
                    count + trees.len() - goal
                )));
            }
            if let Some(t) = candidate(rng).filter(|t| fits(t, &trees)) {
                trees.push(t);
            }
        }
        Ok(())
    };
    place(rng_at_rock, n_at_rock, "trees at the rock", &|rng| {
        let angle = rng.random_range(0.0..std::f64::consts::TAU);
        let (x, y) = rock.ring_point(angle, rng.random_range(0.5..2.0));
        Some(TreeInfo::random(rng, x, y))
    })?;
    place(rng, n, "trees", &|rng| {
        let (x, y) = (rng.random_range(-half..half), rng.random_range(-half..half));
        let t = TreeInfo::random(rng, x, y);
        (rock.ellipse_r(x, y, t.reach() + 2.0) > 1.0).then_some(t)
    })?;
    Ok(trees)
}

/// Uniform random direction (rejection from the cube: exact and seeded).
fn unit_vector(rng: &mut ChaCha8Rng) -> Vector3<f64> {
    loop {
        let v: Vector3<f64> = Vector3::new(
            rng.random_range(-1.0..1.0),
            rng.random_range(-1.0..1.0),
            rng.random_range(-1.0..1.0),
        );
        let n = v.norm_squared();
        if n > 1e-4 && n <= 1.0 {
            return v / n.sqrt();
        }
    }
}

/// Trunk, branches and `leaf_faces` leaf faces of one tree.
pub(crate) fn tree_mesh(
    tree: &TreeInfo,
    leaf_faces: usize,
    ground: &TerrainGrid,
    rng: &mut ChaCha8Rng,
) -> Builder {
    let mut out = Builder::default();
    let [x, y] = tree.position;
    let z0 = ground.height(x, y);
    let centre = Point3::new(x, y, z0 + tree.canopy_height);
    let r = tree.trunk_radius;
    let trunk = cylinder(
        Point3::new(x, y, z0 - TRUNK_BURY),
        centre,
        r,
        0.55 * r,
        TRUNK_SIDES,
        TRUNK_SEGMENTS,
    );
    out.append(&trunk, Material::Tree);
    let [rx, ry, rz] = tree.canopy_radii;
    let phase = rng.random_range(0.0..std::f64::consts::TAU);
    for k in 0..BRANCHES {
        let a = phase
            + std::f64::consts::TAU * k as f64 / BRANCHES as f64
            + rng.random_range(-0.4..0.4);
        let from = Point3::new(x, y, centre.z - rz * rng.random_range(0.2..0.6));
        let to = from
            + Vector3::new(
                0.65 * rx * a.cos(),
                0.65 * ry * a.sin(),
                rz * rng.random_range(0.2..0.6),
            );
        let branch = cylinder(from, to, 0.35 * r, 0.12 * r, BRANCH_SIDES, 1);
        out.append(&branch, Material::Tree);
    }
    leaves(&mut out, tree, centre, leaf_faces, rng);
    out
}

/// Leaves in clusters (twigs) inside the canopy ellipsoid. Each leaf is a
/// jittered triangle or a jittered quad (two faces) tilted outward, sized so
/// the total leaf area is `LEAF_AREA_INDEX` times the canopy footprint.
fn leaves(
    out: &mut Builder,
    tree: &TreeInfo,
    centre: Point3<f64>,
    n_faces: usize,
    rng: &mut ChaCha8Rng,
) {
    if n_faces == 0 {
        return;
    }
    let radii = Vector3::from(tree.canopy_radii);
    let face_area = LEAF_AREA_INDEX * tree.footprint_area() / n_faces as f64;
    let n_clusters = rng.random_range(40..=70usize);
    let cluster_r = 0.22 * radii.min();
    // Cluster centres in the outer part of the canopy, far enough inside the
    // ellipsoid that their leaves stay within it.
    let clusters: Vec<Vector3<f64>> = (0..n_clusters)
        .map(|_| {
            let rho = 0.35 + 0.4 * rng.random::<f64>().cbrt();
            unit_vector(rng).component_mul(&radii) * rho
        })
        .collect();
    let mut made = 0;
    let mut k = 0;
    while made < n_faces {
        let c = clusters[k % n_clusters];
        k += 1;
        let offset = unit_vector(rng) * cluster_r * rng.random::<f64>().cbrt();
        let local = c + offset;
        let outward = local
            .component_div(&radii.component_mul(&radii))
            .normalize();
        let n = (unit_vector(rng) + outward * 0.8).normalize();
        let n = if n.norm_squared() > 0.5 { n } else { outward };
        let t1 = n.cross(&unit_vector_not_parallel(&n)).normalize();
        let t2 = n.cross(&t1);
        let quad = n_faces - made >= 2 && rng.random::<bool>();
        let corners = if quad { 4 } else { 3 };
        // Circumradius from the per-face area: a regular triangle of radius s
        // has area 1.30 s^2, a square of radius s has 2 s^2 over two faces.
        let s = if quad {
            face_area.sqrt()
        } else {
            (face_area / 1.299).sqrt()
        };
        let phase = rng.random_range(0.0..std::f64::consts::TAU);
        let step = std::f64::consts::TAU / corners as f64;
        let p0 = centre + local;
        let pts: Vec<Point3<f64>> = (0..corners)
            .map(|i| {
                let a = phase + step * i as f64 + rng.random_range(-0.2..0.2) * step;
                let rr = s * rng.random_range(0.75..1.25);
                p0 + (t1 * a.cos() + t2 * a.sin()) * rr
            })
            .collect();
        let base = out.vertex(pts[0]);
        for p in &pts[1..] {
            out.vertex(*p);
        }
        // t1 x t2 = n: increasing angles run counter-clockwise about n.
        out.face([base, base + 1, base + 2], Material::Tree);
        if quad {
            out.face([base, base + 2, base + 3], Material::Tree);
        }
        made += if quad { 2 } else { 1 };
    }
}

fn unit_vector_not_parallel(n: &Vector3<f64>) -> Vector3<f64> {
    if n.x.abs() < 0.9 {
        Vector3::x()
    } else {
        Vector3::y()
    }
}

#[cfg(test)]
mod tests {
    use super::super::terrain::Terrain;
    use super::*;
    use rand::SeedableRng;

    #[test]
    fn tree_has_wood_and_exact_leaf_count_inside_canopy() {
        let t = Terrain::new(2);
        let g = TerrainGrid::new(&t, 20.0, 40, 40);
        let mut rng = ChaCha8Rng::seed_from_u64(1);
        let tree = TreeInfo::random(&mut rng, 3.0, -4.0);
        let b = tree_mesh(&tree, 1001, &g, &mut rng);
        assert_eq!(b.n_faces(), WOOD_FACES + 1001);
        let m = b.finish();
        m.validate().unwrap();
        let z0 = g.height(3.0, -4.0);
        let c = Point3::new(3.0, -4.0, z0 + tree.canopy_height);
        let r = Vector3::from(tree.canopy_radii);
        for f in WOOD_FACES..m.n_faces() {
            for p in m.triangle(f) {
                let q = (p - c).component_div(&r);
                assert!(
                    q.norm() < 1.15,
                    "leaf vertex outside the canopy: {}",
                    q.norm()
                );
            }
        }
        // Leaf area as designed.
        let area: f64 = (WOOD_FACES..m.n_faces()).map(|f| m.face_area(f)).sum();
        let want = LEAF_AREA_INDEX * tree.footprint_area();
        assert!(
            (area / want - 1.0).abs() < 0.15,
            "leaf area {area} vs {want}"
        );
    }
}
