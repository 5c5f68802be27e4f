//! Every parameter of the MVS in one serialisable struct, with documented
//! defaults ([`MvsParams::defaults_toml`] prints them commented).

use std::fmt::Write as _;

use serde::{Deserialize, Serialize};

use crate::error::{MvsError, Result};
use crate::sgm::{Algorithm, SgmParams};

/// Parameters of PatchMatch, geometric filtering and fusion. Missing fields
/// in a config take their defaults.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct MvsParams {
    /// The dense matcher: PatchMatch (default) or semi-global matching.
    /// The geometric filter and fusion parameters below serve both; the
    /// PatchMatch ones (window, iterations, NCC, geometric pass) are unused
    /// by SGM, whose own are in `sgm`.
    pub algorithm: Algorithm,
    /// Seed of every random choice (per-pixel hash, so the output does not
    /// depend on the thread count).
    pub seed: u64,
    /// Half size of the matching window, pixels (5: an 11x11 window).
    pub window_radius: u32,
    /// Step between window samples, pixels (2: 6x6 of the 11x11 samples).
    pub window_step: u32,
    /// Leave the window grid's four corner samples out. They are the
    /// farthest from the centre (the smallest spatial weight, e^-1 of the
    /// centre's at the defaults), and without them the default 6x6 grid's
    /// 32 samples fill four 8-lane chunks of the cost's hot loop exactly,
    /// where 36 need five. Off by default: it saved about 5 % of the time
    /// on Brighton, but cost depth precision where the window is large
    /// against the image (median error on a 96 x 72 rendered triplet about
    /// 3 % higher, past the Python binding test's 1 % bar; the rendered
    /// peer pair's geometric map 0.7-0.8 points lower; docs/performance.md,
    /// "Stop 55").
    pub window_drop_corners: bool,
    /// Spatial sigma of the bilateral weights, pixels.
    pub sigma_spatial: f32,
    /// Colour sigma of the bilateral weights, grey levels in [0, 1].
    pub sigma_color: f32,
    /// PatchMatch iterations (each: red pixels, then black pixels); with
    /// coarse-to-fine, the iterations of the coarsest level.
    pub iterations: u32,
    /// Coarse-to-fine: number of half-resolution levels solved before the
    /// full resolution (0: none). A level is only added while its smaller
    /// side keeps `coarse_min_size` pixels. The coarsest level starts from
    /// random planes and scores every source for half its iterations:
    /// about five times a finer level's work per pixel (136 source
    /// scorings a pixel against 27 on Brighton), so each level that
    /// shrinks it to a quarter pays. 2 (stop 53): 0.82 of the CPU of one
    /// level on Brighton at 2000 px; 3 with `coarse_min_size` 128 (stop
    /// 57, Brighton's 2000 x 1125 photos get a 250 x 140 coarsest level):
    /// 0.86 of the time on 9 of its photos; with the stop's faster window
    /// kernel, 0.859 of stop 56's time on all 18 (a clean build, measured
    /// at stop 58), and 94.5 % of COLMAP's sparse points within 1 % against
    /// 94.6 % (64.7 against 65.0 % on the 9); at full resolution (4 photos)
    /// 3.5 % fewer fused points. Guarded by
    /// `two_coarse_levels_keep_the_quality_of_one` and
    /// `three_coarse_levels_keep_the_quality_of_two`; docs/performance.md,
    /// "Stop 53" and "Stop 57".
    pub coarse_levels: u32,
    /// Coarse-to-fine: smallest side (pixels) a halved level may have.
    /// 160 (stop 53): 640 x 480 images and 800 px photos got the coarse
    /// level (with 256 they ran single scale); 128 (stop 57, the one other
    /// value tried): a third level for Brighton at 2000 px (above), and a
    /// coarse level for the 387 x 288 real-photo test's images (median
    /// error 0.068 % against 0.075 % single scale). Above the 120 px
    /// coarse level the coarse-to-fine guard checks
    /// (`coarse_to_fine_keeps_single_scale_quality`).
    pub coarse_min_size: u32,
    /// Coarse-to-fine: iterations of each level finer than the coarsest,
    /// which starts from the coarser level's planes.
    pub fine_iterations: u32,
    /// Coarse-to-fine: propagation at each level finer than the coarsest.
    /// A pixel is offered up to four neighbours' planes (one per direction);
    /// it scores only the `fine_neighbours` of them whose neighbours have
    /// the lowest cost (4: all). The planes come from the coarser solution
    /// and neighbours mostly offer nearly the same plane; the lowest-cost
    /// ones are the likeliest to win. 2, half, is the one value chosen
    /// (docs/performance.md, "Stop 59"): `fast_256` CPU about 0.86, 9
    /// Brighton photos about 0.88; the peer pairs' maps 0.05-0.2 points
    /// lower (StereoSGBM's bar held as before), the real-photo test's
    /// median error 0.067 % against 0.068 %. The geometric pass, which
    /// repairs inconsistent pixels by propagation, keeps all four: two
    /// there too cost the rendered pair's geometric map 0.7-0.8 points.
    /// Guarded by `two_fine_neighbours_keep_the_quality_of_four`.
    pub fine_neighbours: usize,
    /// Refinement in passes that start from solved planes (the finer
    /// pyramid levels and the geometric pass): `false` tries only the
    /// perturbation of the pixel's plane, `true` also a random depth and a
    /// random normal, as the first pass does. Once the planes come from a
    /// solution the random candidates rarely win, and they are most of the
    /// work left (propagation skips unchanged neighbours): `false` took
    /// 0.76 of the time on `paper_1024` with the quality bars held
    /// (docs/performance.md, "Stop 53"), and is the default.
    pub seeded_random_candidates: bool,
    /// Early stop per pixel: from a pass's second iteration on, a pixel is
    /// settled, and not updated again in the pass, when neither it nor any
    /// neighbour it takes planes from changed at its last update; a
    /// change is a cost lowered by more than `settle_cost` (0: any change
    /// of the plane). With 0, a settled pixel's only candidate left is its
    /// perturbation, and nearly every pixel's perturbation wins by some
    /// small amount: hardly any pixel settles (no time saved on Brighton).
    /// 0.01, a hundredth of the NCC's range from no correlation to a
    /// perfect one, was chosen by that rule and is the only other value
    /// run: 0.87 of the time on 9 Brighton photos, quality bars held
    /// (docs/performance.md, "Stop 55"). Above 0, a neighbour whose cost
    /// fell by less is taken as unchanged, and its plane is not offered
    /// again.
    pub settle_cost: f32,
    /// Number of best source costs averaged per hypothesis (view selection:
    /// an occluded or mismatched source beyond the best k does not count).
    pub top_k_sources: usize,
    /// View selection once a pixel's plane is nearly solved: each pixel
    /// scores its hypotheses on only the `seeded_sources` sources with the
    /// lowest cost for its plane (0: every source). A source that does not
    /// see the plane's surface (occluded, out of frame) would never be
    /// among the `top_k_sources` averaged: scoring it is wasted work, most
    /// of the work where a view has many sources (8 on a real flight
    /// against 2 in a triplet). The coarsest level chooses after half its
    /// iterations, and the finer levels keep that choice (pixel to
    /// parent); the geometric pass chooses afresh for its seed plane, as
    /// its ranking adds the geometric term. 4 is `top_k_sources` (3) plus
    /// one spare, so that a better plane may still trade one source of its
    /// best three; chosen by that rule, not by a measurement
    /// (docs/performance.md, "Stop 54" and "Stop 55").
    pub seeded_sources: usize,
    /// Most source images per reference image.
    pub max_sources: usize,
    /// Margin added on both sides of a depth range derived from sparse
    /// points, as a share of the range.
    pub depth_range_margin: f64,
    /// Photometric filter: smallest NCC (1 - cost) a depth keeps.
    pub min_ncc: f32,
    /// Geometric filter: a source is consistent when the forward-backward
    /// reprojection error is at most this many pixels ...
    pub max_reproj_error_px: f32,
    /// ... and the depths differ by at most this share.
    pub max_depth_diff: f32,
    /// Geometric filter: consistent sources a pixel needs.
    pub min_consistent_sources: usize,
    /// Geometric filter: smallest triangulation angle (degrees) between the
    /// reference and its consistent sources at the pixel's point.
    pub min_triangulation_angle_deg: f64,
    /// Fusion: fewest pixels (reference included) a fused point needs.
    pub min_fused_pixels: usize,
    /// Smallest angle (degrees) between a normal and the viewing ray's
    /// reverse that a hypothesis may have before it faces away (grazing
    /// planes match nothing reliably).
    pub max_normal_view_angle_deg: f32,
    /// Run a second, geometric PatchMatch pass (as COLMAP's
    /// `geom_consistency`): each source's cost gains a penalty for the
    /// forward-backward reprojection error through that source's
    /// photometric depth map.
    pub geom_consistency: bool,
    /// Iterations of the geometric pass, which starts from the photometric
    /// planes. One, not COLMAP's five: on rendered rock and ground, 2 kept
    /// the completeness of 6 within 0.5 points, with fewer outliers, in
    /// 0.65x the time (docs/performance.md, "Fewer geometric iterations");
    /// since the photometric planes come from coarse-to-fine with view
    /// selection, 1 scores as well as 2 on the peer pairs (rendered +0.5
    /// points within 2 px, Motorcycle equal) and the suite's guard holds it
    /// to 6's bar ("Stop 54").
    pub geom_iterations: u32,
    /// Weight of the reprojection error (pixels) in the geometric pass
    /// (COLMAP's `geom_consistency_regularizer`).
    pub geom_regularizer: f32,
    /// Cap of the reprojection error in the geometric pass, pixels (COLMAP's
    /// `geom_consistency_max_cost`).
    pub geom_max_error_px: f32,
    /// Geometric pass: a pixel whose photometric plane as many of the
    /// sources it scores as its cost averages (`top_k_sources`) already
    /// agree with as the geometric filter asks (the
    /// forward-backward reprojection error within this many pixels, the
    /// depths within `max_depth_diff`), and whose propagation neighbours
    /// are in the same case, keeps that plane and is not updated; 0
    /// updates every pixel, as COLMAP does. The pass exists to repair
    /// pixels the sources disagree with, by propagating consistent
    /// neighbours' planes into them; a consistent pixel's update is most of
    /// the pass's work and seldom changes whether the filter keeps it.
    /// 1 pixel is the geometric filter's own bound (`max_reproj_error_px`),
    /// chosen by that rule, not by a sweep. The rule itself is the fourth
    /// of four variants, each measured: a mean reprojection error alone
    /// settled nearly every pixel of a two-view pair and cost its
    /// geometric map 2 points (docs/performance.md, "Stop 61"). Guarded by
    /// `settled_geometric_pixels_keep_the_quality_of_all`.
    pub geom_settled_px: f32,
    /// Parameters of the semi-global matcher (the `[sgm]` table).
    pub sgm: SgmParams,
}

