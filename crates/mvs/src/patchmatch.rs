//! PatchMatch stereo for one reference image against its sources: random
//! initialisation, red-black checkerboard propagation of planes from
//! neighbours, random refinement of depth and normal.

use rayon::prelude::*;

use crate::cost::{RefPatch, Window, MAX_COST};
use crate::error::{MvsError, Result};
use crate::geom_term::{GeomSource, Photometric};
pub use crate::maps::DepthNormalMap;
use crate::params::MvsParams;
use crate::pyramid::{half, half_k, upsample};
use crate::rng::PixelRng;
use crate::view::{k_of, GreyImage, Relative, View};
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
                normal: &state.normal,
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
}

/// `dst = src`, rows of `w` copied in parallel.
fn copy_rows<T: Copy + Send + Sync>(dst: &mut [T], src: &[T], w: usize) {
    dst.par_chunks_mut(w)
        .zip(src.par_chunks(w))
        .for_each(|(d, s)| d.copy_from_slice(s));
}

#[path = "scoring.rs"]
mod scoring;

#[path = "update.rs"]
mod update;
use update::random_normal;

#[cfg(test)]
#[path = "patchmatch_tests.rs"]
mod tests;
