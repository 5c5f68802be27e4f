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
            "no position in the flight volume {:?}..{:?} keeps the clearance of {:.2} m to \
             the mesh ({} random draws; the clearance is the safety distance plus the position \
             margin, whose parts `vpctl plan` prints): lower safety_distance_m, give a more \
             precise position class (`[safety] gnss = \"rtk\"` for a model aligned to RTK \
             positions), or enlarge the volume",
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
/// link the caller has no use for costs no ray. [`LazyLinks`] defers the
/// segment tests further, until a caller needs their answer.
pub fn link_valued<V: Send>(
    surrogates: &[Point3<f64>],
    triangles: &[(Point3<f64>, Vector3<f64>)],
    fov_deg: f64,
    caster: &RayCaster,
    value: impl Fn(usize, usize) -> Option<V> + Sync,
) -> (Vec<Vec<u32>>, Vec<Vec<V>>) {
    let per_tri = in_frustum(surrogates, triangles, fov_deg, |s, t| {
        let v = value(s, t)?;
        let origin = segment_origin(&triangles[t]);
        (!caster.occluded(&origin, &surrogates[s])).then_some(v)
    });
    per_surrogate(surrogates.len(), per_tri)
}

/// Where the segment test of a link starts: the centroid, lifted along
/// the normal (the M1 visibility rule).
fn segment_origin((c, n): &(Point3<f64>, Vector3<f64>)) -> Point3<f64> {
    c + n * FACE_VISIBILITY_EPSILON
}

/// Per triangle, the surrogates (ascending) inside its virtual camera's
/// frustum for which `keep(surrogate, triangle)` is `Some`.
fn in_frustum<V: Send>(
    surrogates: &[Point3<f64>],
    triangles: &[(Point3<f64>, Vector3<f64>)],
    fov_deg: f64,
    keep: impl Fn(usize, usize) -> Option<V> + Sync,
) -> Vec<Vec<(u32, V)>> {
    let tan = (0.5 * fov_deg).to_radians().tan();
    triangles
        .par_iter()
        .enumerate()
        .map(|(t, (c, n))| {
            let (e1, e2) = basis(n);
            surrogates
                .iter()
                .enumerate()
                .filter(|(_, s)| {
                    let v = *s - c;
                    let z = v.dot(n);
                    z > 0.0 && v.dot(&e1).abs() <= z * tan && v.dot(&e2).abs() <= z * tan
                })
                .filter_map(|(i, _)| Some((i as u32, keep(i, t)?)))
                .collect()
        })
        .collect()
}

/// Per-triangle lists turned into per-surrogate lists of triangles
/// (ascending) and values.
fn per_surrogate<V>(n: usize, per_tri: Vec<Vec<(u32, V)>>) -> (Vec<Vec<u32>>, Vec<Vec<V>>) {
    let mut links: Vec<Vec<u32>> = (0..n).map(|_| Vec::new()).collect();
    let mut values: Vec<Vec<V>> = (0..n).map(|_| Vec::new()).collect();
    for (t, ss) in per_tri.into_iter().enumerate() {
        for (s, v) in ss {
            links[s as usize].push(t as u32);
            values[s as usize].push(v);
        }
    }
    (links, values)
}

/// The links of [`link_valued`] with their segment tests deferred: the
/// candidates (inside the frustum, with a value) are found up front, and a
/// candidate's segment is tested only when [`LazyLinks::resolve`] asks for
/// it. Once every candidate is resolved, the visible ones are exactly the
/// links of [`link_valued`] (tested).
///
/// # Performance
/// M3 needs the answer only for links that still carry a potential gain,
/// of surrogates whose summed gain could still matter: on the paper's
/// parameters about a tenth of the 780k candidate segments.
pub struct LazyLinks {
    /// Per surrogate: candidate triangles (indices, ascending).
    triangles: Vec<Vec<u32>>,
    /// Per surrogate: the value of each candidate.
    values: Vec<Vec<f64>>,
    /// Per surrogate: whether each candidate's segment is clear (a link),
    /// `None` until tested.
    seen: Vec<Vec<Option<bool>>>,
    /// Per triangle: where its segments start.
    origins: Vec<Point3<f64>>,
    /// The surrogate positions.
    surrogates: Vec<Point3<f64>>,
}

impl LazyLinks {
    /// The candidates of [`link_valued`]: frustum test and `value`, no ray.
    pub fn new(
        surrogates: &[Point3<f64>],
        triangles: &[(Point3<f64>, Vector3<f64>)],
        fov_deg: f64,
        value: impl Fn(usize, usize) -> Option<f64> + Sync,
    ) -> Self {
        let per_tri = in_frustum(surrogates, triangles, fov_deg, value);
        let (tris, values) = per_surrogate(surrogates.len(), per_tri);
        LazyLinks {
            seen: tris.iter().map(|t| vec![None; t.len()]).collect(),
            triangles: tris,
            values,
            origins: triangles.iter().map(segment_origin).collect(),
            surrogates: surrogates.to_vec(),
        }
    }

