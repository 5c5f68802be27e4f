//! Undistortion into a dense workspace, as COLMAP's `image_undistorter
//! --output_type COLMAP` does it: every camera becomes a `PINHOLE` camera
//! ([`undistort_camera`]), every image is resampled bilinearly into it
//! ([`undistort_image`]), every 2D feature is moved with it
//! ([`undistort_reconstruction`]), and [`undistort_workspace`] writes
//! `images/`, `sparse/` and `stereo/` — the layout `vp-mvs` reads.

use std::fmt::Write as _;
use std::path::{Path, PathBuf};

use image::{ImageFormat, RgbImage};
use nalgebra::Point2;
use rayon::prelude::*;

use super::model::{CameraModel, ColmapCamera};
use super::reconstruction::Reconstruction;
use super::{detect_format, read_model_as};
use crate::error::{Location, Result, SceneError};
use crate::outdir::OutDir;

/// COLMAP's `UndistortCameraOptions` (its defaults).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct UndistortOptions {
    /// 0: no blank pixels in the output (crop); 1: every input pixel kept.
    pub blank_pixels: f64,
    /// Smallest scale of the output size relative to the input.
    pub min_scale: f64,
    /// Largest scale of the output size relative to the input.
    pub max_scale: f64,
    /// Longest side of the output images, pixels (`None`: no limit), as
    /// COLMAP's `--max_image_size`: a field laptop runs dense stereo and
    /// prediction on a 12-20 Mpx drone photo at a fraction of that.
    pub max_image_size: Option<u32>,
}

impl Default for UndistortOptions {
    fn default() -> Self {
        UndistortOptions {
            blank_pixels: 0.0,
            min_scale: 0.2,
            max_scale: 2.0,
            max_image_size: None,
        }
    }
}

fn camera_error(cam: &ColmapCamera, message: &str) -> SceneError {
    SceneError::InvalidArgument(format!("camera {} ({}): {message}", cam.id, cam.model))
}

