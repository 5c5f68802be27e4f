//! COLMAP's dense workspace, as `image_undistorter` writes it: `images/`
//! (any format the `image` crate reads, grey or colour), `sparse/` (text or
//! binary model with PINHOLE / SIMPLE_PINHOLE cameras), optionally
//! `stereo/patch-match.cfg`; and the outputs vp-mvs writes into it:
//! `stereo/depth_maps/<image>.{photometric,geometric}.bin`,
//! `stereo/normal_maps/<image>.{photometric,geometric}.bin`, `fused.ply`.

use std::collections::HashMap;
use std::path::{Path, PathBuf};

use nalgebra::Point3;
use vp_scene::colmap::{self, CameraModel, DepthMap, NormalMap, Reconstruction};
use vp_scene::Camera;

use crate::error::{MvsError, Result};
use crate::params::MvsParams;
use crate::sources::{best_sources, frustum_sources};
use crate::view::{check_depth_range, GreyImage, View};
use vp_scene::triangulation::triangulation_angle_deg;

/// One image of the sparse model.
#[derive(Debug, Clone)]
pub struct ModelImage {
    /// COLMAP image id.
    pub id: u32,
    /// Image name, relative to `images/`.
    pub name: String,
    /// Posed pinhole camera.
    pub camera: Camera,
}

/// An opened dense workspace: its model, checked to be undistorted.
#[derive(Debug, Clone)]
pub struct Workspace {
    /// The workspace directory.
    pub root: PathBuf,
    /// The sparse model.
    pub model: Reconstruction,
    /// The model's images in id order.
    pub images: Vec<ModelImage>,
    /// The `cameras` file of the model (named in errors).
    pub cameras_file: PathBuf,
}

impl Workspace {
    /// Opens `root`: reads `root/sparse` and refuses cameras with lens
    /// distortion.
    pub fn open(root: &Path) -> Result<Self> {
        let sparse = root.join("sparse");
        if !sparse.is_dir() || !root.join("images").is_dir() {
            return Err(MvsError::Input {
                path: root.to_path_buf(),
                message: "not an MVS workspace: one holds `images/` (undistorted) and `sparse/` \
                          (their COLMAP model), as `vpctl colmap undistort --colmap MODEL \
                          --images IMAGES --out WORKSPACE` (or COLMAP's image_undistorter) \
                          writes; pass that folder as --workspace"
                    .into(),
            });
        }
        let format = colmap::detect_format(&sparse)?;
        let cameras_file = format.files(&sparse)[0].clone();
        let model = colmap::read_model_as(&sparse, format)?;
        for cam in model.cameras.values() {
            if !matches!(cam.model, CameraModel::Pinhole | CameraModel::SimplePinhole) {
                return Err(MvsError::Input {
                    path: cameras_file.clone(),
                    message: format!(
                        "camera {} is {}: dense stereo needs undistorted PINHOLE or SIMPLE_PINHOLE \
                         cameras; undistort the images first (colmap image_undistorter)",
                        cam.id, cam.model
                    ),
                });
            }
        }
        let mut images = Vec::with_capacity(model.images.len());
        for im in model.images.values() {
            images.push(ModelImage {
                id: im.id,
                name: im.name.clone(),
                camera: model.camera_of(im.id)?,
            });
        }
        Ok(Workspace {
            root: root.to_path_buf(),
            model,
            images,
            cameras_file,
        })
    }

    /// Path of an image file.
    pub fn image_path(&self, name: &str) -> PathBuf {
        self.root.join("images").join(name)
    }

    /// Indices (into [`Workspace::images`]) of the named images, all images
    /// when `names` is `None`. Unknown names are an error.
    pub fn select(&self, names: Option<&[String]>) -> Result<Vec<usize>> {
        let Some(names) = names else {
            return Ok((0..self.images.len()).collect());
        };
        let by_name: HashMap<&str, usize> = self
            .images
            .iter()
            .enumerate()
            .map(|(i, im)| (im.name.as_str(), i))
            .collect();
        let mut out = Vec::with_capacity(names.len());
        for n in names {
            let i = by_name.get(n.as_str()).ok_or_else(|| {
                MvsError::InvalidArgument(format!(
                    "image '{n}' is not in the model {}",
                    self.root.join("sparse").display()
                ))
            })?;
            if !out.contains(i) {
                out.push(*i);
            }
        }
        Ok(out)
    }

