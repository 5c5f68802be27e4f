//! M1: quality fulfillment f(t) of sampled triangles of the region of interest.
//!
//! docs/design.md#m1-quality-fulfillment: split the ROI faces to
//! the mean edge length, draw N_t of them, find the cameras that see each,
//! and take f(t) as the best triplet of those cameras. The triplet maximum is
//! exact; [`best_triplet`] prunes with upper bounds and equals the plain
//! enumeration [`best_triplet_plain`] (tested).

use nalgebra::{Point3, Vector3};
use rand::seq::index;
use rand::Rng;
use rand_chacha::ChaCha8Rng;
use rayon::prelude::*;
use vp_scene::mesh_ops::{split_faces, submesh};
use vp_scene::raster::ConfidenceImage;
use vp_scene::raycast::RayCaster;
use vp_scene::{Camera, Mesh};

use crate::error::{PlannerError, Result};
use crate::quality::{CamTerm, ConfCurve, Requirements};

/// Best triplet of one triangle.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Best {
    /// The maximised value (f, or q when no confidence is used).
    pub value: f64,
    /// q = alpha f_res + (1 - alpha) f_unc of that triplet.
    pub q: f64,
    /// f_conf of that triplet (1 when no confidence is used).
    pub conf: f64,
    /// Indices (into the term list) of the triplet, ascending.
    pub triplet: [usize; 3],
}

fn eval(terms: &[CamTerm], t: [usize; 3], conf: Option<&ConfCurve>, req: &Requirements) -> Best {
    let (a, b, c) = (&terms[t[0]], &terms[t[1]], &terms[t[2]]);
    let (value, q, conf) = if let Some(curve) = conf {
        req.fulfillment(a, b, c, curve)
    } else {
        let q = req.quality(a, b, c);
        (q * 1.0, q, 1.0)
    };
    Best {
        value,
        q,
        conf,
        triplet: t,
    }
}

/// Plain enumeration of every triplet: the reference for [`best_triplet`].
pub fn best_triplet_plain(
    terms: &[CamTerm],
    conf: Option<&ConfCurve>,
    req: &Requirements,
) -> Option<Best> {
    let n = terms.len();
    let mut best: Option<Best> = None;
    for i in 0..n {
        for j in i + 1..n {
            for k in j + 1..n {
                let b = eval(terms, [i, j, k], conf, req);
                if best.is_none_or(|x| b.value > x.value) {
                    best = Some(b);
                }
            }
        }
    }
    best
}

/// The triplet maximising `q * f_conf(angle)` (or `q` when `conf` is
/// `None`), with pruning that never changes the maximum value.
///
/// Cameras are visited by decreasing r_i, so the third camera of a triplet
/// is its coarsest and fixes f_res. A triplet is skipped when its upper bound
/// `(alpha f_res + (1 - alpha) f_unc_bound) * max f_conf` cannot beat the best
/// value found; f_unc_bound uses Weyl's inequality (the smallest eigenvalue of
/// a sum of three rank-2 informations is at most the sum of the largest
/// eigenvalues of two of them), and where that does not prune, with the
/// Rayleigh quotient bound of [`Requirements::f_unc_bound_triplet`]. Once
/// even the f_res bound fails, no later triplet can win and the search ends.
///
/// # Performance
/// Plain enumeration is cubic in the number of observing cameras; with
/// saturating resolution the bound stops the search after the first triplet
/// that reaches the confidence maximum.
pub fn best_triplet(
    terms: &[CamTerm],
    conf: Option<&ConfCurve>,
    req: &Requirements,
) -> Option<Best> {
    let n = terms.len();
    if n < 3 {
        return None;
    }
    let mut order: Vec<usize> = (0..n).collect();
    order.sort_by(|&a, &b| terms[b].r.total_cmp(&terms[a].r).then(a.cmp(&b)));
    let conf_max = conf.map_or(1.0, ConfCurve::max);
    // Relative slack so round-off in the bounds never prunes a winner.
    let slack = 1.0 + 1e-9;
    let mut best: Option<Best> = None;
    let beats = |bound: f64, best: &Option<Best>| best.is_none_or(|b| bound * slack > b.value);
    for kk in 2..n {
        let k = order[kk];
        let f_res = req.f_res(terms[k].r);
        let bound_k = (req.alpha * f_res + (1.0 - req.alpha)) * conf_max;
        if !beats(bound_k, &best) {
            break;
        }
        for jj in 1..kk {
            let j = order[jj];
            for &i in &order[..jj] {
                let (li, lj, lk) = (terms[i].info_max, terms[j].info_max, terms[k].info_max);
                let lmin = (li + lj).min(li + lk).min(lj + lk);
                let bound = |f_unc: f64| (req.alpha * f_res + (1.0 - req.alpha) * f_unc) * conf_max;
                if !beats(bound(req.f_unc_bound(lmin)), &best)
                    || !beats(
                        bound(req.f_unc_bound_triplet(&terms[i], &terms[j], &terms[k])),
                        &best,
                    )
                {
                    continue;
                }
                let mut t = [i, j, k];
                t.sort_unstable();
                let b = eval(terms, t, conf, req);
                if best.is_none_or(|x| b.value > x.value) {
                    best = Some(b);
                }
            }
        }
    }
    best
}