/// The `PINHOLE` camera COLMAP's undistorter makes of `cam`: same focal
/// lengths, the image size scaled so that the undistorted image holds no
/// blank pixels (with `blank_pixels = 0`), the principal point scaled with
/// it. `SIMPLE_PINHOLE` and `PINHOLE` cameras are returned unchanged, as
/// COLMAP does.
pub fn undistort_camera(cam: &ColmapCamera, opts: &UndistortOptions) -> Result<ColmapCamera> {
    if cam.model == CameraModel::Equirectangular {
        return Err(camera_error(
            cam,
            "an equirectangular panorama has no pinhole undistortion",
        ));
    }
    cam.model
        .check_param_count(cam.params.len())
        .map_err(|m| camera_error(cam, &m))?;
    let Some((fx, fy, cx, cy)) = cam.focal_and_principal_point() else {
        return Err(camera_error(cam, "no focal length"));
    };
    if !(fx > 0.0 && fy > 0.0 && fx.is_finite() && fy.is_finite())
        || cam.width == 0
        || cam.height == 0
    {
        return Err(camera_error(cam, "focal lengths and size must be positive"));
    }
    // COLMAP (3.8) keeps undistorted cameras as they are (but for the size
    // limit).
    if matches!(cam.model, CameraModel::SimplePinhole | CameraModel::Pinhole) {
        return Ok(limit_size(cam.clone(), opts.max_image_size));
    }
    let mut out = ColmapCamera {
        id: cam.id,
        model: CameraModel::Pinhole,
        width: cam.width,
        height: cam.height,
        params: vec![fx, fy, cx, cy],
    };
    let (w, h) = (cam.width as f64, cam.height as f64);
    // Where the distorted image's border lands in the pinhole image.
    let to_pinhole = |x: f64, y: f64| -> Result<(f64, f64)> {
        let (u, v) = cam.cam_from_img(x, y).ok_or_else(|| {
            camera_error(
                cam,
                &format!("pixel ({x}, {y}) has no ray in front of the camera: cannot undistort to a pinhole"),
            )
        })?;
        Ok((fx * u + cx, fy * v + cy))
    };
    let (mut left_min, mut left_max) = (f64::MAX, f64::MIN);
    let (mut right_min, mut right_max) = (f64::MAX, f64::MIN);
    for y in 0..cam.height {
        let yc = y as f64 + 0.5;
        let (l, _) = to_pinhole(0.5, yc)?;
        let (r, _) = to_pinhole(w - 0.5, yc)?;
        left_min = left_min.min(l);
        left_max = left_max.max(l);
        right_min = right_min.min(r);
        right_max = right_max.max(r);
    }
    let (mut top_min, mut top_max) = (f64::MAX, f64::MIN);
    let (mut bottom_min, mut bottom_max) = (f64::MAX, f64::MIN);
    for x in 0..cam.width {
        let xc = x as f64 + 0.5;
        let (_, t) = to_pinhole(xc, 0.5)?;
        let (_, b) = to_pinhole(xc, h - 0.5)?;
        top_min = top_min.min(t);
        top_max = top_max.max(t);
        bottom_min = bottom_min.min(b);
        bottom_max = bottom_max.max(b);
    }
    // Scale so that the output holds every input pixel ...
    let min_scale_x = (cx / (cx - left_min)).min((w - 0.5 - cx) / (right_max - cx));
    let min_scale_y = (cy / (cy - top_min)).min((h - 0.5 - cy) / (bottom_max - cy));
    // ... or so that it has no blank pixel.
    let max_scale_x = (cx / (cx - left_max)).max((w - 0.5 - cx) / (right_min - cx));
    let max_scale_y = (cy / (cy - top_max)).max((h - 0.5 - cy) / (bottom_min - cy));
    let b = opts.blank_pixels;
    let scale_x =
        (1.0 / (min_scale_x * b + max_scale_x * (1.0 - b))).clamp(opts.min_scale, opts.max_scale);
    let scale_y =
        (1.0 / (min_scale_y * b + max_scale_y * (1.0 - b))).clamp(opts.min_scale, opts.max_scale);
    if !(scale_x.is_finite() && scale_y.is_finite()) {
        return Err(camera_error(cam, "undistorted image size is not finite"));
    }
    // Truncation, as COLMAP's size_t cast.
    out.width = (scale_x * w).max(1.0) as u64;
    out.height = (scale_y * h).max(1.0) as u64;
    out.params[2] = cx * out.width as f64 / w;
    out.params[3] = cy * out.height as f64 / h;
    Ok(limit_size(out, opts.max_image_size))
}

/// COLMAP's size limit (3.8, `UndistortCamera` then `Camera::Rescale`): a
/// camera whose longer side exceeds `max_size` is scaled down to it, its
/// size rounded and its focal lengths and principal point scaled per axis
/// by the rounded size.
fn limit_size(mut cam: ColmapCamera, max_size: Option<u32>) -> ColmapCamera {
    let Some(max) = max_size.filter(|&m| m > 0) else {
        return cam;
    };
    let (w, h) = (cam.width as f64, cam.height as f64);
    let scale = (f64::from(max) / w).min(f64::from(max) / h);
    if scale >= 1.0 {
        return cam;
    }
    let (w2, h2) = ((scale * w).round().max(1.0), (scale * h).round().max(1.0));
    let (sx, sy) = (w2 / w, h2 / h);
    (cam.width, cam.height) = (w2 as u64, h2 as u64);
    if cam.model == CameraModel::SimplePinhole {
        // f, cx, cy: one focal length, scaled by the mean.
        cam.params[0] *= f64::midpoint(sx, sy);
        cam.params[1] *= sx;
        cam.params[2] *= sy;
    } else {
        cam.params[0] *= sx;
        cam.params[1] *= sy;
        cam.params[2] *= sx;
        cam.params[3] *= sy;
    }
    cam
}

