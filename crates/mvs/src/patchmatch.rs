//! PatchMatch stereo for one reference image against its sources: random
//! initialisation, red-black checkerboard propagation of planes from
//! neighbours, random refinement of depth and normal.

use rayon::prelude::*;

use crate::cost::{RefPatch, Window, MAX_COST};
use crate::error::{MvsError, Result};
use crate::geom_term::{agrees, GeomSource, Photometric};
pub use crate::maps::DepthNormalMap;
use crate::params::MvsParams;
use crate::pyramid::{half, half_k, upsample};
use crate::rng::PixelRng;
use crate::view::{k_of, pixel_ray, GreyImage, Relative, View};
use crate::warp::PairWarp;

/// Most sources scored per hypothesis (a stack array holds their costs).
pub const MAX_SOURCES: usize = 32;

/// Neighbours a pixel takes plane hypotheses from, a near and a far one
/// per direction: all at an odd Manhattan distance, so they have the other
/// checkerboard colour and stay fixed while this colour is updated
/// (Gipuma's pattern). Of each pair only the one with the lower cost is
/// scored (ACMH's idea of picking the best neighbour per region): half the
/// propagation work for nearly the same reach.
const NEIGHBOURS: [[(i32, i32); 2]; 4] = [
    [(0, -1), (0, -5)],
    [(0, 1), (0, 5)],
    [(-1, 0), (-5, 0)],
    [(1, 0), (5, 0)],
];

/// One plane hypothesis and its costs.
#[derive(Debug, Clone, Copy, PartialEq)]
pub(crate) struct Hyp {
    pub d: f32,
    pub n: [f32; 3],
    /// Cost that ranks hypotheses (photometric, plus the geometric term in
    /// the geometric pass).
    pub cost: f32,
    /// Photometric part of `cost` over the same selected sources.
    pub photo: f32,
}

/// One source image of a reference, at one pyramid level.
struct Source<'a> {
    rel: Relative,
    /// The pair's part of every plane's homography (for this level's
    /// intrinsics).
    warp: PairWarp,
    image: &'a GreyImage,
}

impl<'a> Source<'a> {
    fn new(rel: Relative, kr: &[f32; 4], image: &'a GreyImage) -> Self {
        Source {
            warp: PairWarp::new(&rel, kr),
            rel,
            image,
        }
    }
}

/// What one reference's PatchMatch needs, in f32.
struct Problem<'a> {
    image: &'a GreyImage,
    k: [f32; 4],
    sources: Vec<Source<'a>>,
    /// The sources' photometric depths: set in the geometric pass.
    geom: Option<Vec<GeomSource<'a>>>,
    /// The geometric pass's seed planes' photometric costs over every
    /// source, averaged, when the photometric pass found them (see
    /// [`Photometric::same_sources`]): the seed then adds the mean
    /// geometric term to them instead of scoring the windows again.
    seed_photo: Option<&'a [f32]>,
    range: (f32, f32),
    /// Cosine of the largest normal-to-view angle.
    min_cos: f32,
    top_k: usize,
    win: Window,
    params: &'a MvsParams,
    view_key: u64,
    /// Pyramid level (0 = full resolution): part of the random keys, so
    /// that each level draws its own numbers.
    level: u32,
    /// Skip the propagation candidates scored before (`run`); off only in
    /// the test that holds the two ways equal bit for bit.
    skip_unchanged: bool,
}

/// The raw PatchMatch state of one view (every pixel's winning hypothesis).
pub(crate) struct RawState {
    pub width: usize,
    pub height: usize,
    pub hyps: Vec<Hyp>,
    /// Each pixel's chosen sources (bit masks) when the pass chose
    /// `seeded_sources` of them (see `Problem::run`); `None` when every
    /// pixel scored every source.
    pub sources: Option<Vec<u32>>,
}

/// Where a pass starts from: pixel index -> (depth, normal) of a solved
/// plane (the coarser level's, upsampled, or the photometric pass's).
type Seed<'a> = &'a (dyn Fn(usize) -> (f32, [f32; 3]) + Sync);

/// A plane for every pixel: (pixel index, its ray, its current
/// hypothesis) -> (depth, normal).
type PlaneOf<'a> = &'a (dyn Fn(usize, &[f32; 3], &Hyp) -> (f32, [f32; 3]) + Sync);