    /// Number of surrogates.
    pub fn len(&self) -> usize {
        self.triangles.len()
    }

    /// True when there is no surrogate.
    pub fn is_empty(&self) -> bool {
        self.triangles.is_empty()
    }

    /// Candidate triangles of surrogate `s` (ascending) and their values.
    pub fn candidates(&self, s: usize) -> (&[u32], &[f64]) {
        (&self.triangles[s], &self.values[s])
    }

    /// Whether candidate `k` of surrogate `s` is a link: `None` until resolved.
    pub fn visible(&self, s: usize, k: usize) -> Option<bool> {
        self.seen[s][k]
    }

    /// Tests the segments of the unresolved candidates `k` of the
    /// surrogates `s` in `batch` for which `need(s, k)` holds, in parallel
    /// over the surrogates.
    pub fn resolve(
        &mut self,
        batch: &[usize],
        caster: &RayCaster,
        need: impl Fn(usize, usize) -> bool + Sync,
    ) {
        let me = &*self;
        let answers: Vec<Vec<(usize, bool)>> = batch
            .par_iter()
            .map(|&s| {
                let p = me.surrogates[s];
                (0..me.seen[s].len())
                    .filter(|&k| me.seen[s][k].is_none() && need(s, k))
                    .map(|k| {
                        let origin = &me.origins[me.triangles[s][k] as usize];
                        (k, !caster.occluded(origin, &p))
                    })
                    .collect()
            })
            .collect();
        for (&s, answers) in batch.iter().zip(answers) {
            for (k, clear) in answers {
                self.seen[s][k] = Some(clear);
            }
        }
    }

    /// Number of candidates of surrogate `s` not tested yet for which `need(k)` holds.
    pub fn unresolved(&self, s: usize, need: impl Fn(usize) -> bool) -> usize {
        (0..self.seen[s].len())
            .filter(|&k| self.seen[s][k].is_none() && need(k))
            .count()
    }

    /// Resolves every candidate; returns the links and values of
    /// [`link_valued`].
    pub fn resolve_all(&mut self, caster: &RayCaster) -> (Vec<Vec<u32>>, Vec<Vec<f64>>) {
        let all: Vec<usize> = (0..self.len()).collect();
        self.resolve(&all, caster, |_, _| true);
        (0..self.len())
            .map(|s| {
                let keep = |k: &usize| self.seen[s][*k] == Some(true);
                let n = self.triangles[s].len();
                (
                    (0..n).filter(keep).map(|k| self.triangles[s][k]).collect(),
                    (0..n).filter(keep).map(|k| self.values[s][k]).collect(),
                )
            })
            .unzip()
    }
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

    #[test]
    fn resolved_lazy_links_equal_the_eager_links() {
        let site = vp_scene::procedural::generate_site(&vp_scene::procedural::SiteParams {
            seed: 4,
            target_faces: 20_000,
            ..Default::default()
        })
        .unwrap();
        let caster = RayCaster::new(&site.mesh);
        let mesh = &site.mesh;
        let tris: Vec<_> = (0..mesh.n_faces())
            .step_by(97)
            .map(|f| (mesh.face_centroid(f), mesh.face_normal(f)))
            .collect();
        let b = site.flight_volume;
        let surrogates: Vec<Point3<f64>> = (0..400)
            .map(|i| {
                let u = |k: u32| f64::from((i * 7919 + k * 104_729) % 1000) / 1000.0;
                Point3::from(
                    b.min.coords + (b.max - b.min).component_mul(&Vector3::new(u(1), u(2), u(3))),
                )
            })
            .collect();
        let value =
            |s: usize, t: usize| (!(s + t).is_multiple_of(3)).then_some((s * 31 + t) as f64);
        let eager = link_valued(&surrogates, &tris, 120.0, &caster, value);
        let mut lazy = LazyLinks::new(&surrogates, &tris, 120.0, value);
        // Resolve part of it first: the order of resolution must not matter.
        let some: Vec<usize> = (0..lazy.len()).step_by(3).collect();
        lazy.resolve(&some, &caster, |s, k| (s + k) % 2 == 0);
        let links = lazy.resolve_all(&caster);
        assert!(eager.0.iter().map(Vec::len).sum::<usize>() > 1000);
        assert_eq!(links, eager);
    }
}