impl Default for MvsParams {
    fn default() -> Self {
        MvsParams {
            algorithm: Algorithm::PatchMatch,
            seed: 0,
            window_radius: 5,
            window_step: 2,
            window_drop_corners: false,
            sigma_spatial: 5.0,
            sigma_color: 0.1,
            iterations: 6,
            coarse_levels: 3,
            coarse_min_size: 128,
            fine_iterations: 2,
            fine_neighbours: 2,
            seeded_random_candidates: false,
            settle_cost: 0.01,
            top_k_sources: 3,
            seeded_sources: 4,
            max_sources: 8,
            depth_range_margin: 0.2,
            min_ncc: 0.3,
            max_reproj_error_px: 1.0,
            max_depth_diff: 0.01,
            min_consistent_sources: 1,
            min_triangulation_angle_deg: 1.0,
            min_fused_pixels: 2,
            max_normal_view_angle_deg: 80.0,
            geom_consistency: true,
            geom_iterations: 1,
            geom_regularizer: 0.3,
            geom_max_error_px: 3.0,
            geom_settled_px: 1.0,
            sgm: SgmParams::default(),
        }
    }
}

/// `vpctl mvs --config` (the whole file) and a campaign's `[patchmatch]`;
/// missing keys take [`MvsParams::default`].
impl vp_scene::config_file::ConfigSection for MvsParams {
    type Error = MvsError;