/// Runs PatchMatch for `views[reference]` against `views[s]` for `s` in
/// `sources`.
///
/// # Performance
/// Per iteration each pixel scores up to 4 propagated (`fine_neighbours`
/// at the finer pyramid levels) and 3 refined
/// hypotheses (1 refined in passes that start from solved planes, unless
/// `seeded_random_candidates`), each against every source (in passes that
/// start from solved planes, the pixel's best `seeded_sources`) over the
/// window samples (36 by default): that product is the work. Rows run in parallel
/// (rayon); the output does not depend on the thread count.
pub fn patch_match(
    views: &[View],
    reference: usize,
    sources: &[usize],
    params: &MvsParams,
) -> Result<DepthNormalMap> {
    Ok(patch_match_raw(views, reference, sources, params, None)?.to_map(params))
}

/// PatchMatch, photometric (`previous` = `None`) or geometric: then every
/// source's unfiltered photometric map is in `previous`, the reference's
/// starts from its own planes, and each source's cost gains
/// `geom_regularizer * min(forward-backward reprojection error, geom_max_error_px)`.
pub(crate) fn patch_match_raw(
    views: &[View],
    reference: usize,
    sources: &[usize],
    params: &MvsParams,
    previous: Option<Photometric<'_>>,
) -> Result<RawState> {
    patch_match_raw_with(views, (reference, sources), params, previous, true)
}

/// [`patch_match_raw`], with or without skipping the propagation
/// candidates scored before (the same result either way; tested).
fn patch_match_raw_with(
    views: &[View],
    (reference, sources): (usize, &[usize]),
    params: &MvsParams,
    previous: Option<Photometric<'_>>,
    skip_unchanged: bool,
) -> Result<RawState> {
    params.validate()?;
    let view = views.get(reference).ok_or_else(|| {
        MvsError::InvalidArgument(format!("reference view {reference} does not exist"))
    })?;
    if sources.is_empty() || sources.len() > MAX_SOURCES {
        return Err(MvsError::InvalidArgument(format!(
            "image '{}': {} source images (need 1 to {MAX_SOURCES})",
            view.name,
            sources.len()
        )));
    }
    let k = k_of(&view.camera);
    let mut rel = Vec::with_capacity(sources.len());
    let mut geom = previous.map(|_| Vec::with_capacity(sources.len()));
    for &s in sources {
        let src = views.get(s).filter(|_| s != reference).ok_or_else(|| {
            MvsError::InvalidArgument(format!(
                "image '{}': source view {s} does not exist or is the reference",
                view.name
            ))
        })?;
        let r = Relative::new(&view.camera, &src.camera);
        if let (Some(prev), Some(g)) = (previous, geom.as_mut()) {
            let state = prev.maps.get(s).and_then(Option::as_ref).ok_or_else(|| {
                MvsError::InvalidArgument(format!(
                    "image '{}': source '{}' has no photometric depth map for the geometric pass",
                    view.name, src.name
                ))
            })?;
            g.push(GeomSource {
                depth: &state.depth,
                width: state.width as usize,
                height: state.height as usize,
                rot_back: std::array::from_fn(|i| std::array::from_fn(|j| r.rot[j][i])),
            });
        }
        rel.push(Source::new(r, &k, &src.grey));
    }
    let init = previous.and_then(|p| p.maps.get(reference)?.as_ref());
    // The seed's photometric costs, when the photometric pass's are them
    // (see `Photometric::same_sources`).
    let n_sources = rel.len();
    let seed_photo = init.zip(previous).and_then(|(init, p)| {
        (p.same_sources && n_sources <= params.top_k_sources && init.cost.len() == init.depth.len())
            .then_some(&init.cost[..])
    });
    let problem = Problem {
        image: &view.grey,
        k,
        sources: rel,
        geom,
        seed_photo,
        range: (view.depth_range.0 as f32, view.depth_range.1 as f32),
        min_cos: params.max_normal_view_angle_deg.to_radians().cos(),
        top_k: params.top_k_sources,
        win: Window::new(params),
        params,
        view_key: reference as u64,
        level: 0,
        skip_unchanged,
    };
    Ok(match init {
        Some(init) => problem.run(
            Some(&|i: usize| (init.depth[i], init.normal[i])),
            None,
            params.geom_iterations,
        ),
        None => problem.solve(params.coarse_levels),
    })
}

impl RawState {
    /// The winning planes and their photometric costs, unfiltered: what
    /// the geometric pass starts from and reads the sources' depths in (20
    /// bytes a pixel against the hypotheses' 24), and, once filtered by
    /// [`DepthNormalMap::photometric`], the photometric map.
    pub(crate) fn unfiltered(&self) -> DepthNormalMap {
        DepthNormalMap {
            width: self.width as u32,
            height: self.height as u32,
            depth: self.hyps.iter().map(|h| h.d).collect(),
            normal: self.hyps.iter().map(|h| h.n).collect(),
            cost: self.hyps.iter().map(|h| h.photo).collect(),
        }
    }

