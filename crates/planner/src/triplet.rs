//! M3: the best camera triplet: potential gains, mean-shift orientation,
//! b triplets per surrogate, safety filtering and the gain g(c3).
//!
//! The visit order (decreasing summed potential gain) with its early stop
//! is the paper's shortcut, a heuristic: it can miss the best triplet.
//! [`Search::early_stop`] = false searches every surrogate instead.

use std::cmp::Ordering;
use std::collections::BinaryHeap;
use std::time::Instant;

use nalgebra::{Matrix3, Point3, Vector3};
use rayon::prelude::*;
use vp_scene::raycast::{RayCaster, FACE_VISIBILITY_EPSILON};
use vp_scene::{Camera, Intrinsics, Mesh};

use crate::fulfillment::Fulfillment;
use crate::quality::{CamTerm, ConfCurve};
use crate::safety::Safety;
use crate::surrogate::{basis, LazyLinks};

mod mean_shift;

/// Azimuths of the three cameras around the viewing direction, degrees
/// [vpctl] (docs/design.md#m3-best-triplet): one above, two below, measured
/// from image right.
const AZIMUTHS_DEG: [f64; 3] = [90.0, 210.0, 330.0];

/// Surrogates evaluated together between two early-stop checks; results
/// are merged in visit order, so they equal a sequential visit.
const CHUNK: usize = 4;

/// Segment tests [`Search::run_lazy`] gathers into one parallel batch
/// (from as many surrogates as it takes) before testing them.
const RESOLVE_BATCH_RAYS: usize = 2048;

/// A surrogate in the visit order of [`Search::run_lazy`]: by decreasing
/// sum, then increasing index (the order of [`Search::run`]).
#[derive(Debug, Clone, Copy)]
struct Ranked {
    /// Summed potential gain, or a bound of it when not `exact`.
    sum: f64,
    /// Surrogate index.
    s: usize,
    /// Whether `sum` is the summed potential gain over links.
    exact: bool,
}

impl PartialEq for Ranked {
    fn eq(&self, other: &Self) -> bool {
        self.cmp(other) == Ordering::Equal
    }
}

impl Eq for Ranked {}

impl PartialOrd for Ranked {
    fn partial_cmp(&self, other: &Self) -> Option<Ordering> {
        Some(self.cmp(other))
    }
}

impl Ord for Ranked {
    /// Greater = visited first.
    fn cmp(&self, other: &Self) -> Ordering {
        self.sum.total_cmp(&other.sum).then(other.s.cmp(&self.s))
    }
}

/// A candidate triplet.
#[derive(Debug, Clone, PartialEq)]
pub struct Candidate {
    /// The three cameras (roll 0, looking at the focus).
    pub cameras: [Camera; 3],
    /// g(c3): summed fulfillment gain over the selected triangles.
    pub gain: f64,
    /// Angle bin the triplet was built for.
    pub bin: usize,
    /// Bin-centre triangulation angle at the focus, degrees.
    pub angle_deg: f64,
    /// Index of the surrogate it was built around.
    pub surrogate: usize,
}

/// Outcome of one best-triplet search.
#[derive(Debug, Clone, Default)]
pub struct Outcome {
    /// The best candidate with a positive gain, if any.
    pub best: Option<Candidate>,
    /// Surrogates oriented and evaluated.
    pub visited: usize,
    /// True when the deadline stopped the search.
    pub timed_out: bool,
}

/// One M3 search over the surrogates.
pub struct Search<'a> {
    /// f(t) of the sampled triangles with all current cameras.
    pub ful: &'a Fulfillment,
    /// T: indices into `ful.tris`.
    pub selected: &'a [usize],
    /// The T triangles as a mesh (face i = `selected[i]`), for visibility.
    pub selected_mesh: &'a Mesh,
    /// Surrogate positions (M2).
    pub surrogates: &'a [Point3<f64>],
    /// Safety rules for the cameras.
    pub safety: &'a Safety,
    /// Ray caster of the scene mesh.
    pub caster: &'a RayCaster,
    /// Intrinsics of the new views.
    pub intrinsics: Intrinsics,
    /// Gimbal pitch limits, radians.
    pub pitch_limits: (f64, f64),
    /// The paper's early stop (heuristic) when true; all surrogates when false.
    pub early_stop: bool,
    /// Stop searching at this instant.
    pub deadline: Option<Instant>,
}

