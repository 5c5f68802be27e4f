//! Semi-global matching, in the family of Hirschmüller's SGM (PAMI 2008)
//! and SURE's tSGM (Rothermel et al. 2012): the fast dense stereo, and the
//! matcher whose confidence falls with the triangulation angle (the paper's
//! SURE), next to the PatchMatch of [`crate::patchmatch`].
//!
//! Per (reference, source) pair: rectification ([`rectify`], Fusiello et
//! al. 2000) with the disparity interval from the depth range, a census
//! 9x7 cost, aggregation along 8 (or 4) paths, winner-take-all with
//! uniqueness, parabola sub-pixel, left-right check and speckle filter
//! ([`matching`]), and the disparities turned back into depths on the
//! reference's own (unrectified) pixel grid. A reference with several
//! sources fuses its pairs' depths per pixel (multi-baseline, as SURE
//! does): the largest group of depths within `pair_tolerance_px` of
//! disparity of each other, its median kept when the group has `min_agreeing_pairs`
//! members (or all the pairs that gave a depth, if fewer). The output is a
//! [`DepthNormalMap`] like PatchMatch's, so the geometric filter, fusion
//! and COLMAP's files follow unchanged. Integer aggregation and a fixed
//! order: the same inputs give the same bytes for any thread count.

mod costs;
mod fusion;
pub(crate) mod matching;
pub(crate) mod rectify;
#[cfg(test)]
mod reference;
#[cfg(test)]
pub(crate) mod tests;
mod winners;

use std::fmt::Write as _;

use nalgebra::Vector3;
use rayon::prelude::*;
use serde::{Deserialize, Serialize};

use crate::error::{MvsError, Result};
use crate::params::MvsParams;
use crate::patchmatch::DepthNormalMap;
use crate::view::View;
use fusion::PairDepth;
use matching::RectifiedPair;
use rectify::{Rectification, RectifyError};

/// Which dense matcher [`crate::reconstruct`] runs.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, Serialize, Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum Algorithm {
    /// Slanted-plane PatchMatch with NCC (COLMAP-like; [`crate::patch_match`]).
    #[default]
    PatchMatch,
    /// Semi-global matching on rectified pairs ([`semi_global`]).
    Sgm,
}

impl std::fmt::Display for Algorithm {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str(match self {
            Algorithm::PatchMatch => "patchmatch",
            Algorithm::Sgm => "sgm",
        })
    }
}

/// Which right-image winner a left pixel's disparity is checked against
/// (the left-right consistency check).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, Serialize, Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum LeftRight {
    /// Hirschmüller (PAMI 2008, sec. 3.4): the right pixel's own winner,
    /// the smallest aggregated sum along its whole epipolar line; a left
    /// pixel is kept when its disparity is within `lr_max_diff` of it.
    Hirschmuller,
    /// OpenCV StereoSGBM's rule: a right pixel takes the disparity of the
    /// unique left winner with the smallest sum that lands on it (none: no
    /// check), and a left pixel is dropped only when the right pixels at
    /// both the floor and the ceiling of its sub-pixel disparity disagree
    /// by more than `lr_max_diff`. It keeps more pixels where the
    /// disparity changes by more than 1 px per pixel (slanted surfaces
    /// seen from wide angles). The default: with it vp-mvs's matcher is
    /// within gate G0's 10 points of StereoSGBM on converging pairs up to
    /// 45 deg, with Hirschmüller's rule 13.8 points below at 35-45 deg
    /// (docs/campaign-findings.md, "Gate G0").
    #[default]
    Opencv,
}