    /// Depth range of image `i` from the sparse points it sees, widened by
    /// `margin` of the range on both sides; `None` without points.
    pub fn depth_range_from_points(&self, i: usize, margin: f64) -> Option<(f64, f64)> {
        let im = &self.model.images[&self.images[i].id];
        let cam_from_world = self.images[i].camera.cam_from_world();
        let (mut lo, mut hi) = (f64::INFINITY, f64::NEG_INFINITY);
        for p2 in &im.points2d {
            let Some(p) = p2.point3d_id.and_then(|id| self.model.points.get(&id)) else {
                continue;
            };
            let z = (cam_from_world * p.xyz).z;
            if z > 0.0 {
                lo = lo.min(z);
                hi = hi.max(z);
            }
        }
        if !(lo <= hi) {
            return None;
        }
        let span = (hi - lo).max(1e-3 * hi);
        Some(((lo - margin * span).max(0.5 * lo), hi + margin * span))
    }

    /// Loads the selected images as views. Errors name the file: missing
    /// or unreadable image, size different from its camera.
    pub fn load_views(&self, selected: &[usize], ranges: &[(f64, f64)]) -> Result<Vec<View>> {
        let mut views = Vec::with_capacity(selected.len());
        for (&i, &range) in selected.iter().zip(ranges) {
            let im = &self.images[i];
            let path = self.image_path(&im.name);
            let rgb = image::open(&path)
                .map_err(|e| MvsError::Input {
                    path: path.clone(),
                    message: format!("cannot read image: {e}"),
                })?
                .to_rgb8();
            let k = im.camera.intrinsics;
            if (rgb.width(), rgb.height()) != (k.width, k.height) {
                return Err(MvsError::Input {
                    path,
                    message: format!(
                        "image is {}x{} but camera of image {} in the model is {}x{}",
                        rgb.width(),
                        rgb.height(),
                        im.id,
                        k.width,
                        k.height
                    ),
                });
            }
            views.push(View::new(&im.name, im.camera, rgb, range)?);
        }
        Ok(views)
    }

    /// Source images of each selected image (indices into `selected`):
    /// from `stereo/patch-match.cfg` when present, else automatic.
    pub fn sources(
        &self,
        selected: &[usize],
        ranges: &[(f64, f64)],
        params: &MvsParams,
    ) -> Result<Vec<Vec<usize>>> {
        let cfg = self.root.join("stereo").join("patch-match.cfg");
        if cfg.is_file() {
            return self.sources_from_cfg(&cfg, selected, ranges, params);
        }
        Ok(self.auto_sources(selected, ranges, params))
    }