    /// The photometric map: [`RawState::unfiltered`], filtered.
    pub(crate) fn to_map(&self, params: &MvsParams) -> DepthNormalMap {
        self.unfiltered().photometric(params)
    }
}

impl Problem<'_> {
    /// PatchMatch from random planes, first on `levels` halvings of the
    /// images (while their smaller side keeps `coarse_min_size` pixels):
    /// the coarsest level runs `iterations`, each finer one starts from the
    /// coarser winners and runs `fine_iterations`.
    fn solve(&self, levels: u32) -> RawState {
        let (w, h) = (self.image.width as usize, self.image.height as usize);
        if levels == 0 || (w.min(h) / 2) < self.params.coarse_min_size as usize {
            return self.run(None, None, self.params.iterations);
        }
        let images: Vec<GreyImage> = std::iter::once(self.image)
            .chain(self.sources.iter().map(|s| s.image))
            .map(half)
            .collect();
        let k = half_k(&self.k);
        let coarse = Problem {
            image: &images[0],
            k,
            sources: self
                .sources
                .iter()
                .zip(&images[1..])
                .map(|(s, img)| {
                    let rel = Relative {
                        k: half_k(&s.rel.k),
                        ..s.rel
                    };
                    Source::new(rel, &k, img)
                })
                .collect(),
            geom: None,
            seed_photo: None,
            range: self.range,
            min_cos: self.min_cos,
            top_k: self.top_k,
            win: self.win.clone(),
            params: self.params,
            view_key: self.view_key,
            level: self.level + 1,
            skip_unchanged: self.skip_unchanged,
        };
        let low = coarse.solve(levels - 1);
        let init = upsample(&low, &coarse.k, w, h, &self.k, MAX_COST);
        self.run(
            Some(&|i: usize| (init.hyps[i].d, init.hyps[i].n)),
            init.sources.as_deref(),
            self.params.fine_iterations,
        )
    }

    /// `iterations` of PatchMatch from `init` (scored afresh) or, without
    /// it, from random planes; each pixel's hypotheses scored on the
    /// sources `chosen` for it at a coarser level, if given.
    ///
    /// View selection (`seeded_sources`, when it keeps fewer than all):
    /// once a pixel's plane is nearly solved, only the sources with the
    /// lowest cost for it are scored. A pass from random planes chooses
    /// them after half its iterations, for each pixel's plane then; a pass
    /// from solved planes, for the seed plane, unless the choice was made
    /// at a coarser level (then it is carried down, pixel to parent, and
    /// the seed is scored on those sources only). The choice never changes
    /// a pixel's cost: `seeded_sources` is at least `top_k_sources`, so the
    /// best sources include the averaged ones.
    fn run(&self, init: Option<Seed<'_>>, chosen: Option<&[u32]>, iterations: u32) -> RawState {
        let (w, h) = (self.image.width as usize, self.image.height as usize);
        // The geometric pass and each pyramid level draw other numbers
        // than the full-resolution photometric pass.
        let pass =
            (if self.geom.is_some() { 1u64 << 32 } else { 0 }) | (u64::from(self.level) << 40);
        let mut state: Vec<Hyp> = vec![
            Hyp {
                d: 0.0,
                n: [0.0, 0.0, -1.0],
                cost: MAX_COST,
                photo: MAX_COST,
            };
            w * h
        ];
        // The sources each pixel scores its hypotheses on (see above).
        let keep = self.params.seeded_sources;
        let choosing = keep > 0 && keep < self.sources.len();
        let chosen = chosen.filter(|c| choosing && c.len() == w * h);
        let subset = init.is_some() && choosing && chosen.is_none();
        let mut sources = chosen.map_or_else(|| vec![self.all_sources(); w * h], <[u32]>::to_vec);
        let start = |idx: usize, ray: &[f32; 3], _: &Hyp| {
            if let Some(seed) = init {
                return seed(idx);
            }
            let mut rng = PixelRng::new(self.params.seed, self.view_key, idx as u64, pass);
            let d = self.random_depth(&mut rng);
            (d, random_normal(&mut rng, ray))
        };
        self.score_planes((&mut state, &mut sources), subset.then_some(keep), &start);
        // Whether each pixel's hypothesis changed at its last update. Every
        // propagation neighbour is of the other colour, updated in the half
        // between two updates of a pixel: one that did not change offers
        // the same candidate the pixel already scored, against a best
        // that is at most as costly now, so skipping it changes nothing
        // (bit for bit, when any change counts, `settle_cost` 0, and every
        // neighbour's plane is scored, `fine_neighbours` 4; `update`).
        let mut changed = vec![true; w * h];
        let settled = self.settled_seeds(&state, &sources);
        let random_candidates = init.is_none() || self.params.seeded_random_candidates;
        // Propagation candidates a pixel scores: fewer at the finer levels.
        let neighbours = if init.is_some() && self.geom.is_none() {
            self.params.fine_neighbours
        } else {
            NEIGHBOURS.len()
        };
        let choose_at = (init.is_none() && choosing && iterations >= 2).then_some(iterations / 2);
        // The state and flags a half-iteration reads, copied from the last
        // one's output into buffers kept for the whole pass (a fresh clone
        // each half was a serial copy into newly faulted pages).
        let mut prev = state.clone();
        let mut seen = changed.clone();
        for it in 0..iterations {
            if choose_at == Some(it) {
                // The current planes, on their best sources (their costs
                // stay the same: see above).
                let current = |_: usize, _: &[f32; 3], hyp: &Hyp| (hyp.d, hyp.n);
                self.score_planes((&mut state, &mut sources), Some(keep), &current);
            }
            for colour in 0..2 {
                copy_rows(&mut prev, &state, w);
                if it > 0 {
                    copy_rows(&mut seen, &changed, w);
                }
                let seen = (it > 0).then_some(&seen[..]);
                let prev = &prev[..];
                let step = pass + 1 + 2 * u64::from(it) + colour as u64;
                state
                    .par_chunks_mut(w)
                    .zip(changed.par_chunks_mut(w))
                    .enumerate()
                    .for_each(|(y, (row, flags))| {
                        let mut patch = RefPatch::default();
                        let mut x = (y + colour) % 2;
                        while x < w {
                            // Kept as seeded (`geom_settled_px`).
                            if it == 0 && settled.as_ref().is_some_and(|s| s[y * w + x]) {
                                flags[x] = false;
                                x += 2;
                                continue;
                            }
                            let old = row[x];
                            row[x] = self.update(
                                (prev, seen, &sources),
                                &mut patch,
                                (x, y),
                                (it, step, random_candidates, neighbours),
                            );
                            flags[x] = self.changed(&old, &row[x]);
                            x += 2;
                        }
                    });
            }
        }
        let chose = choosing && (init.is_some() || choose_at.is_some());
        RawState {
            width: w,
            height: h,
            hyps: state,
            sources: chose.then_some(sources),
        }
    }

    /// In the geometric pass (with `geom_settled_px` above 0), the pixels
    /// left as seeded: those whose seed plane every source they score
    /// (`sources`) already agrees with as the geometric filter asks
    /// ([`agrees`]: within `geom_settled_px` pixels and `max_depth_diff`),
    /// and whose propagation neighbours are in the same case. This is the
    /// settle rule of `update` with "disagrees" for "changed": a pixel next
    /// to one to be repaired is still updated, and may take a better plane
    /// from it. The first iteration does not update settled pixels, and
    /// marks them unchanged for the next ones. A pixel whose plane could
    /// not be scored never agrees, nor any without a geometric term
    /// (`geom_regularizer` 0).
    fn settled_seeds(&self, seeds: &[Hyp], sources: &[u32]) -> Option<Vec<bool>> {
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
                h.photo < MAX_COST
                    && (0..self.sources.len())
                        .filter(|k| mask & (1 << k) != 0)
                        .all(|k| {
                            agrees(
                                &self.k,
                                bounds,
                                &self.sources[k].rel,
                                &geom[k],
                                (x, y),
                                &ray,
                                h.d,
                            )
                        })
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
    fn changed(&self, old: &Hyp, new: &Hyp) -> bool {
        let settle = self.params.settle_cost;
        if settle > 0.0 {
            old.cost - new.cost > settle
        } else {
            !same_bits(old, new)
        }
    }

    fn random_depth(&self, rng: &mut PixelRng) -> f32 {
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
    fn update(
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

/// `dst = src`, rows of `w` copied in parallel.
fn copy_rows<T: Copy + Send + Sync>(dst: &mut [T], src: &[T], w: usize) {
    dst.par_chunks_mut(w)
        .zip(src.par_chunks(w))
        .for_each(|(d, s)| d.copy_from_slice(s));
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
fn random_normal(rng: &mut PixelRng, ray: &[f32; 3]) -> [f32; 3] {
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

#[path = "scoring.rs"]
mod scoring;

#[cfg(test)]
#[path = "patchmatch_tests.rs"]
mod tests;