/// The best triplet of `terms` given `current`, the best triplet of all
/// of them but the last: `current`, or the best triplet that contains the
/// last camera when that one is strictly better.
///
/// The value equals [`best_triplet`] on all the terms, bit for bit (the same
/// triplets are evaluated in the same index order, the same bounds prune
/// them). Among triplets of equal value it may report another one than
/// [`best_triplet`] would; only the value is used once planning has started.
///
/// # Performance
/// A new camera of a triangle with n observers adds C(n - 1, 2) triplets,
/// where recomputing would enumerate all C(n, 3) again: M3 adds three
/// cameras per triplet to triangles that tens of cameras already see.
pub fn best_triplet_including_last(
    terms: &[CamTerm],
    conf: Option<&ConfCurve>,
    req: &Requirements,
    current: Best,
) -> Best {
    let Some(new) = terms.len().checked_sub(1) else {
        return current;
    };
    let mut order: Vec<usize> = (0..new).collect();
    order.sort_by(|&a, &b| terms[b].r.total_cmp(&terms[a].r).then(a.cmp(&b)));
    let conf_max = conf.map_or(1.0, ConfCurve::max);
    let slack = 1.0 + 1e-9;
    let mut best = current;
    let beats = |bound: f64, best: &Best| bound * slack > best.value;
    let ln = terms[new].info_max;
    for jj in 1..order.len() {
        // The triplet's coarsest camera is j or the new one: i comes before
        // j in decreasing r.
        let j = order[jj];
        let f_res = req.f_res(terms[j].r.min(terms[new].r));
        if !beats((req.alpha * f_res + (1.0 - req.alpha)) * conf_max, &best) {
            break;
        }
        for &i in &order[..jj] {
            let (li, lj) = (terms[i].info_max, terms[j].info_max);
            let lmin = (li + lj).min(li + ln).min(lj + ln);
            let bound = |f_unc: f64| (req.alpha * f_res + (1.0 - req.alpha) * f_unc) * conf_max;
            if !beats(bound(req.f_unc_bound(lmin)), &best)
                || !beats(
                    bound(req.f_unc_bound_triplet(&terms[i], &terms[j], &terms[new])),
                    &best,
                )
            {
                continue;
            }
            let b = eval(terms, [i.min(j), i.max(j), new], conf, req);
            if b.value > best.value {
                best = b;
            }
        }
    }
    best
}

/// One sampled triangle of the (split) region of interest.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct SampledTriangle {
    /// Face of the input mesh it was split from.
    pub parent: u32,
    /// Centroid.
    pub centroid: Point3<f64>,
    /// Unit normal.
    pub normal: Vector3<f64>,
}

/// Splits the ROI faces to the mean ROI edge length and draws `n` of them
/// without replacement. Returns the sampled triangles as a mesh (for
/// visibility queries) and their descriptions.
pub fn sample_triangles(
    mesh: &Mesh,
    roi_faces: &[u32],
    n: usize,
    rng: &mut ChaCha8Rng,
) -> Result<(Mesh, Vec<SampledTriangle>)> {
    let roi = submesh(mesh, roi_faces);
    let mean = roi.mean_edge_length();
    if !(mean > 0.0) {
        return Err(PlannerError::Input(
            "the region of interest has no non-degenerate face".into(),
        ));
    }
    let (split, parent) = split_faces(&roi, mean)?;
    let usable: Vec<u32> = (0..split.n_faces())
        .filter(|&f| split.face_area(f) > 0.0)
        .map(|f| f as u32)
        .collect();
    let picked: Vec<u32> = if usable.len() <= n {
        usable
    } else {
        let mut idx = index::sample(rng, usable.len(), n).into_vec();
        // Keep the draw (which triangles) but order them by face for stable output.
        idx.sort_unstable();
        idx.into_iter().map(|i| usable[i]).collect()
    };
    let tris = picked
        .iter()
        .map(|&f| SampledTriangle {
            parent: roi_faces[parent[f as usize] as usize],
            centroid: split.face_centroid(f as usize),
            normal: split.face_normal(f as usize),
        })
        .collect();
    Ok((submesh(&split, &picked), tris))
}

