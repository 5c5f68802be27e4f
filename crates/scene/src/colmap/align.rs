//! Georegistration of a sparse model, as COLMAP's `model_aligner` does it:
//! a similarity transform (scale, rotation, translation) from the model's
//! camera centres to known image positions in a local ENU frame, robust to a
//! few bad positions (RANSAC over minimal triples, then a least-squares fit
//! on the inliers, Umeyama's method). The file that records the result
//! next to the model, `frame.json`, and its check are in `frame.rs`.

use std::path::Path;

use nalgebra::{Isometry3, Point3, Translation3, Vector3};
use rand::{Rng, SeedableRng};
use serde::{Deserialize, Serialize};

use super::reconstruction::Reconstruction;
pub use super::strip::StripFit;
use super::strip::{fit_strip, mean_and_scatter, strip_view};
use crate::error::{Result, SceneError};
use crate::sim3::{umeyama, Sim3};

/// One image position used for the alignment, with its residual.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct PositionResidual {
    /// Image name.
    pub name: String,
    /// Distance between the aligned camera centre and the given position (m).
    pub residual_m: f64,
    /// Whether the position was used in the final fit.
    pub inlier: bool,
}

/// Parameters of [`align_to_positions`].
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct AlignParams {
    /// A position farther than this from its aligned camera is an outlier (m).
    pub max_error_m: f64,
    /// RANSAC iterations.
    pub iterations: usize,
    /// Seed of the sampling.
    pub seed: u64,
    /// When the camera centres (or positions) lie on a line, as on a single
    /// strip (corridor) flight: take the rotation about that line from the
    /// cameras' mean viewing direction, assuming they look down (nadir or
    /// oblique, below the horizon), instead of refusing. The rotation chosen
    /// makes the mean viewing direction point as far down as possible.
    pub gravity_from_views: bool,
}

impl Default for AlignParams {
    fn default() -> Self {
        AlignParams {
            max_error_m: 3.0,
            iterations: 2000,
            seed: 0,
            gravity_from_views: false,
        }
    }
}

/// How far a point set is from a line: the second singular value of the
/// centred points over the first (0 for collinear points).
fn planarity(points: &[Point3<f64>]) -> f64 {
    let (_, cov) = mean_and_scatter(points);
    let mut s: Vec<f64> = cov
        .symmetric_eigenvalues()
        .iter()
        .map(|v| v.max(0.0).sqrt())
        .collect();
    s.sort_by(|a, b| b.total_cmp(a));
    if s[0] <= 0.0 {
        0.0
    } else {
        s[1] / s[0]
    }
}

/// Below this [`planarity`] a point set is taken as a line.
const MIN_PLANARITY: f64 = 0.02;

/// A similarity fitted to a minimal sample (`None`: degenerate sample).
type SampleFit<'a> = dyn Fn(&[Point3<f64>], &[Point3<f64>]) -> Option<Sim3> + 'a;

/// RANSAC over minimal samples of `k` points: the largest set of indices
/// whose positions a similarity fitted (`fit`) to `k` of them explains within
/// `max_error_m` (ties: the smaller squared error).
fn ransac_inliers(
    src: &[Point3<f64>],
    dst: &[Point3<f64>],
    params: &AlignParams,
    k: usize,
    fit: &SampleFit<'_>,
) -> Vec<usize> {
    let n = src.len();
    let inliers_of = |s: &Sim3| -> Vec<usize> {
        (0..n)
            .filter(|&i| (s.apply(&src[i]) - dst[i]).norm() <= params.max_error_m)
            .collect()
    };
    let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(params.seed);
    let mut best: Vec<usize> = Vec::new();
    let mut best_err = f64::INFINITY;
    let mut idx = Vec::with_capacity(k);
    for _ in 0..params.iterations {
        idx.clear();
        for _ in 0..k {
            idx.push(rng.random_range(0..n));
        }
        if (1..k).any(|i| idx[..i].contains(&idx[i])) {
            continue;
        }
        let s_k: Vec<_> = idx.iter().map(|&i| src[i]).collect();
        let d_k: Vec<_> = idx.iter().map(|&i| dst[i]).collect();
        let Some(s) = fit(&s_k, &d_k) else {
            continue;
        };
        let inl = inliers_of(&s);
        let e: f64 = inl
            .iter()
            .map(|&i| (s.apply(&src[i]) - dst[i]).norm_squared())
            .sum();
        if inl.len() > best.len() || (inl.len() == best.len() && e < best_err) {
            best = inl;
            best_err = e;
        }
    }
    best
}

