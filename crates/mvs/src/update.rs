//! One PatchMatch update of a pixel (propagation from its neighbours,
//! then refinement) and the rules that leave settled pixels alone.

use rayon::prelude::*;

use super::{Hyp, Problem, NEIGHBOURS};
use crate::cost::{RefPatch, MAX_COST};
use crate::geom_term::agrees;
use crate::rng::PixelRng;
use crate::view::pixel_ray;

impl Problem<'_> {
    /// In the geometric pass (with `geom_settled_px` above 0), the pixels
    /// left as seeded: those whose seed plane as many of the sources they
    /// score (`sources`) as their cost averages (`top_k_sources`, or all of
    /// them where there are fewer) already agree with as the geometric
    /// filter asks ([`agrees`]: within `geom_settled_px` pixels and
    /// `max_depth_diff`), and whose propagation neighbours are in the same
    /// case. This is the settle rule of `update` with "disagrees" for
    /// "changed": a pixel next to one to be repaired is still updated, and
    /// may take a better plane from it. The first iteration does not update
    /// settled pixels, and marks them unchanged for the next ones. A pixel
    /// whose plane could not be scored never agrees, nor any without a
    /// geometric term (`geom_regularizer` 0).
    pub(super) fn settled_seeds(&self, seeds: &[Hyp], sources: &[u32]) -> Option<Vec<bool>> {
        let px = self.params.geom_settled_px;
        let geom = self
            .geom
            .as_ref()
            .filter(|_| px > 0.0 && self.params.geom_regularizer > 0.0)?;
        let bounds = (px, self.params.max_depth_diff);
        let w = self.image.width as usize;
        let agrees: Vec<bool> = (seeds, sources)
            .into_par_iter()
            .enumerate()
            .map(|(i, (h, &mask))| {
                let (x, y) = (i % w, i / w);
                let ray = pixel_ray(&self.k, x, y);
                let averaged = (mask.count_ones() as usize).min(self.top_k);
                let agreeing = (0..self.sources.len())
                    .filter(|k| mask & (1 << k) != 0)
                    .filter(|&k| {
                        let rel = &self.sources[k].rel;
                        agrees(&self.k, bounds, rel, &geom[k], (x, y), &ray, h.d)
                    })
                    .count();
                h.photo < MAX_COST && agreeing >= averaged
            })
            .collect();
        Some(
            (0..seeds.len())
                .into_par_iter()
                .map(|i| agrees[i] && !any_neighbour(&agrees, w, (i % w, i / w), |a| !a))
                .collect(),
        )
    }

    /// Whether an update changed a pixel: its hypothesis changed at all
    /// (`settle_cost` 0), or its cost fell by more than `settle_cost`.
    pub(super) fn changed(&self, old: &Hyp, new: &Hyp) -> bool {
        let settle = self.params.settle_cost;
        if settle > 0.0 {
            old.cost - new.cost > settle
        } else {
            !same_bits(old, new)
        }
    }

    pub(super) fn random_depth(&self, rng: &mut PixelRng) -> f32 {
        // Uniform in inverse depth: uniform in disparity, as a stereo search.
        let (lo, hi) = (1.0 / self.range.1, 1.0 / self.range.0);
        1.0 / (lo + (hi - lo) * rng.next_f32())
    }

    /// One PatchMatch update of pixel (x, y) from the state `prev`:
    /// propagation, then refinement. `changed` (None on a pixel's first
    /// update) says which pixels changed at their last update; a
    /// neighbour pair of which no pixel did is skipped (see `run`).
    /// Of the neighbours' planes, the `neighbours` from the neighbours with
    /// the lowest cost are scored. Without `random_candidates`, refinement
    /// tries only the perturbation.
    /// Every hypothesis is scored on the pixel's sources (bit masks).
    pub(super) fn update(
        &self,
        (prev, changed, sources): (&[Hyp], Option<&[bool]>, &[u32]),
        patch: &mut RefPatch,
        (x, y): (usize, usize),
        (it, step, random_candidates, neighbours): (u32, u64, bool, usize),
    ) -> Hyp {
        let w = self.image.width as usize;
        let h = self.image.height as usize;
        let idx = y * w + x;
        // Settled: neither this pixel nor a neighbour it propagates from
        // changed at its last update (see `settle_cost`).
        if changed.is_some_and(|c| !c[idx] && !any_neighbour(c, w, (x, y), |&c| c)) {
            return prev[idx];
        }
        // Which candidates were scored before (see `run`).
        let changed = changed.filter(|_| self.skip_unchanged);
        let ray = pixel_ray(&self.k, x, y);
        patch.build(self.image, x, y, &self.win);
        let mut best = prev[idx];
        if !patch.textured() {
            return best;
        }
        let consider = |d: f32, n: [f32; 3], best: &mut Hyp| {
            let (cost, photo) = self.cost(patch, (x, y), &ray, d, &n, best.cost, sources[idx]);
            if cost < best.cost {
                *best = Hyp { d, n, cost, photo };
            }
        };
        // Propagation: the neighbour's plane, intersected with this pixel's
        // ray; the planes offered, with their neighbour's cost.
        let mut offered = [(0.0f32, 0.0f32, [0.0f32; 3]); NEIGHBOURS.len()];
        let mut count = 0;
        for pair in NEIGHBOURS {
            let mut pick: Option<(usize, usize)> = None;
            let mut fresh = changed.is_none();
            for (ox, oy) in pair {
                let (nx, ny) = (x as i32 + ox, y as i32 + oy);
                if nx < 0 || ny < 0 || nx as usize >= w || ny as usize >= h {
                    continue;
                }
                let (nx, ny) = (nx as usize, ny as usize);
                fresh |= changed.is_some_and(|c| c[ny * w + nx]);
                if pick.is_none_or(|(px, py)| prev[ny * w + nx].cost < prev[py * w + px].cost) {
                    pick = Some((nx, ny));
                }
            }
            // Neither neighbour changed: the candidate was scored before.
            let Some((nx, ny)) = pick.filter(|_| fresh) else {
                continue;
            };
            let nb = prev[ny * w + nx];
            let nray = pixel_ray(&self.k, nx, ny);
            let n = nb.n;
            let num = nb.d * (n[0] * nray[0] + n[1] * nray[1] + n[2] * nray[2]);
            let den = n[0] * ray[0] + n[1] * ray[1] + n[2] * ray[2];
            if den.abs() < 1e-6 {
                continue;
            }
            let d = num / den;
            // Already this pixel's plane (common once converged): skip.
            if !same_plane(d, &n, &best) {
                offered[count] = (nb.cost, d, n);
                count += 1;
            }
        }
        // At the finer pyramid levels, only the planes of the
        // `fine_neighbours` neighbours with the lowest cost (see
        // `MvsParams::fine_neighbours`), best first; when no more are
        // offered, all of them in the order above.
        if count > neighbours {
            offered[..count].sort_unstable_by(|a, b| a.0.total_cmp(&b.0));
            count = neighbours;
        }
        for &(_, d, n) in &offered[..count] {
            // An earlier candidate may have won with this very plane.
            if !same_plane(d, &n, &best) {
                consider(d, n, &mut best);
            }
        }
        // Refinement: a random depth and a random normal (in passes from
        // random planes, or with `seeded_random_candidates`), and a
        // perturbation of both whose size halves every iteration.
        let mut rng = PixelRng::new(self.params.seed, self.view_key, idx as u64, step);
        let scale = 0.5f32.powi(it as i32);
        let current = best;
        if random_candidates {
            let random_d = self.random_depth(&mut rng);
            let random_n = random_normal(&mut rng, &ray);
            consider(random_d, current.n, &mut best);
            consider(current.d, random_n, &mut best);
        }
        let pert_d = current.d * (1.0 + 0.05 * scale * rng.symmetric());
        let pert_n = normalize([
            current.n[0] + 0.3 * scale * rng.symmetric(),
            current.n[1] + 0.3 * scale * rng.symmetric(),
            current.n[2] + 0.3 * scale * rng.symmetric(),
        ]);
        consider(pert_d, pert_n, &mut best);
        best
    }
}