/// Camera frame around a viewing direction: image right (horizontal when
/// possible) and image up.
fn frame(v: &Vector3<f64>) -> (Vector3<f64>, Vector3<f64>) {
    let right = v.cross(&Vector3::z());
    if right.norm() < 1e-9 {
        let (e1, e2) = basis(v);
        return (e1, e2);
    }
    let right = right.normalize();
    (right, right.cross(v))
}

/// Half-cone angle beta (between a camera ray and the triplet axis) of an
/// equilateral triplet with pairwise angle gamma: sin(gamma/2) = sqrt(3)/2 sin(beta).
fn half_cone(gamma_rad: f64) -> f64 {
    (2.0 * (0.5 * gamma_rad).sin() / 3f64.sqrt())
        .clamp(-1.0, 1.0)
        .asin()
}

/// Geometry of the hypothetical equilateral triplet of one bin.
struct BinGeometry {
    /// Bin index and centre angle, degrees.
    bin: usize,
    sin_b: f64,
    cos_b: f64,
    /// `cos_b^2`: camera distance d / cos_b squared is `d^2 / cos2_b`.
    cos2_b: f64,
    /// `sqrt(f^2 cos2_b min(3 s2, 3 - 1.5 s2)) / sigma`: sqrt of the smallest
    /// information eigenvalue times the focus distance d.
    sqrt_info_d: f64,
}

/// The best fulfillment over the bins of the hypothetical equilateral triplet
/// centred at a surrogate, facing a triangle, with the bin-centre angle at
/// it (M3 g_pot without the `- f(t)`, which is the same for every bin). It
/// depends on the acquired cameras only, so M2 evaluates it once per link.
///
/// The cameras look straight at t, where the information of each is
/// `(f/D)^2 (I - u u^T) / sigma^2`; for the symmetric triplet the smallest
/// eigenvalue of the sum is `min(3 k sin^2 b, k (3 - 1.5 sin^2 b))`,
/// `k = f^2 / (sigma D)^2`, b the half-cone angle. Confidence comes from
/// the acquired image closest to the surrogate among those observing t.
pub struct Potential<'a> {
    ful: &'a Fulfillment,
    focal: f64,
    bins: Vec<BinGeometry>,
    azimuths: [(f64, f64); 3],
    one: ConfCurve,
    /// Centres of the acquired cameras (the closest-image rule reads them per link).
    centres: Vec<Point3<f64>>,
    /// Per sampled triangle: true when all its acquired curves are equal
    /// (always without prediction), so the closest image need not be found.
    uniform: Vec<bool>,
}

impl<'a> Potential<'a> {
    /// Precomputes the per-bin geometry for cameras of focal length `focal` px.
    pub fn new(ful: &'a Fulfillment, focal: f64) -> Self {
        let req = &ful.req;
        let bins = (0..req.bins.len())
            .map(|bin| {
                let gamma = f64::from(req.bins.centre(bin)).to_radians();
                let (sin_b, cos_b) = half_cone(gamma).sin_cos();
                let s2 = sin_b * sin_b;
                let cos2_b = cos_b * cos_b;
                let info = focal * focal * cos2_b * (3.0 * s2).min(3.0 - 1.5 * s2);
                BinGeometry {
                    bin,
                    sin_b,
                    cos_b,
                    cos2_b,
                    sqrt_info_d: info.sqrt() / ful.sigma_px,
                }
            })
            .collect();
        Potential {
            ful,
            focal,
            bins,
            azimuths: AZIMUTHS_DEG.map(|a| a.to_radians().sin_cos()),
            one: ConfCurve::one(&req.bins),
            centres: ful.cameras.iter().map(Camera::center).collect(),
            uniform: ful
                .acquired_curves
                .iter()
                .map(|c| c.windows(2).all(|w| w[0].1 == w[1].1))
                .collect(),
        }
    }