/// Umeyama on a sample that fixes all seven parameters (not on a line).
fn fit_general(src: &[Point3<f64>], dst: &[Point3<f64>]) -> Option<Sim3> {
    if planarity(src) < MIN_PLANARITY || planarity(dst) < MIN_PLANARITY {
        return None;
    }
    umeyama(src, dst)
}

/// The result of [`align_to_positions`].
#[derive(Debug, Clone)]
pub struct Alignment {
    /// Model -> ENU transform.
    pub sim3: Sim3,
    /// Residuals of every position that names an image of the model.
    pub residuals: Vec<PositionResidual>,
    /// RMS residual of the inliers (m).
    pub rms_m: f64,
    /// Positions whose name is not an image of the model.
    pub unmatched: Vec<String>,
    /// `Some` when the cameras lie on a line and the rotation about it came
    /// from their viewing directions ([`AlignParams::gravity_from_views`]).
    pub strip: Option<StripFit>,
}

/// Estimates the similarity that maps the model's camera centres onto
/// `positions` (image name, ENU metres), RANSAC over triples then a
/// least-squares fit on the inliers. `source` names the positions (CSV file
/// or photo folder) in errors: fewer than 3 positions of model images,
/// camera centres or positions on a line (rotation about it undetermined;
/// unless `params.gravity_from_views`, which then takes it from the mean
/// viewing direction, fitting pairs instead of triples), or fewer than 3
/// (and fewer than half the) positions consistent within
/// `params.max_error_m`.
pub fn align_to_positions(
    rec: &Reconstruction,
    positions: &[(String, Point3<f64>)],
    params: &AlignParams,
    source: &Path,
) -> Result<Alignment> {
    // The problem is the positions as a whole (a CSV file or a folder of
    // photos), not a place in them: name the source, no line.
    let err = |m: String| SceneError::InvalidArgument(format!("{}: {m}", source.display()));
    // Centre and viewing direction (optical axis, model frame) by name.
    let by_name: std::collections::HashMap<&str, (Point3<f64>, Vector3<f64>)> = rec
        .images
        .values()
        .map(|im| {
            let view = im.cam_from_world.rotation.inverse() * Vector3::z();
            (im.name.as_str(), (im.center(), view))
        })
        .collect();
    let mut names = Vec::new();
    let mut src = Vec::new();
    let mut dst = Vec::new();
    let mut views = Vec::new();
    let mut unmatched = Vec::new();
    for (name, p) in positions {
        match by_name.get(name.as_str()) {
            Some((c, v)) => {
                names.push(name.clone());
                src.push(*c);
                dst.push(*p);
                views.push(*v);
            }
            None => unmatched.push(name.clone()),
        }
    }
    if src.len() < 3 {
        return Err(err(format!(
            "{} position(s) name images of the model ({} images; {} name none): at least 3 are \
             needed to fix scale, rotation and translation",
            src.len(),
            rec.images.len(),
            unmatched.len()
        )));
    }
    let strip = line_check(&src, &dst, &views, params.gravity_from_views).map_err(err)?;
    let on_line = strip.is_some();
    let view = strip.map_or_else(Vector3::zeros, |(v, _)| v);
    let strip = strip.map(|(_, s)| s);
    let fit = |s: &[Point3<f64>], d: &[Point3<f64>]| -> Option<Sim3> {
        if on_line {
            fit_strip(s, d, &view)
        } else {
            fit_general(s, d)
        }
    };
    let n = src.len();
    let inliers_of = |s: &Sim3| -> Vec<usize> {
        (0..n)
            .filter(|&i| (s.apply(&src[i]) - dst[i]).norm() <= params.max_error_m)
            .collect()
    };
    let k = if on_line { 2 } else { 3 };
    let mut best = ransac_inliers(&src, &dst, params, k, &fit);
    if best.len() < k || 2 * best.len() < n {
        return Err(err(format!(
            "the positions are inconsistent with the model: the best similarity explains only {} \
             of {n} positions within {} m (--max-error)",
            best.len(),
            params.max_error_m
        )));
    }
    // Refit on the inliers until they no longer change.
    let mut sim = None;
    for _ in 0..5 {
        let s: Vec<_> = best.iter().map(|&i| src[i]).collect();
        let d: Vec<_> = best.iter().map(|&i| dst[i]).collect();
        let f = if on_line {
            fit_strip(&s, &d, &view)
        } else {
            umeyama(&s, &d)
        };
        let f = f.ok_or_else(|| err("degenerate inlier set".into()))?;
        let inl = inliers_of(&f);
        sim = Some(f);
        if inl == best || inl.len() < k {
            break;
        }
        best = inl;
    }
    let sim = sim.ok_or_else(|| err("no alignment".into()))?;
    let residuals: Vec<PositionResidual> = (0..n)
        .map(|i| PositionResidual {
            name: names[i].clone(),
            residual_m: (sim.apply(&src[i]) - dst[i]).norm(),
            inlier: best.contains(&i),
        })
        .collect();
    let rms_m = inlier_rms(&residuals);
    Ok(Alignment {
        sim3: sim,
        residuals,
        rms_m,
        unmatched,
        strip: strip.map(|st| StripFit {
            view_tilt_deg: (-(sim.rotation() * view).z).asin().to_degrees(),
            ..st
        }),
    })
}