    fn sources_from_cfg(
        &self,
        cfg: &Path,
        selected: &[usize],
        ranges: &[(f64, f64)],
        params: &MvsParams,
    ) -> Result<Vec<Vec<usize>>> {
        let text = std::fs::read_to_string(cfg).map_err(|e| MvsError::Input {
            path: cfg.to_path_buf(),
            message: format!("cannot read: {e}"),
        })?;
        let pos: HashMap<&str, usize> = selected
            .iter()
            .enumerate()
            .map(|(k, &i)| (self.images[i].name.as_str(), k))
            .collect();
        let auto = self.auto_sources(selected, ranges, params);
        let mut out: Vec<Vec<usize>> = vec![Vec::new(); selected.len()];
        let mut lines = text
            .lines()
            .enumerate()
            .map(|(n, l)| (n + 1, l.trim()))
            .filter(|(_, l)| !l.is_empty() && !l.starts_with('#'));
        while let Some((n, reference)) = lines.next() {
            let Some((_, spec)) = lines.next() else {
                return Err(MvsError::Input {
                    path: cfg.to_path_buf(),
                    message: format!("line {n}: reference '{reference}' has no source line"),
                });
            };
            let Some(&r) = pos.get(reference) else {
                // A reference outside the selection is not reconstructed.
                continue;
            };
            out[r] = if spec == "__all__" {
                (0..selected.len()).filter(|&k| k != r).collect()
            } else if let Some(rest) = spec.strip_prefix("__auto__") {
                let k: usize = rest
                    .trim_start_matches(',')
                    .trim()
                    .parse()
                    .unwrap_or(params.max_sources);
                auto[r].iter().copied().take(k).collect()
            } else {
                let mut v = Vec::new();
                for name in spec.split(',').map(str::trim).filter(|s| !s.is_empty()) {
                    // Sources outside the selection are skipped, as COLMAP does
                    // when it reconstructs a subset.
                    if let Some(&k) = pos.get(name) {
                        if k != r && !v.contains(&k) {
                            v.push(k);
                        }
                    } else if !self.images.iter().any(|im| im.name == name) {
                        return Err(MvsError::Input {
                            path: cfg.to_path_buf(),
                            message: format!(
                                "source image '{name}' of '{reference}' is not in the model"
                            ),
                        });
                    }
                }
                v
            };
        }
        Ok(out)
    }

    /// Automatic sources: with sparse points, the images sharing the most
    /// points seen under at least the minimum triangulation angle; without,
    /// the images whose frustum covers most of the reference's (sampled at
    /// three depths of its range) with at least that angle at mid range.
    pub fn auto_sources(
        &self,
        selected: &[usize],
        ranges: &[(f64, f64)],
        params: &MvsParams,
    ) -> Vec<Vec<usize>> {
        if self.model.points.is_empty() {
            let cams: Vec<Camera> = selected.iter().map(|&i| self.images[i].camera).collect();
            return frustum_sources(&cams, ranges, params);
        }
        let min_angle_deg = params.min_triangulation_angle_deg;
        selected
            .iter()
            .enumerate()
            .map(|(r, &ri)| {
                let cr = self.images[ri].camera.center();
                let scored =
                    selected
                        .iter()
                        .enumerate()
                        .filter(|&(s, _)| s != r)
                        .map(|(s, &si)| {
                            let cs = self.images[si].camera.center();
                            (
                                self.shared_points(ri, si, &cr, &cs, min_angle_deg) as f64,
                                s,
                            )
                        });
                best_sources(scored, params.max_sources)
            })
            .collect()
    }

    fn shared_points(
        &self,
        a: usize,
        b: usize,
        ca: &Point3<f64>,
        cb: &Point3<f64>,
        min_angle_deg: f64,
    ) -> usize {
        let (ia, ib) = (self.images[a].id, self.images[b].id);
        let seen_by_a = self.model.images[&ia]
            .points2d
            .iter()
            .filter_map(|p| p.point3d_id);
        let mut n = 0;
        for id in seen_by_a {
            let Some(p) = self.model.points.get(&id) else {
                continue;
            };
            if p.track.iter().any(|&(im, _)| im == ib)
                && triangulation_angle_deg(&p.xyz, &[*ca, *cb]) >= min_angle_deg
            {
                n += 1;
            }
        }
        n
    }
}

/// Where the outputs of image `name` go.
pub fn output_paths(root: &Path, name: &str, kind: &str) -> (PathBuf, PathBuf) {
    let stereo = root.join("stereo");
    (
        stereo.join("depth_maps").join(format!("{name}.{kind}.bin")),
        stereo
            .join("normal_maps")
            .join(format!("{name}.{kind}.bin")),
    )
}