/// How the multi-baseline fusion decides that two pairs agree on a
/// pixel's depth ([`fusion`]).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, Serialize, Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum PairAgreement {
    /// Within `pair_depth_tolerance` of each other, relative to the depth.
    /// In disparity that is 1 % of each pair's disparity: a few hundredths
    /// of a pixel for a narrow pair, more than one for a wide one, so it
    /// rejects narrow-angle pixels most (docs/campaign-findings.md, "G1
    /// again, and why SGM rose"). The default until 2026-12-04; kept for
    /// comparison with the runs made with it.
    Relative,
    /// Within `pair_tolerance_px` pixels of disparity in the reference's
    /// narrowest pair (its focal length times baseline over the depth):
    /// the same test in image space at every baseline, as SURE's
    /// consistency check and COLMAP's geometric filter work in pixels.
    /// The default: issue 35 asks for a fusion "as SURE does", and the
    /// relative rule was not that (docs/campaign-findings.md, "G1 on the
    /// fusion the issue specified").
    #[default]
    Pixels,
}

/// Parameters of the semi-global matcher (the `[sgm]` table of a config).
/// The defaults are published ones, not tuned here: census 9x7, P1 = 10,
/// P2 = 120, 8 paths, uniqueness 0.95 and a left-right tolerance of 1 px
/// are libSGM's defaults for its census 9x7 cost (Fixstars, the census
/// matcher of Hernandez-Juarez et al. 2016); the speckle filter is OpenCV
/// StereoSGBM's usual 100 px window and 2 px range.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct SgmParams {
    /// Census window width, pixels (odd; width * height - 1 <= 64 bits).
    pub census_width: u32,
    /// Census window height, pixels (odd).
    pub census_height: u32,
    /// Penalty of a 1 px disparity change between neighbours (cost units:
    /// census bits).
    pub p1: u16,
    /// Penalty of a larger disparity change.
    pub p2: u16,
    /// Aggregation paths: 8 (Hirschmüller's) or 4 (horizontal and vertical).
    pub paths: u32,
    /// The best aggregated cost must be at most this share of every cost
    /// two or more disparities away (1 disables).
    pub uniqueness: f32,
    /// Largest left-right disparity difference, pixels.
    pub lr_max_diff: u32,
    /// Which right winner the left-right check compares with.
    pub left_right: LeftRight,
    /// Speckle filter: connected regions of at most this many pixels are
    /// dropped (0 disables).
    pub speckle_size: u32,
    /// Speckle filter: neighbours within this disparity difference (pixels)
    /// belong to one region.
    pub speckle_range: f32,
    /// Most disparities a pair may search; a depth range that needs more
    /// is refused (narrow it, or raise this: memory is up to width x
    /// height x disparities x 2 bytes, about half that when both sweeps
    /// run at once).
    pub max_disparities: u32,
    /// Multi-baseline fusion: pairs whose depths must agree before a pixel
    /// keeps one (fewer when fewer pairs gave a depth there).
    pub min_agreeing_pairs: u32,
    /// Multi-baseline fusion: relative depth difference within which two
    /// pairs agree (`pair_agreement = "relative"`).
    pub pair_depth_tolerance: f32,
    /// Multi-baseline fusion: how two pairs' depths agree.
    pub pair_agreement: PairAgreement,
    /// Multi-baseline fusion: disparity difference, pixels of the narrowest
    /// pair, within which two pairs agree (`pair_agreement = "pixels"`).
    /// 1 px as COLMAP's geometric consistency
    /// (`filter_geom_consistency_max_cost`), not tuned here.
    pub pair_tolerance_px: f32,
}

impl Default for SgmParams {
    fn default() -> Self {
        SgmParams {
            census_width: 9,
            census_height: 7,
            p1: 10,
            p2: 120,
            paths: 8,
            uniqueness: 0.95,
            lr_max_diff: 1,
            left_right: LeftRight::Opencv,
            speckle_size: 100,
            speckle_range: 2.0,
            max_disparities: 512,
            min_agreeing_pairs: 2,
            pair_depth_tolerance: 0.01,
            pair_agreement: PairAgreement::Pixels,
            pair_tolerance_px: 1.0,
        }
    }
}