/// Bilinear sample at `(x, y)` (pixel-centre coordinates: pixel (i, j) is at
/// (i, j)), `None` outside the interpolation domain. The domain is
/// COLMAP's (3.8): `0 <= x < w - 1` and `0 < y <= h - 1` (its bitmaps are
/// stored bottom-up and it floors the flipped row).
fn bilinear(img: &RgbImage, x: f64, y: f64) -> Option<[f64; 3]> {
    let (w, h) = (f64::from(img.width()), f64::from(img.height()));
    let inv_y = h - 1.0 - y;
    let x0 = x.floor();
    let y0 = inv_y.floor();
    if !(x0 >= 0.0 && x0 + 1.0 < w && y0 >= 0.0 && y0 + 1.0 < h) {
        return None;
    }
    let dx = x - x0;
    let dy = inv_y - y0;
    // Rows in top-down order: flipped row r is image row h - 1 - r.
    let (xi, r0, r1) = (x0 as u32, (h - 1.0 - y0) as u32, (h - 2.0 - y0) as u32);
    let p = |xx: u32, yy: u32| img.get_pixel(xx, yy).0;
    let (a, b, c, d) = (p(xi, r0), p(xi + 1, r0), p(xi, r1), p(xi + 1, r1));
    let mut out = [0.0; 3];
    for k in 0..3 {
        let top = (1.0 - dx) * f64::from(a[k]) + dx * f64::from(b[k]);
        let bottom = (1.0 - dx) * f64::from(c[k]) + dx * f64::from(d[k]);
        out[k] = (1.0 - dy) * top + dy * bottom;
    }
    Some(out)
}

/// Resamples `img`, taken with `distorted`, into the pinhole camera
/// `undistorted` (from [`undistort_camera`]), as COLMAP's
/// `WarpImageBetweenCameras` does: to avoid aliasing the warp runs at the
/// input's resolution (the pinhole camera scaled to it), each pixel centre
/// cast through the pinhole, projected with the full distorted model and
/// sampled bilinearly (black outside the input), and the result is then
/// rescaled to the output size with FreeImage's bilinear filter. The input
/// must have the distorted camera's size.
pub fn undistort_image(
    img: &RgbImage,
    distorted: &ColmapCamera,
    undistorted: &ColmapCamera,
) -> Result<RgbImage> {
    if u64::from(img.width()) != distorted.width || u64::from(img.height()) != distorted.height {
        return Err(camera_error(
            distorted,
            &format!(
                "the image is {}x{}, the camera {}x{}",
                img.width(),
                img.height(),
                distorted.width,
                distorted.height
            ),
        ));
    }
    let Some((fx, fy, cx, cy)) = undistorted.focal_and_principal_point() else {
        return Err(camera_error(undistorted, "not a pinhole camera"));
    };
    let (Ok(w2), Ok(h2)) = (
        u32::try_from(undistorted.width),
        u32::try_from(undistorted.height),
    ) else {
        return Err(camera_error(undistorted, "image size too large"));
    };
    let (w, h) = img.dimensions();
    let sx = f64::from(w) / f64::from(w2);
    let sy = f64::from(h) / f64::from(h2);
    let (fx, fy, cx, cy) = (fx * sx, fy * sy, cx * sx, cy * sy);
    let mut out = RgbImage::new(w, h);
    let row_len = w as usize * 3;
    out.as_mut()
        .par_chunks_mut(row_len.max(1))
        .enumerate()
        .for_each(|(y, row)| {
            let yc = y as f64 + 0.5;
            for x in 0..w as usize {
                let xc = x as f64 + 0.5;
                let (u, v) = ((xc - cx) / fx, (yc - cy) / fy);
                let sample = distorted
                    .img_from_cam(u, v)
                    .and_then(|(sx, sy)| bilinear(img, sx - 0.5, sy - 0.5));
                let px = sample.map_or([0u8; 3], |c| c.map(|v| v.round().clamp(0.0, 255.0) as u8));
                row[3 * x..3 * x + 3].copy_from_slice(&px);
            }
        });
    if (w, h) == (w2, h2) {
        return Ok(out);
    }
    Ok(rescale_bilinear(&out, w2, h2))
}