/// Writes a depth and a normal map (atomically each), creating folders.
pub fn write_maps(root: &Path, name: &str, kind: &str, map: &crate::DepthNormalMap) -> Result<()> {
    let (dp, np) = output_paths(root, name, kind);
    for p in [&dp, &np] {
        if let Some(dir) = p.parent() {
            std::fs::create_dir_all(dir).map_err(|e| MvsError::Io {
                path: dir.to_path_buf(),
                source: e,
            })?;
        }
    }
    colmap::write_depth_map(
        &dp,
        &DepthMap {
            width: map.width,
            height: map.height,
            data: map.depth.clone(),
        },
    )?;
    colmap::write_normal_map(
        &np,
        &NormalMap {
            width: map.width,
            height: map.height,
            data: map.normal.clone(),
        },
    )?;
    Ok(())
}

/// Options of [`run_workspace`].
#[derive(Debug, Clone, Default)]
pub struct RunOptions {
    /// Reconstruct only these images (names under `images/`), each against
    /// sources among them; all images when `None`.
    pub images: Option<Vec<String>>,
    /// Depth range for every image, overriding the sparse points.
    pub depth_range: Option<(f64, f64)>,
    /// Parameters.
    pub params: MvsParams,
}

/// What [`run_workspace`] did.
#[derive(Debug, Clone, PartialEq)]
pub struct RunSummary {
    /// Images reconstructed (those with at least one source).
    pub reconstructed: Vec<String>,
    /// Share of valid pixels in each geometric map, in the order above.
    pub geometric_valid_share: Vec<f64>,
    /// Number of fused points.
    pub fused_points: usize,
    /// Path of the fused cloud.
    pub fused_path: PathBuf,
}

/// Reconstructs a dense workspace: reads and checks every input first, then
/// runs PatchMatch, the geometric filter and fusion, and writes the maps and
/// `fused.ply`. `progress` receives one line per step.
pub fn run_workspace(
    root: &Path,
    options: &RunOptions,
    progress: &mut dyn FnMut(&str),
) -> Result<RunSummary> {
    let params = &options.params;
    params.validate()?;
    let ws = Workspace::open(root)?;
    let selected = ws.select(options.images.as_deref())?;
    if selected.len() < 2 {
        return Err(MvsError::InvalidArgument(format!(
            "{} image(s) selected from {}: multi-view stereo needs at least two",
            selected.len(),
            root.display()
        )));
    }
    let ranges = ws.depth_ranges(&selected, options.depth_range, params.depth_range_margin)?;
    let sources = ws.sources(&selected, &ranges, params)?;
    progress(&format!("loading {} images", selected.len()));
    let mut views = ws.load_views(&selected, &ranges)?;
    // Each photometric map goes to disk as soon as it is final: it is
    // not held beside the other views' passes and the fused cloud.
    let geometric =
        crate::reconstruct_maps(&views, &sources, params, false, progress, &mut |r, map| {
            write_maps(root, &views[r].name, "photometric", &map)
        })?;
    // Fusion reads depths, normals and colours only: the grey images (4
    // bytes a pixel) are let go first, as the maps' costs were.
    for view in &mut views {
        view.grey = GreyImage {
            width: 0,
            height: 0,
            data: Vec::new(),
        };
    }
    progress("fusion");
    // Each geometric map is written and let go once fusion is done with
    // it.
    let mut shares: Vec<(usize, f64)> = Vec::new();
    let mut fused = crate::FusedPly::default();
    crate::fuse_releasing(
        &views,
        geometric,
        &sources,
        params,
        &mut |r, g| {
            write_maps(root, &views[r].name, "geometric", &g)?;
            let valid = g.depth.iter().filter(|&&d| d > 0.0).count();
            shares.push((r, valid as f64 / g.depth.len() as f64));
            Ok(())
        },
        &mut |p| fused.push(&p),
    )?;
    shares.sort_by_key(|&(r, _)| r);
    let summary = RunSummary {
        reconstructed: shares.iter().map(|&(r, _)| views[r].name.clone()).collect(),
        geometric_valid_share: shares.iter().map(|&(_, s)| s).collect(),
        fused_points: fused.len(),
        fused_path: root.join("fused.ply"),
    };
    fused.write(&summary.fused_path)?;
    Ok(summary)
}