/// Root mean square residual of the inliers.
fn inlier_rms(residuals: &[PositionResidual]) -> f64 {
    let inl: Vec<f64> = residuals
        .iter()
        .filter(|r| r.inlier)
        .map(|r| r.residual_m * r.residual_m)
        .collect();
    (inl.iter().sum::<f64>() / inl.len() as f64).sqrt()
}

/// `None` when neither the camera centres nor the positions lie on a line;
/// if either does, the error (without `gravity_from_views`) or what
/// `strip_view` returns.
fn line_check(
    src: &[Point3<f64>],
    dst: &[Point3<f64>],
    views: &[Vector3<f64>],
    gravity_from_views: bool,
) -> std::result::Result<Option<(Vector3<f64>, StripFit)>, String> {
    let hint = "; if the cameras look down (nadir or oblique, below the horizon), pass \
                --gravity-from-views to take the rotation about the line from their mean \
                viewing direction";
    if planarity(src) < MIN_PLANARITY && !gravity_from_views {
        return Err(format!(
            "the model cannot be aligned: its {} camera centres lie on a line (spread across it \
             {:.3} % of the spread along it), so the rotation about that line is undetermined{hint}",
            src.len(),
            100.0 * planarity(src)
        ));
    }
    if planarity(dst) < MIN_PLANARITY && !gravity_from_views {
        return Err(format!(
            "the positions cannot align the model: the {} positions lie on a line, so the \
             rotation about it is undetermined{hint}",
            dst.len()
        ));
    }
    if planarity(src) < MIN_PLANARITY || planarity(dst) < MIN_PLANARITY {
        strip_view(src, dst, views).map(Some)
    } else {
        Ok(None)
    }
}

/// The model moved by `sim`: points transformed, camera poses composed with
/// the inverse transform (cameras keep their intrinsics).
pub fn transform_reconstruction(rec: &Reconstruction, sim: &Sim3) -> Reconstruction {
    let mut out = rec.clone();
    let rot = sim.rotation();
    for p in out.points.values_mut() {
        p.xyz = sim.apply(&p.xyz);
    }
    for im in out.images.values_mut() {
        let c = sim.apply(&im.center());
        let r_cw = im.cam_from_world.rotation * rot.inverse();
        let t = -(r_cw * c.coords);
        im.cam_from_world = Isometry3::from_parts(Translation3::from(t), r_cw);
    }
    out
}

#[cfg(test)]
mod tests {
    use nalgebra::UnitQuaternion;

    use super::*;