impl SgmParams {
    /// Checks the ranges; the error names the parameter and its value.
    pub fn validate(&self) -> Result<()> {
        let bad = |m: String| Err(MvsError::InvalidArgument(m));
        let (cw, ch) = (self.census_width, self.census_height);
        if cw % 2 == 0 || ch % 2 == 0 || cw * ch < 9 || cw * ch > 65 {
            return bad(format!(
                "sgm.census_width = {cw} and sgm.census_height = {ch} must be odd with \
                 3 * 3 <= width * height <= 65 (one bit per window pixel but the centre)"
            ));
        }
        if !(self.p1 > 0 && self.p1 < self.p2 && self.p2 <= 8000) {
            return bad(format!(
                "sgm.p1 = {} and sgm.p2 = {} must satisfy 0 < p1 < p2 <= 8000",
                self.p1, self.p2
            ));
        }
        if self.paths != 4 && self.paths != 8 {
            return bad(format!("sgm.paths = {} must be 4 or 8", self.paths));
        }
        if !(self.uniqueness > 0.0 && self.uniqueness <= 1.0) {
            return bad(format!(
                "sgm.uniqueness = {} is outside (0, 1]",
                self.uniqueness
            ));
        }
        if !(self.speckle_range >= 0.0 && self.speckle_range.is_finite()) {
            return bad(format!(
                "sgm.speckle_range = {} must be >= 0",
                self.speckle_range
            ));
        }
        if !(2..=4096).contains(&self.max_disparities) {
            return bad(format!(
                "sgm.max_disparities = {} is outside 2..=4096",
                self.max_disparities
            ));
        }
        if self.min_agreeing_pairs == 0 {
            return bad("sgm.min_agreeing_pairs must be at least 1".into());
        }
        if !(self.pair_depth_tolerance > 0.0 && self.pair_depth_tolerance < 1.0) {
            return bad(format!(
                "sgm.pair_depth_tolerance = {} is outside (0, 1)",
                self.pair_depth_tolerance
            ));
        }
        if !(self.pair_tolerance_px > 0.0 && self.pair_tolerance_px.is_finite()) {
            return bad(format!(
                "sgm.pair_tolerance_px = {} must be > 0",
                self.pair_tolerance_px
            ));
        }
        Ok(())
    }

    /// The `[sgm]` table of the defaults, each field after its doc line.
    pub(crate) fn defaults_toml() -> String {
        let d = SgmParams::default();
        let fields: [(&str, &str, String); 15] = [
            (
                "census_width",
                "Census window width, pixels (odd).",
                d.census_width.to_string(),
            ),
            (
                "census_height",
                "Census window height, pixels (odd).",
                d.census_height.to_string(),
            ),
            (
                "p1",
                "Penalty of a 1 px disparity step (census bits; libSGM's default).",
                d.p1.to_string(),
            ),
            (
                "p2",
                "Penalty of a larger disparity step (libSGM's default).",
                d.p2.to_string(),
            ),
            ("paths", "Aggregation paths: 8 or 4.", d.paths.to_string()),
            (
                "uniqueness",
                "Best cost at most this share of every cost 2+ disparities away (1: off).",
                format!("{:?}", d.uniqueness),
            ),
            (
                "lr_max_diff",
                "Left-right check: largest disparity difference, pixels.",
                d.lr_max_diff.to_string(),
            ),
            (
                "left_right",
                "Left-right check against \"hirschmuller\" (the right pixel's own winner) or \"opencv\" (the best left winner landing on it).",
                format!("\"{}\"", match d.left_right {
                    LeftRight::Hirschmuller => "hirschmuller",
                    LeftRight::Opencv => "opencv",
                }),
            ),
            (
                "speckle_size",
                "Speckle filter: regions of at most this many pixels are dropped (0: off).",
                d.speckle_size.to_string(),
            ),
            (
                "speckle_range",
                "Speckle filter: disparity difference within a region, pixels.",
                format!("{:?}", d.speckle_range),
            ),
            (
                "max_disparities",
                "Most disparities per pair (a wider depth range is refused).",
                d.max_disparities.to_string(),
            ),
            (
                "min_agreeing_pairs",
                "Multi-baseline fusion: pairs that must agree on a pixel's depth.",
                d.min_agreeing_pairs.to_string(),
            ),
            (
                "pair_depth_tolerance",
                "Multi-baseline fusion: relative depth difference of agreeing pairs (pair_agreement = \"relative\").",
                format!("{:?}", d.pair_depth_tolerance),
            ),
            (
                "pair_agreement",
                "Multi-baseline fusion: pairs agree in \"relative\" depth or in \"pixels\" of the narrowest pair's disparity.",
                format!("\"{}\"", match d.pair_agreement {
                    PairAgreement::Relative => "relative",
                    PairAgreement::Pixels => "pixels",
                }),
            ),
            (
                "pair_tolerance_px",
                "Multi-baseline fusion: disparity difference of agreeing pairs, pixels (pair_agreement = \"pixels\").",
                format!("{:?}", d.pair_tolerance_px),
            ),
        ];
        let mut s = String::from(
            "\n# Semi-global matcher (algorithm = \"sgm\"); defaults are libSGM's and OpenCV's.\n[sgm]\n",
        );
        for (name, doc, value) in fields {
            let _ = write!(s, "\n# {doc}\n{name} = {value}\n");
        }
        s
    }
}