    fn check(&self, place: &str) -> Result<()> {
        // `place` is the file, or the file and section; the error names the file.
        self.validate().map_err(|e| MvsError::Config {
            path: place.into(),
            message: e.to_string(),
        })
    }
}

impl MvsParams {
    /// Checks the ranges; the error names the parameter and its value.
    pub fn validate(&self) -> Result<()> {
        let bad = |m: String| Err(MvsError::InvalidArgument(m));
        if self.window_step == 0 || self.window_radius == 0 || self.window_radius > 32 {
            return bad(format!(
                "window_radius = {} and window_step = {} must be positive (radius <= 32)",
                self.window_radius, self.window_step
            ));
        }
        if self.window_step > self.window_radius {
            return bad(format!(
                "window_step = {} exceeds window_radius = {}",
                self.window_step, self.window_radius
            ));
        }
        if !(self.sigma_spatial > 0.0 && self.sigma_color > 0.0) {
            return bad(format!(
                "sigma_spatial = {} and sigma_color = {} must be positive",
                self.sigma_spatial, self.sigma_color
            ));
        }
        if !(self.settle_cost >= 0.0 && self.settle_cost < 2.0) {
            return bad(format!(
                "settle_cost = {} must be in [0, 2) (a cost change; costs are in [0, 2])",
                self.settle_cost
            ));
        }
        if self.coarse_levels > 0 && self.coarse_min_size < 2 * self.window_radius + 1 {
            return bad(format!(
                "coarse_min_size = {} is smaller than the window (2 * window_radius + 1 = {})",
                self.coarse_min_size,
                2 * self.window_radius + 1
            ));
        }
        if !(1..=4).contains(&self.fine_neighbours) {
            return bad(format!(
                "fine_neighbours = {} must be 1 to 4 (a pixel has four propagation neighbours)",
                self.fine_neighbours
            ));
        }
        if self.top_k_sources == 0 || self.max_sources == 0 {
            return bad("top_k_sources and max_sources must be at least 1".into());
        }
        if self.seeded_sources != 0 && self.seeded_sources < self.top_k_sources {
            return bad(format!(
                "seeded_sources ({}) must be 0 (every source) or at least top_k_sources ({})",
                self.seeded_sources, self.top_k_sources
            ));
        }
        if !(self.depth_range_margin >= 0.0 && self.depth_range_margin.is_finite()) {
            return bad(format!(
                "depth_range_margin = {} must be >= 0",
                self.depth_range_margin
            ));
        }
        if !(-1.0..=1.0).contains(&self.min_ncc) {
            return bad(format!("min_ncc = {} is outside [-1, 1]", self.min_ncc));
        }
        if !(self.max_reproj_error_px > 0.0 && self.max_depth_diff > 0.0) {
            return bad(format!(
                "max_reproj_error_px = {} and max_depth_diff = {} must be positive",
                self.max_reproj_error_px, self.max_depth_diff
            ));
        }
        if !(0.0..180.0).contains(&self.min_triangulation_angle_deg) {
            return bad(format!(
                "min_triangulation_angle_deg = {} is outside [0, 180)",
                self.min_triangulation_angle_deg
            ));
        }
        if !(self.max_normal_view_angle_deg > 0.0 && self.max_normal_view_angle_deg < 90.0) {
            return bad(format!(
                "max_normal_view_angle_deg = {} is outside (0, 90)",
                self.max_normal_view_angle_deg
            ));
        }
        if !(self.geom_regularizer >= 0.0 && self.geom_max_error_px > 0.0) {
            return bad(format!(
                "geom_regularizer = {} must be >= 0 and geom_max_error_px = {} > 0",
                self.geom_regularizer, self.geom_max_error_px
            ));
        }
        if !(self.geom_settled_px >= 0.0 && self.geom_settled_px.is_finite()) {
            return bad(format!(
                "geom_settled_px = {} must be >= 0 (0: every pixel is updated)",
                self.geom_settled_px
            ));
        }
        self.sgm.validate()
    }