    /// A single strip: cameras on a line (a slight climb), looking down and
    /// a little forward, with per-camera jitter of the view (about 2
    /// degrees), positions with 5 cm noise and one bad position; the model
    /// is the truth moved by the inverse of a known similarity.
    fn strip_model(view_along_line: bool) -> (Reconstruction, Vec<(String, Point3<f64>)>, Sim3) {
        let truth = Sim3 {
            scale: 4.0,
            rotation_wxyz: {
                let q = UnitQuaternion::from_euler_angles(0.7, -0.4, 2.1);
                [q.w, q.i, q.j, q.k]
            },
            translation: [30.0, -12.0, 95.0],
        };
        let q = truth.rotation();
        let line = Vector3::new(0.8, 0.6, 0.05).normalize();
        let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(7);
        let mut noise = |a: f64| {
            Vector3::new(
                rng.random_range(-a..a),
                rng.random_range(-a..a),
                rng.random_range(-a..a),
            )
        };
        let mut rec = Reconstruction::default();
        let mut positions = Vec::new();
        for k in 0..20 {
            let c_w = Point3::from(Vector3::new(10.0, 5.0, 60.0) + line * (8.0 * f64::from(k)));
            let v_w = if view_along_line {
                line + noise(0.03)
            } else {
                -Vector3::z() + 0.3 * line + noise(0.03)
            };
            let c_m = Point3::from(
                q.inverse() * (c_w.coords - Vector3::from(truth.translation)) / truth.scale,
            );
            let v_m = q.inverse() * v_w.normalize();
            let r_wc = UnitQuaternion::rotation_between(&Vector3::z(), &v_m).unwrap();
            let r_cw = r_wc.inverse();
            let name = format!("strip_{k:02}.jpg");
            rec.images.insert(
                k,
                super::super::ColmapImage {
                    id: k,
                    camera_id: 1,
                    name: name.clone(),
                    cam_from_world: Isometry3::from_parts(
                        Translation3::from(-(r_cw * c_m.coords)),
                        r_cw,
                    ),
                    points2d: Vec::new(),
                },
            );
            let bad = if k == 13 {
                Vector3::new(0.0, 25.0, 0.0)
            } else {
                Vector3::zeros()
            };
            positions.push((name, c_w + noise(0.05) + bad));
        }
        (rec, positions, truth)
    }

    #[test]
    fn align_a_strip_takes_the_rotation_about_it_from_the_views() {
        let (rec, positions, truth) = strip_model(false);
        let src = Path::new("strip.csv");
        // Without the flag: refused, and the message names the flag.
        let e = align_to_positions(&rec, &positions, &AlignParams::default(), src)
            .unwrap_err()
            .to_string();
        assert!(
            e.contains("lie on a line") && e.contains("--gravity-from-views"),
            "{e}"
        );
        let params = AlignParams {
            gravity_from_views: true,
            ..AlignParams::default()
        };
        let al = align_to_positions(&rec, &positions, &params, src).unwrap();
        assert!(
            (al.sim3.scale / truth.scale - 1.0).abs() < 0.01,
            "{:?}",
            al.sim3
        );
        let angle = al.sim3.rotation().angle_to(&truth.rotation()).to_degrees();
        assert!(angle < 1.0, "rotation off by {angle} degrees");
        for r in &al.residuals {
            assert_eq!(r.inlier, r.name != "strip_13.jpg", "{r:?}");
        }
        assert!(al.rms_m < 0.2, "{}", al.rms_m);
        // The views were 0.3 along the line per 1 down: 73 degrees down.
        let strip = al.strip.unwrap();
        assert!((strip.view_tilt_deg - 73.3).abs() < 1.5, "{strip:?}");
    }

    #[test]
    fn align_a_strip_refuses_views_along_the_line() {
        let (rec, positions, _) = strip_model(true);
        let params = AlignParams {
            gravity_from_views: true,
            ..AlignParams::default()
        };
        let e = align_to_positions(&rec, &positions, &params, Path::new("strip.csv"))
            .unwrap_err()
            .to_string();
        assert!(
            e.contains("strip.csv") && e.contains("look along it"),
            "{e}"
        );
    }
}