/// Reconstructs the named images (at least two, e.g. a labelgen triplet)
/// on their own at pyramid level `level` (1 = full size, each level halving
/// the images and intrinsics), each image against the others, and writes
/// `<out_dir>/<image>.photometric.bin` and `.geometric.bin` depth maps:
/// the layout of one `<triplet id>/level<L>` folder that `vpctl labelgen
/// run` reads. Returns the share of valid geometric pixels per image.
pub fn run_image_set(
    ws: &Workspace,
    names: &[String],
    level: u32,
    depth_range: Option<(f64, f64)>,
    params: &MvsParams,
    out_dir: &Path,
    progress: &mut dyn FnMut(&str),
) -> Result<Vec<f64>> {
    params.validate()?;
    if !(1..=8).contains(&level) {
        return Err(MvsError::InvalidArgument(format!(
            "pyramid level {level} is outside 1..=8"
        )));
    }
    let selected = ws.select(Some(names))?;
    if selected.len() < 2 {
        return Err(MvsError::InvalidArgument(format!(
            "{} distinct image(s) in {names:?}: multi-view stereo needs at least two",
            selected.len()
        )));
    }
    let ranges = ws.depth_ranges(&selected, depth_range, params.depth_range_margin)?;
    let full = ws.load_views(&selected, &ranges)?;
    let factor = 1u32 << (level - 1);
    let views: Vec<View> = if factor == 1 {
        full
    } else {
        let mut out = Vec::with_capacity(full.len());
        for v in full {
            let k = v.camera.intrinsics;
            let (w, h) = (
                (k.width as f64 / f64::from(factor)).round().max(1.0) as u32,
                (k.height as f64 / f64::from(factor)).round().max(1.0) as u32,
            );
            let rgb = image::imageops::resize(&v.rgb, w, h, image::imageops::FilterType::Triangle);
            let mut ks = k.scaled(f64::from(w) / f64::from(k.width));
            (ks.width, ks.height) = (w, h);
            let camera = Camera::new(ks, v.camera.world_from_cam);
            out.push(View::new(&v.name, camera, rgb, v.depth_range)?);
        }
        out
    };
    let sources: Vec<Vec<usize>> = (0..views.len())
        .map(|r| (0..views.len()).filter(|&s| s != r).collect())
        .collect();
    let output = crate::reconstruct(&views, &sources, params, progress)?;
    let mut shares = Vec::with_capacity(views.len());
    for (k, view) in views.iter().enumerate() {
        let (Some(p), Some(g)) = (&output.photometric[k], &output.geometric[k]) else {
            continue;
        };
        for (kind, map) in [("photometric", p), ("geometric", g)] {
            let path = out_dir.join(format!("{}.{kind}.bin", view.name));
            if let Some(dir) = path.parent() {
                std::fs::create_dir_all(dir).map_err(|e| MvsError::Io {
                    path: dir.to_path_buf(),
                    source: e,
                })?;
            }
            colmap::write_depth_map(
                &path,
                &DepthMap {
                    width: map.width,
                    height: map.height,
                    data: map.depth.clone(),
                },
            )?;
        }
        shares.push(g.depth.iter().filter(|&&d| d > 0.0).count() as f64 / g.depth.len() as f64);
    }
    Ok(shares)
}

impl Workspace {
    /// The depth range of each selected image: `given` for all, or each
    /// image's own from the sparse points it sees (with `margin`); checked.
    fn depth_ranges(
        &self,
        selected: &[usize],
        given: Option<(f64, f64)>,
        margin: f64,
    ) -> Result<Vec<(f64, f64)>> {
        selected
            .iter()
            .map(|&i| {
                let name = &self.images[i].name;
                let range = match given {
                    Some(r) => r,
                    None => self.depth_range_from_points(i, margin).ok_or_else(|| {
                        MvsError::InvalidArgument(format!(
                            "image '{name}' sees no sparse points: give a depth range \
                             (--depth-range MIN,MAX)"
                        ))
                    })?,
                };
                check_depth_range(range)
                    .map_err(|m| MvsError::InvalidArgument(format!("image '{name}': {m}")))?;
                Ok(range)
            })
            .collect()
    }
}