    /// Window sample offsets along one axis: `-r, -r + step, ..., <= r`.
    pub(crate) fn window_offsets(&self) -> Vec<i32> {
        let r = self.window_radius as i32;
        (-r..=r).step_by(self.window_step as usize).collect()
    }

    /// The window's samples, offsets (x, y) from its centre, row by row:
    /// the grid of [`MvsParams::window_offsets`], without its corners when
    /// `window_drop_corners`.
    pub(crate) fn window_samples(&self) -> Vec<(i32, i32)> {
        let offsets = self.window_offsets();
        let (first, last) = (offsets[0], offsets[offsets.len() - 1]);
        let corner = |o: i32| o == first || o == last;
        offsets
            .iter()
            .flat_map(|&oy| offsets.iter().map(move |&ox| (ox, oy)))
            .filter(|&(ox, oy)| !(self.window_drop_corners && corner(ox) && corner(oy)))
            .collect()
    }

    /// Number of window samples a hypothesis is scored on, per source.
    pub fn window_sample_count(&self) -> usize {
        self.window_samples().len()
    }

    /// Parses a TOML config (missing fields take defaults) and validates it;
    /// `path` names the file in errors (the argument order of every vpctl
    /// config reader: the text, then where it came from).
    pub fn from_toml(text: &str, path: &std::path::Path) -> Result<Self> {
        // The one reader of every vpctl config: file, line, column, and the
        // valid keys when a key is unknown.
        vp_scene::config_file::read_section(text, path, "")
    }