    /// The value for surrogate position `s` and sampled triangle `t`.
    pub fn value(&self, s: &Point3<f64>, t: usize) -> f64 {
        let (ful, req) = (self.ful, &self.ful.req);
        let tri = &ful.tris[t];
        let to = s - tri.centroid;
        let d = to.norm();
        if !(d > 0.0) {
            return 0.0;
        }
        let w = to / d;
        let (e1, e2) = frame(&-w);
        let curves = &ful.acquired_curves[t];
        let curve = if self.uniform[t] {
            curves.first().map_or(&self.one, |x| &x.1)
        } else {
            curves
                .iter()
                .map(|x| ((self.centres[x.0 as usize] - s).norm_squared(), x.0, &x.1))
                .min_by(|a, b| a.0.total_cmp(&b.0).then(a.1.cmp(&b.1)))
                .map_or(&self.one, |x| x.2)
        };
        // n . u for u = w cos b + (e1 cos a + e2 sin a) sin b.
        let (nw, n1, n2) = (tri.normal.dot(&w), tri.normal.dot(&e1), tri.normal.dot(&e2));
        let ring_min = self
            .azimuths
            .iter()
            .map(|(sa, ca)| n1 * ca + n2 * sa)
            .fold(f64::INFINITY, f64::min);
        let (f2, d_sq) = (self.focal * self.focal, d * d);
        let mut best = 0.0f64;
        for g in &self.bins {
            let cos_min = nw * g.cos_b + ring_min * g.sin_b;
            let r_min = (f2 * cos_min * g.cos2_b / d_sq).max(0.0);
            let f_unc = (req.accuracy * g.sqrt_info_d / d).min(1.0);
            let q = req.alpha * req.f_res(r_min) + (1.0 - req.alpha) * f_unc;
            // At a bin centre the interpolated curve is the bin's own value.
            best = best.max(q * f64::from(curve.0[g.bin]));
        }
        best
    }
}