/// f(t) bookkeeping over the sampled triangles and a growing camera set.
///
/// `Clone`: replacing a dropped triplet replays the kept ones on f(t) as it
/// was before M3 ([`crate::plan`]).
#[derive(Clone)]
pub struct Fulfillment {
    /// Requirements used for scoring.
    pub req: Requirements,
    /// sigma_px.
    pub sigma_px: f64,
    /// c.
    pub min_cameras: usize,
    /// The sampled triangles.
    pub tris: Vec<SampledTriangle>,
    /// The sampled triangles as a mesh (face i = triangle i).
    pub tri_mesh: Mesh,
    /// All cameras: acquired first, then planned.
    pub cameras: Vec<Camera>,
    /// Number of acquired cameras (the first ones of `cameras`).
    pub n_acquired: usize,
    /// Per triangle: observing cameras (indices into `cameras`) and their terms.
    pub observers: Vec<Vec<(u32, CamTerm)>>,
    /// Per triangle: confidence curves of the acquired observers, by camera
    /// index; for a triangle no acquired image observes, the curve of the
    /// closest acquired image whose frame contains it (if any).
    pub acquired_curves: Vec<Vec<(u32, ConfCurve)>>,
    /// Per triangle: confidence curve of the acquired observer closest to the centroid.
    pub curve: Vec<ConfCurve>,
    /// Per triangle: f(t) and its best triplet.
    pub best: Vec<Option<Best>>,
}

impl Fulfillment {
    /// M1 for the acquired cameras (`confidence[i]` belongs to `cameras[i]`;
    /// `None` means no prediction, confidence 1).
    pub fn new(
        req: Requirements,
        sigma_px: f64,
        min_cameras: usize,
        (tri_mesh, tris): (Mesh, Vec<SampledTriangle>),
        caster: &RayCaster,
        cameras: &[Camera],
        confidence: &[Option<&ConfidenceImage>],
    ) -> Self {
        let n = tris.len();
        let mut me = Fulfillment {
            req,
            sigma_px,
            min_cameras,
            tris,
            tri_mesh,
            cameras: Vec::new(),
            n_acquired: cameras.len(),
            observers: vec![Vec::new(); n],
            acquired_curves: vec![Vec::new(); n],
            curve: Vec::new(),
            best: vec![None; n],
        };
        for (ci, cam) in cameras.iter().enumerate() {
            let seen = me.observe(cam, caster);
            for &t in &seen {
                let tri = me.tris[t];
                let curve = match confidence[ci] {
                    Some(img) => {
                        let px = cam
                            .project(&tri.centroid)
                            .map_or((0.0, 0.0), |p| (p.x, p.y));
                        ConfCurve::sample(img, px, &me.req.bins)
                    }
                    None => ConfCurve::one(&me.req.bins),
                };
                me.acquired_curves[t].push((ci as u32, curve));
            }
        }
        // [vpctl] A triangle no acquired image observes (occluded, seen
        // edge-on, back-facing) takes the prediction at its place in the
        // closest acquired image whose frame contains it: that pixel shows
        // the same material at the same scale, a better guess than "no
        // prediction". Only without any such image is the confidence 1.
        for t in 0..n {
            if !me.acquired_curves[t].is_empty() {
                continue;
            }
            let c = me.tris[t].centroid;
            let fallback = cameras
                .iter()
                .enumerate()
                .filter_map(|(ci, cam)| cam.project_in_frame(&c).map(|px| (ci, px)))
                .min_by(|a, b| {
                    let da = (cameras[a.0].center() - c).norm_squared();
                    let db = (cameras[b.0].center() - c).norm_squared();
                    da.total_cmp(&db).then(a.0.cmp(&b.0))
                });
            if let Some((ci, px)) = fallback {
                let curve = confidence[ci].map_or_else(
                    || ConfCurve::one(&me.req.bins),
                    |img| ConfCurve::sample(img, (px.x, px.y), &me.req.bins),
                );
                me.acquired_curves[t].push((ci as u32, curve));
            }
        }
        me.curve = (0..n)
            .map(|t| {
                let c = me.tris[t].centroid;
                me.acquired_curves[t]
                    .iter()
                    .min_by(|a, b| {
                        let da = (me.cameras[a.0 as usize].center() - c).norm_squared();
                        let db = (me.cameras[b.0 as usize].center() - c).norm_squared();
                        da.total_cmp(&db).then(a.0.cmp(&b.0))
                    })
                    .map_or_else(|| ConfCurve::one(&me.req.bins), |x| x.1.clone())
            })
            .collect();
        me.update_all();
        me
    }