    /// The defaults as TOML, each field preceded by its documentation.
    pub fn defaults_toml() -> String {
        let d = MvsParams::default();
        let fields: [(&str, &str, String); 30] = [
            ("algorithm", "Dense matcher: \"patchmatch\" or \"sgm\" (semi-global matching, parameters in [sgm] below).", format!("\"{}\"", d.algorithm)),
            ("seed", "Seed of every random choice (same seed, same bytes for any thread count).", d.seed.to_string()),
            ("window_radius", "Half size of the matching window, pixels (5: an 11x11 window).", d.window_radius.to_string()),
            ("window_step", "Step between window samples, pixels.", d.window_step.to_string()),
            ("window_drop_corners", "Leave the window grid's four corner samples out (36 -> 32 samples at the defaults: four 8-lane chunks instead of five).", d.window_drop_corners.to_string()),
            ("sigma_spatial", "Spatial sigma of the bilateral NCC weights, pixels.", fmt_f(f64::from(d.sigma_spatial))),
            ("sigma_color", "Colour sigma of the bilateral NCC weights, grey levels in [0, 1].", fmt_f(f64::from(d.sigma_color))),
            ("iterations", "PatchMatch iterations (red-black propagation + random refinement); with coarse-to-fine, at the coarsest level.", d.iterations.to_string()),
            ("coarse_levels", "Coarse-to-fine: half-resolution levels solved before the full resolution (0: none).", d.coarse_levels.to_string()),
            ("coarse_min_size", "Coarse-to-fine: smallest side (pixels) of a halved level; smaller images skip the level.", d.coarse_min_size.to_string()),
            ("fine_iterations", "Coarse-to-fine: iterations at each level finer than the coarsest (it starts from the coarser planes).", d.fine_iterations.to_string()),
            ("fine_neighbours", "Coarse-to-fine: of a pixel's four propagation neighbours, the planes of this many with the lowest cost are scored at each finer level (4: all).", d.fine_neighbours.to_string()),
            ("seeded_random_candidates", "Passes that start from solved planes (finer levels, geometric pass) also try a random depth and normal, not only a perturbation.", d.seeded_random_candidates.to_string()),
            ("top_k_sources", "View selection: the best k source costs are averaged per hypothesis.", d.top_k_sources.to_string()),
            ("settle_cost", "Early stop per pixel: settled when neither it nor a neighbour lowered its cost by more than this at its last update (0: changed at all).", fmt_f(f64::from(d.settle_cost))),
            ("seeded_sources", "View selection in passes from solved planes: each pixel scores only its best this many sources for the seed plane (0: all).", d.seeded_sources.to_string()),
            ("max_sources", "Most source images per reference image.", d.max_sources.to_string()),
            ("depth_range_margin", "Margin on both sides of a depth range from sparse points, share of the range.", fmt_f(d.depth_range_margin)),
            ("min_ncc", "Photometric filter: smallest NCC a depth keeps.", fmt_f(f64::from(d.min_ncc))),
            ("max_reproj_error_px", "Geometric filter: largest forward-backward reprojection error, pixels.", fmt_f(f64::from(d.max_reproj_error_px))),
            ("max_depth_diff", "Geometric filter: largest relative depth difference.", fmt_f(f64::from(d.max_depth_diff))),
            ("min_consistent_sources", "Geometric filter: consistent source views a pixel needs.", d.min_consistent_sources.to_string()),
            ("min_triangulation_angle_deg", "Geometric filter: smallest triangulation angle with the consistent sources, degrees.", fmt_f(d.min_triangulation_angle_deg)),
            ("min_fused_pixels", "Fusion: fewest pixels (reference included) per fused point.", d.min_fused_pixels.to_string()),
            ("max_normal_view_angle_deg", "Largest angle between a normal and the reversed viewing ray, degrees.", fmt_f(f64::from(d.max_normal_view_angle_deg))),
            ("geom_consistency", "Second, geometric PatchMatch pass: penalise reprojection error through the sources' depth maps.", d.geom_consistency.to_string()),
            ("geom_iterations", "Geometric pass: PatchMatch iterations, starting from the photometric planes.", d.geom_iterations.to_string()),
            ("geom_regularizer", "Geometric pass: weight of the reprojection error (pixels) in the cost.", fmt_f(f64::from(d.geom_regularizer))),
            ("geom_max_error_px", "Geometric pass: cap of the reprojection error, pixels.", fmt_f(f64::from(d.geom_max_error_px))),
            ("geom_settled_px", "Geometric pass: a pixel whose photometric plane its sources agree with within this many pixels (and max_depth_diff), as its neighbours' do, keeps it (0: every pixel is updated).", fmt_f(f64::from(d.geom_settled_px))),
        ];
        let mut s = String::from(
            "# vp-mvs parameters (vpctl mvs run --config FILE); every field is optional.\n",
        );
        for (name, doc, value) in fields {
            let _ = write!(s, "\n# {doc}\n{name} = {value}\n");
        }
        s.push_str(&SgmParams::defaults_toml());
        s
    }
}