impl Search<'_> {
    /// g_pot(t) for surrogate `s` (index) and selected triangle `ti` (index
    /// into `selected`): `max(0, best - f(t))` with the precomputed best
    /// hypothetical fulfillment (see [`Potential::value`]).
    fn potential_gain(&self, best: f64, t: usize) -> f64 {
        if self.ful.observers[t].len() + 3 < self.ful.min_cameras {
            return 0.0;
        }
        (best - self.ful.f(t)).max(0.0)
    }

    /// g(c3) = sum over T seen by all three cameras of max(f(t, c3) - f(t), 0).
    ///
    /// # Performance
    /// Visibility is the M1 rule (in frustum, front-facing, unoccluded), but
    /// the occlusion rays, the only costly part, are cast last and only for
    /// triangles that would add a positive gain: most triangles fail the
    /// frustum test of some camera or are already as fulfilled as this
    /// triplet can make them. The sum is the same as testing every triangle.
    /// A triangle whose f(t, c3) provably cannot exceed f(t) is left out
    /// before its terms are computed ([`Search::cannot_gain`]).
    pub fn gain(&self, cams: &[Camera; 3]) -> f64 {
        self.gain_above(cams, f64::NEG_INFINITY).unwrap_or(0.0)
    }

    /// [`Search::gain`] when it may exceed `floor`: `None` only when
    /// g(c3) <= `floor`, found without casting the occlusion rays.
    ///
    /// The positive gains before the occlusion test, summed in the same
    /// order, bound g(c3) from above (a sum of a superset of non-negative
    /// terms rounds no lower), so a triplet whose bound is at most `floor`
    /// needs no ray. M3 passes the best gain found so far: on the first
    /// iteration most triplets of the later visits are below it.
    pub fn gain_above(&self, cams: &[Camera; 3], floor: f64) -> Option<f64> {
        let ful = self.ful;
        let centres = cams.map(|c| c.center());
        let bound_cams = BoundCams::new(cams, ful);
        let mut positive: Vec<(usize, f64)> = Vec::new();
        let mut upper = 0.0;
        for (i, &t) in self.selected.iter().enumerate() {
            if ful.observers[t].len() + 3 < ful.min_cameras {
                continue;
            }
            let p = self.selected_mesh.face_centroid(i);
            let n = self.selected_mesh.face_normal(i);
            let seen = |k: usize| cams[k].in_frustum(&p) && n.dot(&(p - centres[k])) < 0.0;
            if !(seen(0) && seen(1) && seen(2)) {
                continue;
            }
            let tri = &ful.tris[t];
            let f_t = ful.f(t);
            if self.cannot_gain(&bound_cams, t, f_t) {
                continue;
            }
            let terms = cams.map(|c| CamTerm::new(&c, &tri.centroid, &tri.normal, ful.sigma_px));
            let (f, _, _) = ful
                .req
                .fulfillment(&terms[0], &terms[1], &terms[2], &ful.curve[t]);
            let gain = f - f_t;
            if !(gain > 0.0) {
                continue;
            }
            upper += gain;
            positive.push((i, gain));
        }
        if upper <= floor {
            return None;
        }
        let mut g = 0.0;
        for (i, gain) in positive {
            let p = self.selected_mesh.face_centroid(i);
            let n = self.selected_mesh.face_normal(i);
            let target = p + n * FACE_VISIBILITY_EPSILON;
            if centres.iter().all(|c| !self.caster.occluded(c, &target)) {
                g += gain;
            }
        }
        Some(g)
    }

    /// True when f(t, c3) <= `f_t` for sampled triangle `t` seen by the
    /// triplet `cams`, from an upper bound that needs neither the
    /// information matrices nor their eigenvalue: f_res (all three
    /// resolutions, as [`CamTerm::new`] takes them), and f_unc bounded by
    /// the Rayleigh quotient of the summed information at the direction
    /// from t to the cameras' mean centre, `sum_i |J_i v|^2 / sigma^2`,
    /// plus a margin of 1e-9 of its trace (as
    /// [`Requirements::f_unc_bound_triplet`]). The relative slack of 1e-6
    /// covers the round-off of these terms against the exact ones and the
    /// f32 rounding of an interpolated confidence.
    ///
    /// # Performance
    /// After the first iterations most triangles a triplet sees are already
    /// better fulfilled than it can make them: this skips their three
    /// Jacobians and the closed-form eigenvalue (an arccosine and a cosine).
    ///
    /// [`Requirements::f_unc_bound_triplet`]: crate::quality::Requirements::f_unc_bound_triplet
    fn cannot_gain(&self, cams: &BoundCams, t: usize, f_t: f64) -> bool {
        const SLACK: f64 = 1.0 + 1e-6;
        let ful = self.ful;
        let req = &ful.req;
        if !(f_t > 0.0) || !cams.usable {
            return false;
        }
        let tri = &ful.tris[t];
        let (p, n) = (tri.centroid, tri.normal);
        let to_cam = cams.centres.map(|c| c - p);
        let mut r_min = f64::INFINITY;
        for (k, d) in to_cam.iter().enumerate() {
            let (d2, nd) = (d.norm_squared(), n.dot(d));
            let r = if nd > 0.0 && d2 > 0.0 {
                cams.f2[k] * nd / (d2 * d2.sqrt())
            } else {
                0.0
            };
            r_min = r_min.min(r);
        }
        let conf_max = ful.curve[t].max();
        let f_res = req.f_res(r_min);
        let bound = |f_unc: f64| (req.alpha * f_res + (1.0 - req.alpha) * f_unc) * conf_max;
        if bound(1.0) * SLACK <= f_t {
            return true;
        }
        let Some(v) = (cams.mean_centre - p).try_normalize(1e-12) else {
            return false;
        };
        let (mut quotient, mut trace) = (0.0, 0.0);
        for (k, d) in to_cam.iter().enumerate() {
            let pc = -(cams.cam_from_world[k] * d);
            if !(pc.z > 0.0) {
                return false;
            }
            let w = cams.cam_from_world[k] * v;
            let (fx, fy) = cams.fxy[k];
            let iz = 1.0 / pc.z;
            // J = D R with D the 2x3 derivative of the pinhole projection
            // in the camera frame; R is a rotation, so |J|_F = |D|_F.
            let (dxx, dxz) = (fx * iz, -fx * pc.x * iz * iz);
            let (dyy, dyz) = (fy * iz, -fy * pc.y * iz * iz);
            let (jx, jy) = (dxx * w.x + dxz * w.z, dyy * w.y + dyz * w.z);
            quotient += jx * jx + jy * jy;
            trace += dxx * dxx + dxz * dxz + dyy * dyy + dyz * dyz;
        }
        let (quotient, trace) = (quotient * cams.inv_s2, trace * cams.inv_s2);
        bound(req.f_unc_bound(quotient + 1e-9 * trace)) * SLACK <= f_t
    }

    /// Orients surrogate `s` with its `links` and their potential gains
    /// `gpot`, builds its b triplets and returns the best safe one.
    ///
    /// Only the links with a positive gain count: a link of gain 0 adds a
    /// zero to every sum here, so it can be left out.
    ///
    /// `floor` is the best gain of the search before this visit: a triplet
    /// whose gain is at most `floor` can be reported or not (the caller
    /// keeps a candidate only when it beats `floor`), so its gain need not
    /// be found exactly ([`Search::gain_above`]). Above `floor`, the
    /// candidate is the one a visit without it returns.
    fn visit(&self, s: usize, links: &[u32], gpot: &[f64], floor: f64) -> Option<Candidate> {
        let pos = self.surrogates[s];
        let rays: Vec<(Vector3<f64>, f64)> = links
            .iter()
            .zip(gpot)
            .map(|(&ti, &g)| {
                let t = self.selected[ti as usize];
                ((self.ful.tris[t].centroid - pos).normalize(), g)
            })
            .collect();
        let (hfov, vfov) = self.intrinsics.fov();
        let v = Self::orient(&rays, 0.5 * hfov.min(vfov))?;
        let look = Camera::from_yaw_pitch(
            self.intrinsics,
            pos,
            v.y.atan2(v.x),
            v.z.clamp(-1.0, 1.0).asin(),
        );
        // Re-link with the real frustum; recompute the focus distance.
        let (mut gsum, mut dsum) = (0.0, 0.0);
        for (&ti, &g) in links.iter().zip(gpot) {
            let c = self.ful.tris[self.selected[ti as usize]].centroid;
            if g > 0.0 && look.in_frustum(&c) {
                gsum += g;
                dsum += g * (c - pos).norm();
            }
        }
        if !(gsum > 0.0) {
            return None;
        }
        let focus = pos + v * (dsum / gsum);
        let (right, up) = frame(&v);
        let bins = &self.ful.req.bins;
        let mut best: Option<Candidate> = None;
        for bin in 0..bins.len() {
            let gamma = f64::from(bins.centre(bin));
            let radius = (dsum / gsum) * half_cone(gamma.to_radians()).tan();
            let mut cams = Vec::with_capacity(3);
            for a in AZIMUTHS_DEG {
                let (sa, ca) = a.to_radians().sin_cos();
                let c = pos + (right * ca + up * sa) * radius;
                let dir = focus - c;
                let pitch = (dir.z / dir.norm()).clamp(-1.0, 1.0).asin();
                if pitch < self.pitch_limits.0
                    || pitch > self.pitch_limits.1
                    || !self.safety.point_ok(&c)
                {
                    break;
                }
                cams.push(Camera::from_yaw_pitch(
                    self.intrinsics,
                    c,
                    dir.y.atan2(dir.x),
                    pitch,
                ));
            }
            let Ok(cams) = <[Camera; 3]>::try_from(cams) else {
                continue;
            };
            let bin_floor = best.as_ref().map_or(floor, |b| b.gain.max(floor));
            let Some(gain) = self.gain_above(&cams, bin_floor) else {
                continue;
            };
            if gain > 0.0 && best.as_ref().is_none_or(|b| gain > b.gain) {
                best = Some(Candidate {
                    cameras: cams,
                    gain,
                    bin,
                    angle_deg: gamma,
                    surrogate: s,
                });
            }
        }
        best
    }

    /// Potential gains per surrogate (aligned with `links`), from the best
    /// hypothetical fulfillment of each link ([`Search::run`]'s arguments).
    fn potential_gains(&self, links: &[Vec<u32>], potential: &[Vec<f64>]) -> Vec<Vec<f64>> {
        potential
            .par_iter()
            .zip(links)
            .map(|(best, links)| {
                links
                    .iter()
                    .zip(best)
                    .map(|(&ti, &b)| self.potential_gain(b, self.selected[ti as usize]))
                    .collect()
            })
            .collect()
    }

    /// Visits surrogates by decreasing summed potential gain; with
    /// `early_stop`, stops when that sum is below the best gain found.
    ///
    /// The reference for [`Search::run_lazy`], on every link tested:
    /// `links` holds, per surrogate, the linked triangles (indices into
    /// `selected`), and `potential`, per surrogate and link, the best
    /// hypothetical fulfillment over the bins ([`Potential::value`]);
    /// g_pot = max(0, that - f(t)).
    pub fn run(&self, links: &[Vec<u32>], potential: &[Vec<f64>]) -> Outcome {
        let gpot = self.potential_gains(links, potential);
        let sums: Vec<f64> = gpot.iter().map(|g| g.iter().sum()).collect();
        let mut order: Vec<usize> = (0..sums.len()).filter(|&s| sums[s] > 0.0).collect();
        order.sort_by(|&a, &b| sums[b].total_cmp(&sums[a]).then(a.cmp(&b)));
        let mut out = Outcome::default();
        'chunks: for chunk in order.chunks(CHUNK) {
            if self.deadline.is_some_and(|d| Instant::now() >= d) {
                out.timed_out = true;
                break;
            }
            let floor = out.best.as_ref().map_or(0.0, |b| b.gain);
            let results: Vec<Option<Candidate>> = chunk
                .par_iter()
                .map(|&s| self.visit(s, &links[s], &gpot[s], floor))
                .collect();
            for (&s, cand) in chunk.iter().zip(results) {
                let best_gain = out.best.as_ref().map_or(0.0, |b| b.gain);
                if self.early_stop && out.best.is_some() && sums[s] < best_gain {
                    break 'chunks;
                }
                out.visited += 1;
                if let Some(c) = cand {
                    if c.gain > best_gain {
                        out.best = Some(c);
                    }
                }
            }
        }
        out
    }

    /// [`Search::run`] on links whose segment tests are done on demand: the
    /// same surrogates visited in the same order, the same outcome, bit for
    /// bit (tested).
    ///
    /// A surrogate's summed gain over its untested candidates bounds its
    /// summed gain over its links from above (the sum of a superset of
    /// non-negative terms, in the same order, rounds no lower). Surrogates
    /// come off a max-heap of these bounds; one whose bound is not exact
    /// yet has the segments of its candidates with a positive gain tested
    /// and goes back with its exact sum. A surrogate comes out for a visit
    /// only with its exact sum on top, so the visit order is
    /// [`Search::run`]'s; the early stop ends the search once the top
    /// bound is below the best gain, without testing what is left.
    ///
    /// # Performance
    /// A link whose potential gain is 0 (f(t) only grows) never needs its
    /// segment, nor does a surrogate whose bound stays below the best gain.
    pub fn run_lazy(&self, lazy: &mut LazyLinks) -> Outcome {
        let gpot: Vec<Vec<f64>> = (0..lazy.len())
            .into_par_iter()
            .map(|s| {
                let (tris, best) = lazy.candidates(s);
                tris.iter()
                    .zip(best)
                    .map(|(&ti, &b)| self.potential_gain(b, self.selected[ti as usize]))
                    .collect()
            })
            .collect();
        let mut order = VisitOrder::new(gpot, lazy);
        let mut out = Outcome::default();
        loop {
            // Every sum left below the best gain: Search::run stops at the
            // next surrogate.
            let stop_below = out
                .best
                .as_ref()
                .filter(|_| self.early_stop)
                .map(|b| b.gain);
            // The next CHUNK surrogates of the visit order.
            let mut chunk: Vec<Ranked> = Vec::with_capacity(CHUNK);
            let mut last = false;
            while chunk.len() < CHUNK {
                let Some(r) = order.next(lazy, self.caster, stop_below) else {
                    last = true;
                    break;
                };
                chunk.push(r);
            }
            if chunk.is_empty() {
                break;
            }
            if self.deadline.is_some_and(|d| Instant::now() >= d) {
                out.timed_out = true;
                break;
            }
            let (lazy, gpot) = (&*lazy, &order.gpot);
            let floor = out.best.as_ref().map_or(0.0, |b| b.gain);
            let results: Vec<Option<Candidate>> = chunk
                .par_iter()
                .map(|r| {
                    let (tris, _) = lazy.candidates(r.s);
                    let (links, g): (Vec<u32>, Vec<f64>) = gpot[r.s]
                        .iter()
                        .enumerate()
                        .filter(|&(k, &g)| g > 0.0 && lazy.visible(r.s, k) == Some(true))
                        .map(|(k, &g)| (tris[k], g))
                        .unzip();
                    self.visit(r.s, &links, &g, floor)
                })
                .collect();
            for (r, cand) in chunk.iter().zip(results) {
                let best_gain = out.best.as_ref().map_or(0.0, |b| b.gain);
                if self.early_stop && out.best.is_some() && r.sum < best_gain {
                    return out;
                }
                out.visited += 1;
                if let Some(c) = cand {
                    if c.gain > best_gain {
                        out.best = Some(c);
                    }
                }
            }
            if last {
                break;
            }
        }
        out
    }
}