    /// Adds a camera, records the triangles it sees; returns them.
    fn observe(&mut self, cam: &Camera, caster: &RayCaster) -> Vec<usize> {
        let ci = self.cameras.len() as u32;
        self.cameras.push(*cam);
        let visible = caster.visible_faces(cam, &self.tri_mesh);
        let mut seen = Vec::new();
        for (t, v) in visible.into_iter().enumerate() {
            if v {
                let tri = self.tris[t];
                let term = CamTerm::new(cam, &tri.centroid, &tri.normal, self.sigma_px);
                self.observers[t].push((ci, term));
                seen.push(t);
            }
        }
        seen
    }

    /// Recomputes f(t) for every triangle.
    pub fn update_all(&mut self) {
        let req = &self.req;
        let c = self.min_cameras;
        self.best = self
            .observers
            .par_iter()
            .zip(&self.curve)
            .map(|(obs, curve)| best_of(obs, curve, req, c))
            .collect();
    }

    /// f(t) of triangle `t`.
    pub fn f(&self, t: usize) -> f64 {
        self.best[t].map_or(0.0, |b| b.value)
    }

    /// f_cov of triangle `t`: seen by at least c cameras.
    pub fn covered(&self, t: usize) -> bool {
        self.observers[t].len() >= self.min_cameras
    }

    /// Mean f over the sampled triangles.
    pub fn mean_f(&self) -> f64 {
        if self.tris.is_empty() {
            return 0.0;
        }
        (0..self.tris.len()).map(|t| self.f(t)).sum::<f64>() / self.tris.len() as f64
    }

    /// Share of sampled triangles with f_cov = 1.
    pub fn coverage(&self) -> f64 {
        if self.tris.is_empty() {
            return 0.0;
        }
        (0..self.tris.len()).filter(|&t| self.covered(t)).count() as f64 / self.tris.len() as f64
    }

    /// Selection weight `w(t) = 1 - f(t) / f_conf(t*)` (1 when uncovered;
    /// when f(t) = 0, t* maximises q, so w = 1 - q(t*)).
    pub fn weight(&self, t: usize) -> f64 {
        match self.best[t] {
            None => 1.0,
            Some(b) if b.value > 0.0 && b.conf > 0.0 => (1.0 - b.value / b.conf).clamp(0.0, 1.0),
            Some(_) => {
                let terms: Vec<CamTerm> = self.observers[t].iter().map(|o| o.1).collect();
                best_triplet(&terms, None, &self.req).map_or(1.0, |b| (1.0 - b.q).clamp(0.0, 1.0))
            }
        }
    }

    /// Draws up to `n` triangles without replacement with probability
    /// proportional to their weight (Efraimidis-Spirakis keys); all of them
    /// when at most `n` have a positive weight. Sorted indices.
    pub fn select(&self, n: usize, rng: &mut ChaCha8Rng) -> Vec<usize> {
        let mut keyed: Vec<(f64, usize)> = (0..self.tris.len())
            .filter_map(|t| {
                let w = self.weight(t);
                let u: f64 = rng.random::<f64>().max(f64::MIN_POSITIVE);
                (w > 0.0).then(|| (u.ln() / w, t))
            })
            .collect();
        keyed.sort_by(|a, b| b.0.total_cmp(&a.0).then(a.1.cmp(&b.1)));
        let mut out: Vec<usize> = keyed.into_iter().take(n).map(|k| k.1).collect();
        out.sort_unstable();
        out
    }

    /// Adds a planned camera (no confidence image) and updates f(t) of the
    /// triangles it sees, including triplets that mix old and new cameras.
    pub fn add_planned(&mut self, cam: &Camera, caster: &RayCaster) {
        let seen = self.observe(cam, caster);
        let req = &self.req;
        let c = self.min_cameras;
        let updated: Vec<(usize, Option<Best>)> = seen
            .par_iter()
            .map(|&t| {
                let (obs, curve) = (&self.observers[t], &self.curve[t]);
                let b = match self.best[t] {
                    // The old triplets were searched already: only those
                    // with the new camera can raise f(t).
                    Some(cur) => {
                        let terms: Vec<CamTerm> = obs.iter().map(|o| o.1).collect();
                        Some(best_triplet_including_last(&terms, Some(curve), req, cur))
                    }
                    None => best_of(obs, curve, req, c),
                };
                (t, b)
            })
            .collect();
        for (t, b) in updated {
            self.best[t] = b;
        }
    }
}