/// Whether `test` holds for the flag of any propagation neighbour of pixel
/// (x, y) inside the image (rows of `w` flags).
fn any_neighbour(
    flags: &[bool],
    w: usize,
    (x, y): (usize, usize),
    test: impl Fn(&bool) -> bool,
) -> bool {
    let h = flags.len() / w;
    NEIGHBOURS.iter().flatten().any(|&(ox, oy)| {
        let (nx, ny) = (x as i32 + ox, y as i32 + oy);
        nx >= 0
            && ny >= 0
            && (nx as usize) < w
            && (ny as usize) < h
            && test(&flags[ny as usize * w + nx as usize])
    })
}

/// Whether plane (d, n) is `hyp`'s, bit for bit.
fn same_plane(d: f32, n: &[f32; 3], hyp: &Hyp) -> bool {
    d.to_bits() == hyp.d.to_bits() && n.map(f32::to_bits) == hyp.n.map(f32::to_bits)
}

/// Whether two hypotheses are the same bit for bit.
fn same_bits(a: &Hyp, b: &Hyp) -> bool {
    a.d.to_bits() == b.d.to_bits()
        && a.n.map(f32::to_bits) == b.n.map(f32::to_bits)
        && a.cost.to_bits() == b.cost.to_bits()
        && a.photo.to_bits() == b.photo.to_bits()
}

/// A random unit normal facing the camera along `ray` (the reversed ray
/// plus a random vector of the unit cube), so that fronto-parallel planes
/// are the most likely and grazing ones rare.
pub(super) fn random_normal(rng: &mut PixelRng, ray: &[f32; 3]) -> [f32; 3] {
    let r = normalize(*ray);
    normalize([
        -r[0] + rng.symmetric(),
        -r[1] + rng.symmetric(),
        -r[2] + rng.symmetric(),
    ])
}

#[inline]
fn normalize(v: [f32; 3]) -> [f32; 3] {
    let l = (v[0] * v[0] + v[1] * v[1] + v[2] * v[2]).sqrt();
    if l > 0.0 {
        [v[0] / l, v[1] / l, v[2] / l]
    } else {
        [0.0, 0.0, -1.0]
    }
}