/// What [`Search::cannot_gain`] reads of a triplet, computed once per
/// [`Search::gain_above`].
struct BoundCams {
    centres: [Point3<f64>; 3],
    mean_centre: Point3<f64>,
    /// Rotation of each camera, world to camera frame, as a matrix.
    cam_from_world: [Matrix3<f64>; 3],
    /// `(fx, fy)` of each camera.
    fxy: [(f64, f64); 3],
    /// Square of each camera's focal length, as `Camera::resolution_at` takes it.
    f2: [f64; 3],
    /// `1 / sigma^2`.
    inv_s2: f64,
    /// False when the requirements are outside the ranges the bound
    /// assumes (alpha in [0, 1], a non-negative accuracy).
    usable: bool,
}

impl BoundCams {
    fn new(cams: &[Camera; 3], ful: &Fulfillment) -> Self {
        let centres = cams.map(|c| c.center());
        let req = &ful.req;
        BoundCams {
            centres,
            mean_centre: Point3::from(
                (centres[0].coords + centres[1].coords + centres[2].coords) / 3.0,
            ),
            cam_from_world: cams.map(|c| {
                *c.world_from_cam
                    .rotation
                    .inverse()
                    .to_rotation_matrix()
                    .matrix()
            }),
            fxy: cams.map(|c| (c.intrinsics.fx, c.intrinsics.fy)),
            f2: cams.map(|c| c.intrinsics.focal() * c.intrinsics.focal()),
            inv_s2: 1.0 / (ful.sigma_px * ful.sigma_px),
            usable: (0.0..=1.0).contains(&req.alpha) && req.accuracy >= 0.0,
        }
    }
}