fn best_of(
    obs: &[(u32, CamTerm)],
    curve: &ConfCurve,
    req: &Requirements,
    c: usize,
) -> Option<Best> {
    if obs.len() < c {
        return None;
    }
    let terms: Vec<CamTerm> = obs.iter().map(|o| o.1).collect();
    best_triplet(&terms, Some(curve), req)
}

#[cfg(test)]
mod tests {
    use super::*;
    use rand::SeedableRng;
    use vp_scene::raster::AngleBins;
    use vp_scene::Intrinsics;

    /// Terms of `n` random cameras looking at the origin (normal +z) from
    /// 20-80 m at 30-85 deg elevation, and a random confidence curve.
    fn random_terms(n: usize, rng: &mut ChaCha8Rng) -> (Vec<CamTerm>, ConfCurve) {
        let k = Intrinsics::new(1200, 800, 1800.0, 1800.0, 600.0, 400.0).unwrap();
        let p = Point3::origin();
        let terms = (0..n)
            .map(|_| {
                let d: f64 = rng.random_range(20.0..80.0);
                let el = rng.random_range(30f64..85.0).to_radians();
                let az = rng.random_range(0f64..360.0).to_radians();
                let c = Point3::new(
                    d * el.cos() * az.cos(),
                    d * el.cos() * az.sin(),
                    d * el.sin(),
                );
                let cam = Camera::look_at(k, c, p).unwrap();
                CamTerm::new(&cam, &p, &Vector3::z(), 1.0)
            })
            .collect();
        let curve = ConfCurve((0..9).map(|_| rng.random_range(0.2f32..1.0)).collect());
        (terms, curve)
    }

    #[test]
    fn pruned_and_incremental_searches_give_the_plain_maximum() {
        let req = Requirements {
            r_desired: 1.0 / (0.008 * 0.008),
            accuracy: 0.008,
            alpha: 0.5,
            bins: AngleBins::paper(),
        };
        let mut rng = ChaCha8Rng::seed_from_u64(11);
        for trial in 0..40 {
            let (terms, curve) = random_terms(30, &mut rng);
            let conf = (trial % 2 == 0).then_some(&curve);
            let mut inc = best_triplet(&terms[..3], conf, &req).unwrap();
            for n in 4..=terms.len() {
                inc = best_triplet_including_last(&terms[..n], conf, &req, inc);
                let full = best_triplet(&terms[..n], conf, &req).unwrap();
                assert_eq!(
                    inc.value.to_bits(),
                    full.value.to_bits(),
                    "trial {trial}, n {n}"
                );
                if n <= 16 {
                    let plain = best_triplet_plain(&terms[..n], conf, &req).unwrap();
                    assert_eq!(full.value.to_bits(), plain.value.to_bits(), "n {n}");
                }
                let again = eval(&terms[..n], inc.triplet, conf, &req);
                assert_eq!(again.value.to_bits(), inc.value.to_bits());
            }
        }
    }

    #[test]
    fn constant_curves_give_the_value_of_the_interpolated_curve() {
        let req = Requirements {
            r_desired: 1.0 / (0.008 * 0.008),
            accuracy: 0.008,
            alpha: 0.5,
            bins: AngleBins::paper(),
        };
        let mut rng = ChaCha8Rng::seed_from_u64(12);
        let (terms, _) = random_terms(12, &mut rng);
        for curve in [
            ConfCurve::one(&req.bins),
            ConfCurve(vec![0.37; 9]),
            ConfCurve(vec![0.0; 9]),
        ] {
            assert!(curve.constant().is_some());
            for i in 0..terms.len() {
                for j in i + 1..terms.len() {
                    for k in j + 1..terms.len() {
                        let (q, angle) = req.score(&terms[i], &terms[j], &terms[k]);
                        let want = q * curve.at(&req.bins, angle);
                        let got = eval(&terms, [i, j, k], Some(&curve), &req).value;
                        assert_eq!(got.to_bits(), want.to_bits());
                    }
                }
            }
        }
        assert_eq!(ConfCurve(vec![-0.0; 9]).constant(), None);
        assert_eq!(ConfCurve(vec![0.5, 0.5, 0.6]).constant(), None);
    }
}
