//! M2: surrogate cameras in free space, linked to the triangles they can see
//! by inverse visibility (the triangles look for surrogates).

use nalgebra::{Point3, Vector3};
use rand::Rng;
use rand_chacha::ChaCha8Rng;
use rayon::prelude::*;
use vp_scene::raycast::{RayCaster, FACE_VISIBILITY_EPSILON};
use vp_scene::Mesh;

use crate::error::{PlannerError, Result};
use crate::safety::Safety;

/// Draws up to `n` positions uniformly in the flight volume (cut to the
/// altitude band and the geofence) that are in free space at the safety
/// distance. Gives up after `200 n` draws; fails when none was found.
pub fn sample_positions(
    safety: &Safety,
    caster: &RayCaster,
    mesh: &Mesh,
    n: usize,
    rng: &mut ChaCha8Rng,
) -> Result<Vec<Point3<f64>>> {
    let b = safety.sampling_box();
    if !(b.min.z < b.max.z) {
        return Err(PlannerError::Input(format!(
            "the flight volume z range [{}, {}] and the altitude limits [{}, {}] do not overlap",
            safety.volume.min.z, safety.volume.max.z, safety.altitude.min_m, safety.altitude.max_m
        )));
    }
    // Draw in batches (deterministic: the draws do not depend on threads),
    // test them in parallel.
    let batch = n.max(256);
    let max_draws = n.saturating_mul(200);
    let mut out = Vec::with_capacity(n);
    let mut drawn = 0;
    while out.len() < n && drawn < max_draws {
        let cands: Vec<Point3<f64>> = (0..batch)
            .map(|_| {
                Point3::new(
                    rng.random_range(b.min.x..=b.max.x),
                    rng.random_range(b.min.y..=b.max.y),
                    rng.random_range(b.min.z..=b.max.z),
                )
            })
            .collect();
        drawn += batch;
        let ok: Vec<bool> = cands
            .par_iter()
            .map(|p| safety.in_free_space(p, caster, mesh))
            .collect();
        out.extend(
            cands
                .into_iter()
                .zip(ok)
                .filter(|x| x.1)
                .map(|x| x.0)
                .take(n - out.len()),
        );
    }
    if out.is_empty() {
        return Err(PlannerError::Input(format!(
            "no position in the flight volume {:?}..{:?} keeps the safety distance of {} m \
             to the mesh ({} random draws): lower the safety distance or enlarge the volume",
            <[f64; 3]>::from(b.min),
            <[f64; 3]>::from(b.max),
            safety.distance,
            drawn
        )));
    }
    Ok(out)
}

/// An orthonormal basis (e1, e2) perpendicular to unit `n`.
pub fn basis(n: &Vector3<f64>) -> (Vector3<f64>, Vector3<f64>) {
    let helper = if n.x.abs() < 0.9 {
        Vector3::x()
    } else {
        Vector3::y()
    };
    let e1 = n.cross(&helper).normalize();
    (e1, n.cross(&e1))
}

/// Inverse visibility: for every triangle (centroid, unit normal), the
/// surrogates inside its virtual camera's square frustum of full opening
/// angle `fov_deg` along the normal that are not occluded. Frustum culling
/// comes first, so only surrogates inside it cost a segment test.
/// Returns, per surrogate, the indices of the triangles linked to it (ascending).
pub fn link(
    surrogates: &[Point3<f64>],
    triangles: &[(Point3<f64>, Vector3<f64>)],
    fov_deg: f64,
    caster: &RayCaster,
) -> Vec<Vec<u32>> {
    link_valued(surrogates, triangles, fov_deg, caster, |_, _| Some(())).0
}

/// [`link`], keeping only the links for which `value(surrogate, triangle)`
/// (indices) is `Some`, returned per surrogate alongside the links.
///
/// # Performance
/// `value` runs after the frustum test and before the segment test, so a
/// link the caller has no use for costs no ray.
pub fn link_valued<V: Send>(
    surrogates: &[Point3<f64>],
    triangles: &[(Point3<f64>, Vector3<f64>)],
    fov_deg: f64,
    caster: &RayCaster,
    value: impl Fn(usize, usize) -> Option<V> + Sync,
) -> (Vec<Vec<u32>>, Vec<Vec<V>>) {
    let tan = (0.5 * fov_deg).to_radians().tan();
    let per_tri: Vec<Vec<(u32, V)>> = triangles
        .par_iter()
        .enumerate()
        .map(|(t, (c, n))| {
            let (e1, e2) = basis(n);
            let origin = c + n * FACE_VISIBILITY_EPSILON;
            surrogates
                .iter()
                .enumerate()
                .filter(|(_, s)| {
                    let v = *s - c;
                    let z = v.dot(n);
                    z > 0.0 && v.dot(&e1).abs() <= z * tan && v.dot(&e2).abs() <= z * tan
                })
                .filter_map(|(i, s)| {
                    let v = value(i, t)?;
                    (!caster.occluded(&origin, s)).then_some((i as u32, v))
                })
                .collect()
        })
        .collect();
    let mut links: Vec<Vec<u32>> = (0..surrogates.len()).map(|_| Vec::new()).collect();
    let mut values: Vec<Vec<V>> = (0..surrogates.len()).map(|_| Vec::new()).collect();
    for (t, ss) in per_tri.into_iter().enumerate() {
        for (s, v) in ss {
            links[s as usize].push(t as u32);
            values[s as usize].push(v);
        }
    }
    (links, values)
}

#[cfg(test)]
mod tests {
    use super::*;
    use vp_scene::procedural::shapes;

    #[test]
    fn links_respect_frustum_and_occlusion() {
        // Ground plane and a wall at x = 5 between a triangle at the origin
        // and surrogates beyond it.
        let mut mesh = shapes::plane(40.0, 40.0, 8, 8);
        let wall = shapes::box_mesh(Point3::new(5.0, -20.0, 0.0), Point3::new(6.0, 20.0, 30.0));
        mesh.append(&wall);
        let caster = RayCaster::new(&mesh);
        let tri = (Point3::new(0.0, 0.0, 0.0), Vector3::z());
        let surrogates = [
            Point3::new(0.0, 0.0, 10.0),  // straight above: linked
            Point3::new(10.0, 0.0, 10.0), // behind the wall: occluded
            Point3::new(-30.0, 0.0, 5.0), // outside the 120 deg frustum
            Point3::new(-5.0, 0.0, 5.0),  // 45 deg off the normal: linked
        ];
        let links = link(&surrogates, &[tri], 120.0, &caster);
        assert_eq!(links, vec![vec![0], vec![], vec![], vec![0]]);
    }
}