/// Semi-global matching of a pair that is already rectified (epipolar
/// lines are rows, the same size): the disparity `x_left - x_right` of each
/// left pixel, searched over `min_disparity .. min_disparity +
/// num_disparities`, NaN where the checks reject it. The matcher of
/// [`semi_global`] without the rectification and back-projection, for
/// rectified data sets (Middlebury, KITTI) and for timing the matcher on
/// its own against other stereo matchers (`benches/sgm.rs`).
pub fn rectified_disparity(
    left: &crate::GreyImage,
    right: &crate::GreyImage,
    min_disparity: i32,
    num_disparities: usize,
    params: &SgmParams,
) -> Result<Vec<f32>> {
    params.validate()?;
    if (left.width, left.height) != (right.width, right.height) {
        return Err(MvsError::InvalidArgument(format!(
            "a rectified pair has two images of one size: the left one is {}x{}, the right one {}x{}",
            left.width, left.height, right.width, right.height
        )));
    }
    let n = left.width as usize * left.height as usize;
    if left.data.len() != n || right.data.len() != n {
        return Err(MvsError::InvalidArgument(format!(
            "a {}x{} image needs {n} intensities; the pair has {} and {}",
            left.width,
            left.height,
            left.data.len(),
            right.data.len()
        )));
    }
    if num_disparities == 0 || num_disparities > params.max_disparities as usize {
        return Err(MvsError::InvalidArgument(format!(
            "{num_disparities} disparities: search between 1 and sgm.max_disparities = {}",
            params.max_disparities
        )));
    }
    let (w, h) = (left.width as usize, left.height as usize);
    // Index k compares left x with right x - k - min_disparity: shift the
    // right image by min_disparity, so the matcher searches 0..n.
    // Row by row: right x - shift lands at x where 0 <= x - shift < w
    // (a slice copy per row, not a division per pixel).
    let shift = i64::from(min_disparity);
    let mut right_shifted = vec![0.0f32; w * h];
    let mut right_valid = vec![false; w * h];
    let lo = shift.clamp(0, w as i64) as usize;
    let hi = (w as i64 + shift).clamp(0, w as i64) as usize;
    for ((dst, ok), src) in right_shifted
        .chunks_exact_mut(w)
        .zip(right_valid.chunks_exact_mut(w))
        .zip(right.data.chunks_exact(w))
    {
        if hi > lo {
            let from = (lo as i64 - shift) as usize;
            dst[lo..hi].copy_from_slice(&src[from..from + (hi - lo)]);
            ok[lo..hi].fill(true);
        }
    }
    let pair = RectifiedPair {
        width: w,
        height: h,
        left: left.data.clone(),
        left_valid: vec![true; w * h],
        right: right_shifted,
        right_valid,
        n_disp: num_disparities,
    };
    let mut disp = matching::match_pair(&pair, params);
    for d in &mut disp {
        *d += min_disparity as f32;
    }
    Ok(disp)
}

