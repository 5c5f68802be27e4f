//! Scoring a plane hypothesis at one pixel of a PatchMatch problem: the
//! cost on each source, aggregated over the pixel's sources with the
//! best-k view selection, and the choice of those sources
//! (`seeded_sources`; see `Problem::run`).

use rayon::prelude::*;

use super::{Hyp, PlaneOf, Problem, MAX_SOURCES};
use crate::cost::{aggregate, aggregate_lower_bound, source_cost, RefPatch, MAX_COST};
use crate::geom_term::reprojection_error;
use crate::view::pixel_ray;
use crate::warp::plane_row;

impl Problem<'_> {
    /// Sets every pixel's hypothesis to the plane `plane(pixel index, its
    /// ray, its current hypothesis)` gives, scored on the pixel's sources
    /// (bit masks in `sources`), or with `choose`, on that many sources
    /// best for the plane, which then become the pixel's sources.
    pub(super) fn score_planes(
        &self,
        (state, sources): (&mut [Hyp], &mut [u32]),
        choose: Option<usize>,
        plane: PlaneOf<'_>,
    ) {
        let w = self.image.width as usize;
        state
            .par_chunks_mut(w)
            .zip(sources.par_chunks_mut(w))
            .enumerate()
            .for_each(|(y, (row, masks))| {
                let mut patch = RefPatch::default();
                for (x, (hyp, mask)) in row.iter_mut().zip(masks).enumerate() {
                    let ray = pixel_ray(&self.k, x, y);
                    let (d, n) = plane(y * w + x, &ray, hyp);
                    let (cost, photo) = if let Some(keep) = choose {
                        patch.build(self.image, x, y, &self.win);
                        let (costs, kept) = self.seed_sources(&patch, (x, y), &ray, (d, &n), keep);
                        *mask = kept;
                        costs
                    } else if let Some(known) = self.seed_photo {
                        let photo = known[y * w + x];
                        self.known_photo_cost(&mut patch, (x, y), &ray, (d, &n), photo)
                    } else {
                        patch.build(self.image, x, y, &self.win);
                        self.cost(&patch, (x, y), &ray, d, &n, f32::INFINITY, *mask)
                    };
                    *hyp = Hyp { d, n, cost, photo };
                }
            });
    }

    /// Whether plane (d, n) can be scored at this pixel: in the depth
    /// range, on a textured patch, facing the camera within the allowed
    /// angle.
    pub(super) fn scorable(&self, patch: &RefPatch, ray: &[f32; 3], d: f32, n: &[f32; 3]) -> bool {
        let ray_len = (ray[0] * ray[0] + ray[1] * ray[1] + 1.0).sqrt();
        let facing = -(n[0] * ray[0] + n[1] * ray[1] + n[2] * ray[2]) / ray_len;
        d >= self.range.0 && d <= self.range.1 && patch.textured() && !(facing < self.min_cos)
    }

    /// The costs of a plane that cannot win.
    pub(super) fn worst(&self) -> (f32, f32) {
        (MAX_COST + self.geom_worst(), MAX_COST)
    }

    /// Costs (ranking, photometric) at pixel (x, y) in source `k` of the
    /// plane at depth `d` whose [`plane_row`] is `m`.
    pub(super) fn source_costs(
        &self,
        patch: &RefPatch,
        (x, y): (usize, usize),
        ray: &[f32; 3],
        (d, m): (f32, Option<&[f32; 3]>),
        k: usize,
    ) -> (f32, f32) {
        let src = &self.sources[k];
        let (u, v) = (x as f32 + 0.5, y as f32 + 0.5);
        let photo = m.map_or(MAX_COST, |m| {
            let h = src.warp.homography(m);
            source_cost(patch, &self.win, u, v, &h, src.image)
        });
        (photo + self.geom_cost(k, (x, y), ray, d), photo)
    }

    /// The geometric term of source `k` at pixel (x, y) for depth `d` (0
    /// in the photometric pass).
    fn geom_cost(&self, k: usize, (x, y): (usize, usize), ray: &[f32; 3], d: f32) -> f32 {
        self.geom.as_ref().map_or(0.0, |g| {
            let cap = self.params.geom_max_error_px;
            let e = reprojection_error(&self.k, cap, &self.sources[k].rel, &g[k], (x, y), ray, d);
            self.params.geom_regularizer * e
        })
    }

    /// Costs (ranking, photometric) of the seed plane (d, n) whose
    /// photometric cost over every source, `photo`, the photometric pass
    /// found (`seed_photo`): every source is averaged, so the ranking cost
    /// is `photo` plus the mean geometric term, with no window scored.
    /// The same value as [`Problem::cost`]'s up to the order of the
    /// additions. A plane whose photometric cost is below the worst was
    /// scorable then, at this pixel with this patch, and is now: only the
    /// others need the patch built (into `patch`) to tell.
    fn known_photo_cost(
        &self,
        patch: &mut RefPatch,
        xy: (usize, usize),
        ray: &[f32; 3],
        (d, n): (f32, &[f32; 3]),
        photo: f32,
    ) -> (f32, f32) {
        if !(photo < MAX_COST) {
            patch.build(self.image, xy.0, xy.1, &self.win);
            if !self.scorable(patch, ray, d, n) {
                return self.worst();
            }
        }
        let m = self.sources.len();
        let geo: f32 = (0..m).map(|k| self.geom_cost(k, xy, ray, d)).sum();
        (photo + geo / m as f32, photo)
    }

    /// Costs (ranking, photometric) of plane (d, n) at pixel (x, y) over
    /// the sources in bit mask `sources`; the worst costs as soon as the
    /// ranking cost provably reaches `bound` (the current best: the
    /// hypothesis would be rejected anyway, so the remaining sources are
    /// not scored).
    #[allow(clippy::too_many_arguments)]
    pub(super) fn cost(
        &self,
        patch: &RefPatch,
        xy: (usize, usize),
        ray: &[f32; 3],
        d: f32,
        n: &[f32; 3],
        bound: f32,
        sources: u32,
    ) -> (f32, f32) {
        if !self.scorable(patch, ray, d, n) {
            return self.worst();
        }
        let row = plane_row(&self.k, d, n, ray);
        let mut costs = [(MAX_COST, MAX_COST); MAX_SOURCES];
        let m = sources.count_ones() as usize;
        let mut j = 0;
        for k in (0..self.sources.len()).filter(|k| sources & (1 << k) != 0) {
            costs[j] = self.source_costs(patch, xy, ray, (d, row.as_ref()), k);
            j += 1;
            if j < m && aggregate_lower_bound(&mut costs[..j], m, self.top_k) >= bound {
                return self.worst();
            }
        }
        aggregate(&mut costs[..m], self.top_k)
    }

    /// Every source, as a bit mask.
    pub(super) fn all_sources(&self) -> u32 {
        u32::MAX >> (MAX_SOURCES - self.sources.len())
    }

    /// The `keep` sources (bit mask) with the lowest ranking cost for the
    /// seed plane (d, n) at pixel (x, y), and the plane's costs over them
    /// (those over every source: `keep` is at least `top_k`); every source
    /// where the plane cannot be scored.
    pub(super) fn seed_sources(
        &self,
        patch: &RefPatch,
        xy: (usize, usize),
        ray: &[f32; 3],
        (d, n): (f32, &[f32; 3]),
        keep: usize,
    ) -> ((f32, f32), u32) {
        if !self.scorable(patch, ray, d, n) {
            return (self.worst(), self.all_sources());
        }
        let m = self.sources.len();
        let row = plane_row(&self.k, d, n, ray);
        let mut ranked = [(MAX_COST, MAX_COST, 0); MAX_SOURCES];
        for (k, r) in ranked[..m].iter_mut().enumerate() {
            let (c, p) = self.source_costs(patch, xy, ray, (d, row.as_ref()), k);
            *r = (c, p, k);
        }
        ranked[..m].sort_unstable_by(|a, b| a.0.total_cmp(&b.0).then(a.2.cmp(&b.2)));
        let mut kept = [(MAX_COST, MAX_COST); MAX_SOURCES];
        let mut mask = 0;
        for (slot, &(c, p, k)) in kept.iter_mut().zip(&ranked[..keep]) {
            *slot = (c, p);
            mask |= 1 << k;
        }
        (aggregate(&mut kept[..keep], self.top_k), mask)
    }

    pub(super) fn geom_worst(&self) -> f32 {
        if self.geom.is_some() {
            self.params.geom_regularizer * self.params.geom_max_error_px
        } else {
            0.0
        }
    }
}