fn fmt_f(v: f64) -> String {
    let s = format!("{v}");
    if s.contains('.') || s.contains('e') {
        s
    } else {
        format!("{s}.0")
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn defaults_toml_round_trips_and_validates() {
        let text = MvsParams::defaults_toml();
        let p = MvsParams::from_toml(&text, std::path::Path::new("mvs.toml")).unwrap();
        assert_eq!(p, MvsParams::default());
        assert_eq!(p.window_offsets(), vec![-5, -3, -1, 1, 3, 5]);
    }

    #[test]
    fn bad_config_names_file_and_field() {
        let e = MvsParams::from_toml("min_ncc = 3.0", std::path::Path::new("m.toml")).unwrap_err();
        assert!(e.to_string().starts_with("m.toml: "), "{e}");
        assert!(e.to_string().contains("min_ncc"), "{e}");
        let e = MvsParams::from_toml("fine_neighbours = 0", std::path::Path::new("m.toml"))
            .unwrap_err();
        assert!(e.to_string().contains("fine_neighbours = 0"), "{e}");
        let e = MvsParams::from_toml("\nbogus = 1", std::path::Path::new("m.toml")).unwrap_err();
        let m = e.to_string();
        assert!(
            m.starts_with("m.toml: line 2: column 1: unknown field `bogus`, expected one of"),
            "{m}"
        );
        assert!(m.contains("`window_radius`"), "{m}");
    }
}