/// The depth of one pair on the reference's grid (0: none).
fn pair_depth(
    views: &[View],
    reference: usize,
    source: usize,
    params: &MvsParams,
) -> Result<PairDepth> {
    let (rv, sv) = (&views[reference], &views[source]);
    let sgm = &params.sgm;
    let rect = match Rectification::new(
        &rv.camera,
        &sv.camera,
        rv.depth_range,
        sgm.max_disparities as usize,
    ) {
        Ok(r) => r,
        Err(RectifyError::Degenerate(_)) => {
            // No row structure for this pair: it gives no depth, the
            // others still may.
            let (w, h) = rv.size();
            return Ok(PairDepth {
                depth: vec![0.0; w * h],
                focal_baseline: None,
            });
        }
        Err(RectifyError::TooManyDisparities(n)) => {
            return Err(MvsError::InvalidArgument(format!(
                "semi-global matching of '{}' against '{}' needs {n} disparities for the depth \
                 range {:?}, more than sgm.max_disparities = {}: narrow the depth range \
                 (--depth-range MIN,MAX) or raise sgm.max_disparities in the --config",
                rv.name, sv.name, rv.depth_range, sgm.max_disparities
            )))
        }
    };
    let (left, left_valid) = rect.resample(&rv.camera, &rv.grey, false);
    let (right, right_valid) = rect.resample(&sv.camera, &sv.grey, true);
    let pair = RectifiedPair {
        width: rect.width,
        height: rect.height,
        left,
        left_valid,
        right,
        right_valid,
        n_disp: rect.n_disp,
    };
    let disp = matching::match_pair(&pair, sgm);
    Ok(PairDepth {
        depth: back_to_depth(&disp, &rect, rv),
        focal_baseline: Some(rect.f * rect.baseline),
    })
}

/// Depth on the reference's own pixels from the rectified disparities:
/// bilinear between the four nearest disparities when they are all valid
/// and within 1 px of each other, else the nearest one; depths outside
/// the view's depth range are dropped.
fn back_to_depth(disp: &[f32], rect: &Rectification, view: &View) -> Vec<f32> {
    let (w, h) = view.size();
    let (rw, rh) = (rect.width as isize, rect.height as isize);
    let at = |x: isize, y: isize| -> f32 {
        if x < 0 || y < 0 || x >= rw || y >= rh {
            f32::NAN
        } else {
            disp[y as usize * rect.width + x as usize]
        }
    };
    let (lo, hi) = view.depth_range;
    let mut out = vec![0.0f32; w * h];
    out.par_chunks_mut(w).enumerate().for_each(|(y, row)| {
        for (x, o) in row.iter_mut().enumerate() {
            let Some((u, v, rz)) = rect.to_rectified(&view.camera, x, y) else {
                continue;
            };
            let (fu, fv) = (u - 0.5, v - 0.5);
            let (x0, y0) = (fu.floor() as isize, fv.floor() as isize);
            let q = [
                at(x0, y0),
                at(x0 + 1, y0),
                at(x0, y0 + 1),
                at(x0 + 1, y0 + 1),
            ];
            let lo_q = q.iter().copied().fold(f32::INFINITY, f32::min);
            let hi_q = q.iter().copied().fold(f32::NEG_INFINITY, f32::max);
            let k = if q.iter().all(|d| !d.is_nan()) && hi_q - lo_q <= 1.0 {
                let (ax, ay) = (fu - x0 as f64, fv - y0 as f64);
                let top = f64::from(q[0]) + ax * f64::from(q[1] - q[0]);
                let bottom = f64::from(q[2]) + ax * f64::from(q[3] - q[2]);
                top + ay * (bottom - top)
            } else {
                let d = at(u.floor() as isize, v.floor() as isize);
                if d.is_nan() {
                    continue;
                }
                f64::from(d)
            };
            if let Some(z) = rect.depth(rz, k) {
                if z >= lo && z <= hi {
                    *o = z as f32;
                }
            }
        }
    });
    out
}