/// FreeImage's resampling weights (`CWeightsTable`) with its bilinear
/// filter, from `src` to `dst` samples: per output sample, the first input
/// index and the normalised weights.
fn freeimage_weights(src: u32, dst: u32) -> Vec<(usize, Vec<f64>)> {
    let scale = f64::from(dst) / f64::from(src);
    let (width, fscale) = if scale < 1.0 {
        (1.0 / scale, scale)
    } else {
        (1.0, 1.0)
    };
    (0..dst)
        .map(|u| {
            let centre = f64::from(u) / scale + 0.5 / scale;
            let left = ((centre - width + 0.5) as i64).max(0) as usize;
            let right = ((centre + width + 0.5) as i64).min(i64::from(src)).max(0) as usize;
            let mut weights: Vec<f64> = (left..right)
                .map(|i| {
                    let t = (fscale * (i as f64 + 0.5 - centre)).abs();
                    fscale * (1.0 - t).max(0.0)
                })
                .collect();
            let total: f64 = weights.iter().sum();
            if total > 0.0 {
                for w in &mut weights {
                    *w /= total;
                }
            }
            (left, weights)
        })
        .collect()
}

/// FreeImage's `FreeImage_Rescale(.., FILTER_BILINEAR)` as COLMAP's
/// `Bitmap::Rescale` calls it: vertical pass first, rounded to 8 bits, then
/// the horizontal pass.
fn rescale_bilinear(img: &RgbImage, w2: u32, h2: u32) -> RgbImage {
    let (w, h) = img.dimensions();
    let to_u8 = |v: f64| (v + 0.5).floor().clamp(0.0, 255.0) as u8;
    let wy = freeimage_weights(h, h2);
    let mut mid = RgbImage::new(w, h2);
    for (y2, (top, weights)) in wy.iter().enumerate() {
        for x in 0..w {
            let mut acc = [0.0; 3];
            for (k, wt) in weights.iter().enumerate() {
                let p = img.get_pixel(x, (top + k) as u32).0;
                for c in 0..3 {
                    acc[c] += wt * f64::from(p[c]);
                }
            }
            mid.put_pixel(x, y2 as u32, image::Rgb(acc.map(to_u8)));
        }
    }
    let wx = freeimage_weights(w, w2);
    let mut out = RgbImage::new(w2, h2);
    for y in 0..h2 {
        for (x2, (left, weights)) in wx.iter().enumerate() {
            let mut acc = [0.0; 3];
            for (k, wt) in weights.iter().enumerate() {
                let p = mid.get_pixel((left + k) as u32, y).0;
                for c in 0..3 {
                    acc[c] += wt * f64::from(p[c]);
                }
            }
            out.put_pixel(x2 as u32, y, image::Rgb(acc.map(to_u8)));
        }
    }
    out
}

/// The model with every camera replaced by its [`undistort_camera`] and
/// every 2D feature moved into it (poses and 3D points unchanged). A
/// feature whose pixel has no ray keeps its position.
pub fn undistort_reconstruction(
    rec: &Reconstruction,
    opts: &UndistortOptions,
) -> Result<Reconstruction> {
    let mut out = rec.clone();
    for (id, cam) in &rec.cameras {
        out.cameras.insert(*id, undistort_camera(cam, opts)?);
    }
    for image in out.images.values_mut() {
        let (Some(d), Some(u)) = (
            rec.cameras.get(&image.camera_id),
            out.cameras.get(&image.camera_id),
        ) else {
            continue;
        };
        let Some((fx, fy, cx, cy)) = u.focal_and_principal_point() else {
            continue;
        };
        for p in &mut image.points2d {
            if let Some((uu, vv)) = d.cam_from_img(p.xy.x, p.xy.y) {
                p.xy = Point2::new(fx * uu + cx, fy * vv + cy);
            }
        }
    }
    Ok(out)
}

/// What [`undistort_workspace`] wrote.
#[derive(Debug, Clone)]
pub struct UndistortReport {
    /// The workspace folder.
    pub out: PathBuf,
    /// `(distorted, undistorted)` camera of each camera id.
    pub cameras: Vec<(ColmapCamera, ColmapCamera)>,
    /// Number of images written.
    pub n_images: usize,
}

