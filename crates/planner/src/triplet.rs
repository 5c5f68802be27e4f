//! M3: the best camera triplet: potential gains, mean-shift orientation,
//! b triplets per surrogate, safety filtering and the gain g(c3).
//!
//! The visit order (decreasing summed potential gain) with its early stop
//! is the paper's shortcut, a heuristic: it can miss the best triplet.
//! [`Search::early_stop`] = false searches every surrogate instead.
//!
//! Here: the search (orient, build the b triplets, visit in order). The
//! potential gains are in `potential.rs`, g(c3) and its bound in `gain.rs`,
//! the mean-shift orientation in `mean_shift.rs`.

use std::cmp::Ordering;
use std::collections::BinaryHeap;
use std::time::Instant;

use nalgebra::{Point3, Vector3};
use rayon::prelude::*;
use vp_scene::raycast::RayCaster;
use vp_scene::{Camera, Intrinsics, Mesh};

use crate::fulfillment::Fulfillment;
use crate::safety::Safety;
use crate::surrogate::{basis, LazyLinks};

mod gain;
mod mean_shift;
mod potential;

pub use potential::Potential;

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
    /// Surrogates not to visit (`banned[s]`; shorter than the surrogates:
    /// the rest are allowed): around them a chosen triplet could not be
    /// flown, and its replacement is searched elsewhere.
    pub banned: &'a [bool],
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

impl Search<'_> {
    fn is_banned(&self, s: usize) -> bool {
        self.banned.get(s).copied().unwrap_or(false)
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
        let mut order: Vec<usize> = (0..sums.len())
            .filter(|&s| sums[s] > 0.0 && !self.is_banned(s))
            .collect();
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
        let mut order = VisitOrder::new(gpot, lazy, |s| self.is_banned(s));
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

/// The visit order of [`Search::run_lazy`], found lazily: a max-heap of
/// surrogates by summed potential gain, exact or a bound from above.
struct VisitOrder {
    /// Per surrogate and candidate link, the potential gain.
    gpot: Vec<Vec<f64>>,
    heap: BinaryHeap<Ranked>,
}

impl VisitOrder {
    fn new(gpot: Vec<Vec<f64>>, lazy: &LazyLinks, banned: impl Fn(usize) -> bool + Sync) -> Self {
        let heap: Vec<Ranked> = (0..lazy.len())
            .into_par_iter()
            .filter(|&s| !banned(s))
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