/// The visit order of [`Search::run_lazy`], found lazily: a max-heap of
/// surrogates by summed potential gain, exact or a bound from above.
struct VisitOrder {
    /// Per surrogate and candidate link, the potential gain.
    gpot: Vec<Vec<f64>>,
    heap: BinaryHeap<Ranked>,
}

impl VisitOrder {
    fn new(gpot: Vec<Vec<f64>>, lazy: &LazyLinks) -> Self {
        let heap: Vec<Ranked> = (0..lazy.len())
            .into_par_iter()
            .filter_map(|s| {
                let r = Self::rank(&gpot, lazy, s);
                (r.sum > 0.0).then_some(r)
            })
            .collect();
        VisitOrder {
            gpot,
            heap: heap.into(),
        }
    }

    /// The sum over positive gains of the candidates of `s` not known to be
    /// occluded; exact when none of them is untested.
    fn rank(gpot: &[Vec<f64>], lazy: &LazyLinks, s: usize) -> Ranked {
        let mut exact = true;
        let sum = gpot[s]
            .iter()
            .enumerate()
            .filter(|&(k, &g)| {
                let v = lazy.visible(s, k);
                exact &= !(g > 0.0 && v.is_none());
                g > 0.0 && v != Some(false)
            })
            .map(|(_, &g)| g)
            .sum();
        Ranked { sum, s, exact }
    }