/// Reads the model in `model_dir` and the images it names from
/// `images_dir`, and writes the undistorted dense workspace `out`:
/// `images/` (8-bit RGB, same names and formats as the input, as COLMAP
/// writes them), `sparse/` (binary model with `PINHOLE` cameras),
/// `stereo/patch-match.cfg` and `stereo/fusion.cfg` (COLMAP's defaults)
/// and the empty `stereo/{depth_maps,normal_maps,consistency_graphs}`.
/// An aligned model's `frame.json` is copied into `sparse/`.
///
/// Nothing partial is written: the workspace is built beside `out` and
/// swapped in when complete ([`OutDir`]). `out` must be new or empty, or
/// an earlier workspace and `force` (then only its files are replaced).
pub fn undistort_workspace(
    model_dir: &Path,
    images_dir: &Path,
    out: &Path,
    opts: &UndistortOptions,
    force: bool,
) -> Result<UndistortReport> {
    let out_dir = OutDir::check(out, "colmap undistort", &[model_dir, images_dir], force)?;
    let format = detect_format(model_dir)?;
    let cameras_file = format.files(model_dir)[0].clone();
    let rec = read_model_as(model_dir, format)?;
    // Undistortion keeps poses and points: an aligned model's frame
    // (`vpctl colmap align`) holds for the workspace too.
    let frame = model_dir.join(super::FRAME_FILE);
    let frame = if frame.is_file() {
        Some(crate::fsio::read_file(&frame)?)
    } else {
        None
    };
    undistort_into(
        &rec,
        &cameras_file,
        frame.as_deref(),
        images_dir,
        &out_dir,
        opts,
    )
}

/// The work of [`undistort_workspace`] on a model already read (from
/// COLMAP's files or OpenSfM's `reconstruction.json`, named by
/// `cameras_file` in errors), with the bytes of the `frame.json` to write
/// into `sparse/`, if any.
pub(crate) fn undistort_into(
    rec: &Reconstruction,
    cameras_file: &Path,
    frame: Option<&[u8]>,
    images_dir: &Path,
    out_dir: &OutDir,
    opts: &UndistortOptions,
) -> Result<UndistortReport> {
    let undistorted = match undistort_reconstruction(rec, opts) {
        Ok(u) => u,
        Err(SceneError::InvalidArgument(m)) => {
            return Err(SceneError::parse(
                cameras_file,
                Location::Header,
                format!("{m} (vpctl colmap undistort handles every COLMAP camera model but EQUIRECTANGULAR)"),
            ))
        }
        Err(e) => return Err(e),
    };
    // Every input image must exist and match its camera before anything is written.
    for im in rec.images.values() {
        let path = images_dir.join(&im.name);
        if !path.is_file() {
            return Err(SceneError::io(
                &path,
                std::io::Error::new(
                    std::io::ErrorKind::NotFound,
                    format!("image {} of the model is missing", im.name),
                ),
            ));
        }
        if ImageFormat::from_path(&path).is_err() {
            return Err(SceneError::parse(
                &path,
                Location::Header,
                "unknown image format (by extension)",
            ));
        }
    }
    let out = out_dir.path().to_path_buf();
    out_dir.write(|tmp| {
        write_workspace(tmp, images_dir, rec, &undistorted)?;
        if let Some(bytes) = frame {
            crate::fsio::write_file_atomic(&tmp.join("sparse").join(super::FRAME_FILE), bytes)?;
        }
        Ok::<_, SceneError>(())
    })?;
    let cameras = rec
        .cameras
        .iter()
        .filter_map(|(id, c)| undistorted.cameras.get(id).map(|u| (c.clone(), u.clone())))
        .collect();
    Ok(UndistortReport {
        out,
        cameras,
        n_images: rec.images.len(),
    })
}