/// Semi-global matching of `views[reference]` against each of `sources`
/// (at most `max_sources`), fused over the pairs into one depth map with
/// normals from the depth gradient. `cost` is 0 for every pixel: SGM has
/// no NCC to report.
///
/// # Performance
/// Per pair: the rectified width x height x disparities cells each get
/// their census cost once per sweep (two sweeps) and one step per path;
/// memory is at most 2 bytes per cell (the sums one sweep leaves for the
/// other), about 1 when both sweeps run side by side.
pub fn semi_global(
    views: &[View],
    reference: usize,
    sources: &[usize],
    params: &MvsParams,
) -> Result<DepthNormalMap> {
    params.sgm.validate()?;
    let (w, h) = views[reference].size();
    let pairs: Vec<PairDepth> = sources
        .iter()
        .take(params.max_sources)
        .map(|&s| pair_depth(views, reference, s, params))
        .collect::<Result<_>>()?;
    let depth = fusion::fuse(&pairs, (w, h), &params.sgm);
    let normal = normals(&views[reference], &depth);
    Ok(DepthNormalMap {
        width: w as u32,
        height: h as u32,
        depth,
        normal,
        cost: vec![0.0; w * h],
    })
}

/// Camera-frame normals from the depth map: the cross product of the
/// steps to the right (or left) and lower (or upper) neighbours with a
/// depth within 5 % of the pixel's, turned toward the camera; the reverse
/// viewing ray where no neighbour qualifies.
fn normals(view: &View, depth: &[f32]) -> Vec<[f32; 3]> {
    let (w, h) = view.size();
    let k = view.camera.intrinsics;
    let point = |x: usize, y: usize, d: f32| {
        let d = f64::from(d);
        Vector3::new(
            (x as f64 + 0.5 - k.cx) / k.fx * d,
            (y as f64 + 0.5 - k.cy) / k.fy * d,
            d,
        )
    };
    let mut out = vec![[0.0f32; 3]; w * h];
    out.par_chunks_mut(w).enumerate().for_each(|(y, row)| {
        for (x, n) in row.iter_mut().enumerate() {
            let d = depth[y * w + x];
            if !(d > 0.0) {
                continue;
            }
            let p = point(x, y, d);
            let near = |xx: usize, yy: usize| {
                let e = depth[yy * w + xx];
                (e > 0.0 && (e - d).abs() <= 0.05 * d).then(|| point(xx, yy, e) - p)
            };
            let dx = (x + 1 < w)
                .then(|| near(x + 1, y))
                .flatten()
                .or_else(|| (x > 0).then(|| near(x - 1, y).map(|v| -v)).flatten());
            let dy = (y + 1 < h)
                .then(|| near(x, y + 1))
                .flatten()
                .or_else(|| (y > 0).then(|| near(x, y - 1).map(|v| -v)).flatten());
            let mut nv = match (dx, dy) {
                (Some(a), Some(b)) => a.cross(&b).try_normalize(1e-12),
                _ => None,
            }
            .unwrap_or_else(|| -p.normalize());
            if nv.dot(&p) > 0.0 {
                nv = -nv;
            }
            *n = [nv.x as f32, nv.y as f32, nv.z as f32];
        }
    });
    out
}