    /// The next surrogate of the visit order with its exact sum, testing
    /// segments as needed; `None` at the end or when every sum left is
    /// below `stop_below`.
    fn next(
        &mut self,
        lazy: &mut LazyLinks,
        caster: &RayCaster,
        stop_below: Option<f64>,
    ) -> Option<Ranked> {
        loop {
            let top = self.heap.pop()?;
            if stop_below.is_some_and(|b| top.sum < b) {
                return None;
            }
            if top.exact {
                return Some(top);
            }
            // Test the segments of this surrogate and of the next ones
            // that are not exact either, together: one parallel batch
            // instead of one per surrogate. Testing more than needed
            // costs rays, never a different order.
            let gpot = &self.gpot;
            let mut batch = vec![top.s];
            let mut rays = lazy.unresolved(top.s, |k| gpot[top.s][k] > 0.0);
            while rays < RESOLVE_BATCH_RAYS && self.heap.peek().is_some_and(|r| !r.exact) {
                let Some(next) = self.heap.pop() else { break };
                rays += lazy.unresolved(next.s, |k| gpot[next.s][k] > 0.0);
                batch.push(next.s);
            }
            lazy.resolve(&batch, caster, |s, k| gpot[s][k] > 0.0);
            for &s in &batch {
                let r = Self::rank(gpot, lazy, s);
                debug_assert!(r.exact);
                if r.sum > 0.0 {
                    self.heap.push(r);
                }
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn half_cone_gives_the_bin_angle() {
        for gamma in [2.5f64, 22.5, 42.5] {
            let beta = half_cone(gamma.to_radians());
            let w = Vector3::z();
            let (e1, e2) = frame(&-w);
            let u: Vec<Vector3<f64>> = AZIMUTHS_DEG
                .iter()
                .map(|a| {
                    let (sa, ca) = a.to_radians().sin_cos();
                    w * beta.cos() + (e1 * ca + e2 * sa) * beta.sin()
                })
                .collect();
            let got = vp_scene::triangulation::largest_pairwise_angle_deg(&u);
            assert!((got - gamma).abs() < 1e-9, "{got} vs {gamma}");
        }
    }
}