fn write_workspace(
    root: &Path,
    images_dir: &Path,
    rec: &Reconstruction,
    undistorted: &Reconstruction,
) -> Result<()> {
    let mkdir = |p: &Path| std::fs::create_dir_all(p).map_err(|e| SceneError::io(p, e));
    for sub in [
        "images",
        "sparse",
        "stereo/depth_maps",
        "stereo/normal_maps",
        "stereo/consistency_graphs",
    ] {
        mkdir(&root.join(sub))?;
    }
    let results: Vec<Result<()>> = rec
        .images
        .values()
        .collect::<Vec<_>>()
        .par_iter()
        .map(|im| {
            let src = images_dir.join(&im.name);
            let dst = root.join("images").join(&im.name);
            if let Some(p) = dst.parent() {
                mkdir(p)?;
            }
            let distorted_model = rec.cameras.get(&im.camera_id).map(|c| c.model);
            let same = rec.cameras.get(&im.camera_id) == undistorted.cameras.get(&im.camera_id);
            if same
                && matches!(
                    distorted_model,
                    Some(CameraModel::SimplePinhole | CameraModel::Pinhole)
                )
            {
                // Already undistorted: COLMAP copies the file (its size is
                // still checked against the camera).
                let (w, h) = image::image_dimensions(&src).map_err(|e| SceneError::Image {
                    path: src.clone(),
                    source: e,
                })?;
                let cam = &rec.cameras[&im.camera_id];
                if (u64::from(w), u64::from(h)) != (cam.width, cam.height) {
                    return Err(SceneError::parse(
                        &src,
                        Location::Header,
                        format!(
                            "camera {} ({}): the image is {w}x{h}, the camera {}x{}",
                            cam.id, cam.model, cam.width, cam.height
                        ),
                    ));
                }
                let bytes = crate::fsio::read_file(&src)?;
                return crate::fsio::write_file_atomic(&dst, &bytes);
            }
            let img = image::open(&src)
                .map_err(|e| SceneError::Image {
                    path: src.clone(),
                    source: e,
                })?
                .to_rgb8();
            let (Some(d), Some(u)) = (
                rec.cameras.get(&im.camera_id),
                undistorted.cameras.get(&im.camera_id),
            ) else {
                return Err(SceneError::InvalidArgument(format!(
                    "image {}: no camera {}",
                    im.name, im.camera_id
                )));
            };
            let warped = undistort_image(&img, d, u)
                .map_err(|e| SceneError::parse(&src, Location::Header, e.to_string()))?;
            save_rgb(&dst, &warped)
        })
        .collect();
    results.into_iter().collect::<Result<Vec<()>>>()?;
    super::write_binary(&root.join("sparse"), undistorted)?;
    let mut patch_match = String::new();
    let mut fusion = String::new();
    for im in undistorted.images.values() {
        let _ = write!(patch_match, "{}\n__auto__, 20\n", im.name);
        let _ = writeln!(fusion, "{}", im.name);
    }
    crate::fsio::write_file_atomic(&root.join("stereo/patch-match.cfg"), patch_match.as_bytes())?;
    crate::fsio::write_file_atomic(&root.join("stereo/fusion.cfg"), fusion.as_bytes())?;
    Ok(())
}

fn save_rgb(path: &Path, img: &RgbImage) -> Result<()> {
    let format = ImageFormat::from_path(path).map_err(|e| SceneError::Image {
        path: path.to_path_buf(),
        source: e,
    })?;
    let mut err = None;
    crate::fsio::write_atomic(path, |w| {
        let r = if format == ImageFormat::Jpeg {
            image::codecs::jpeg::JpegEncoder::new_with_quality(&mut *w, 100).encode_image(img)
        } else {
            img.write_to(w, format)
        };
        r.map_err(|e| {
            let msg = e.to_string();
            err = Some(e);
            std::io::Error::other(msg)
        })
    })
    .map_err(|e| match err {
        Some(source) => SceneError::Image {
            path: path.to_path_buf(),
            source,
        },
        None => e,
    })
}

/// Whether `rec` holds a camera that projects differently from its pinhole
/// approximation; the first such camera.
pub fn first_distorted_camera(rec: &Reconstruction) -> Option<&ColmapCamera> {
    rec.cameras.values().find(|c| c.is_distorted())
}

#[cfg(test)]
#[path = "undistort_tests.rs"]
mod tests;
