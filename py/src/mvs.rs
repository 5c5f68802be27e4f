//! `vpctl._native.mvs`: vp-mvs (CPU PatchMatch multi-view stereo) on a
//! COLMAP dense workspace or on labelgen triplets, writing exactly the files
//! `vpctl mvs run` writes, or on images in memory returning numpy maps. The
//! logic is the front doors `vpctl mvs run` calls too
//! ([`vp_mvs::reconstruct_workspace`], [`vp_mvs::reconstruct_image_sets`])
//! and [`vp_mvs::reconstruct`]; this module only translates arguments.

use std::path::PathBuf;

use numpy::{PyArray2, PyArray3};
use pyo3::prelude::*;
use pyo3::types::PyDict;
use vp_mvs::{
    Algorithm, DepthNormalMap, ImageSet, ImageSetsRequest, MvsParams, RunOptions, SetShares, View,
    WorkspaceRequest,
};

use crate::convert::{self, image2, image3};
use crate::errors::{value_error, IntoPy};
use crate::progress::Progress;
use crate::scene::PyCamera;

/// The parameters of a run: `params` (any subset of `vpctl mvs defaults`),
/// with `seed` and `algorithm` (`vpctl mvs run --seed --algorithm`) over
/// them when given.
fn params_with(
    params: Option<&Bound<'_, PyAny>>,
    seed: Option<u64>,
    algorithm: Option<&str>,
) -> PyResult<MvsParams> {
    let mut p: MvsParams = convert::from_py(params, "params")?;
    if let Some(seed) = seed {
        p.seed = seed;
    }
    if let Some(a) = algorithm {
        p.algorithm = match a {
            "patchmatch" => Algorithm::PatchMatch,
            "sgm" => Algorithm::Sgm,
            _ => {
                return Err(value_error(format!(
                    "algorithm: '{a}' is not a matcher (patchmatch, sgm)"
                )))
            }
        };
    }
    Ok(p)
}

/// `vpctl mvs run --workspace W [--images --depth-range --seed --algorithm --force]`:
/// writes `stereo/depth_maps`, `stereo/normal_maps` and `fused.ply` into the
/// workspace; returns the summary as a dict.
#[pyfunction]
#[pyo3(signature = (workspace, images = None, depth_range = None, params = None, seed = None, force = false, algorithm = None, progress = None))]
#[allow(clippy::too_many_arguments)]
fn run_workspace<'py>(
    py: Python<'py>,
    workspace: PathBuf,
    images: Option<Vec<String>>,
    depth_range: Option<(f64, f64)>,
    params: Option<&Bound<'py, PyAny>>,
    seed: Option<u64>,
    force: bool,
    algorithm: Option<String>,
    progress: Option<Py<PyAny>>,
) -> PyResult<Bound<'py, PyDict>> {
    let mut progress = Progress::from_arg(py, progress)?;
    let mut req = WorkspaceRequest::new(workspace);
    req.options = RunOptions {
        images,
        depth_range,
        params: params_with(params, seed, algorithm.as_deref())?,
    };
    req.force = force;
    let summary = py.detach(|| vp_mvs::reconstruct_workspace(&req, &mut |l| progress.line(l)));
    progress.finish()?;
    let summary = summary.map_err(|e| crate::errors::mvs(&e))?;
    let d = PyDict::new(py);
    d.set_item("reconstructed", summary.reconstructed)?;
    d.set_item("geometric_valid_share", summary.geometric_valid_share)?;
    d.set_item("fused_points", summary.fused_points)?;
    d.set_item("fused_path", summary.fused_path)?;
    Ok(d)
}

/// `vpctl mvs run --workspace W --triplets T --levels L --out OUT`: every
/// triplet on its own at every level into `<out>/<triplet id>/level<L>/`.
/// Every triplet is checked before the first reconstruction. Returns
/// `{triplet id: {level: [share of pixels with a geometric depth per image]}}`.
#[pyfunction]
#[pyo3(signature = (workspace, triplets, out, levels = vec![1], depth_range = None, params = None, seed = None, force = false, algorithm = None, progress = None))]
#[allow(clippy::too_many_arguments)]
fn run_triplets(
    py: Python<'_>,
    workspace: PathBuf,
    triplets: PathBuf,
    out: PathBuf,
    levels: Vec<u32>,
    depth_range: Option<(f64, f64)>,
    params: Option<&Bound<'_, PyAny>>,
    seed: Option<u64>,
    force: bool,
    algorithm: Option<String>,
    progress: Option<Py<PyAny>>,
) -> PyResult<SetShares> {
    let mut progress = Progress::from_arg(py, progress)?;
    let params = params_with(params, seed, algorithm.as_deref())?;
    let sets = py
        .detach(|| vp_labelgen::triplets::read_image_sets(&triplets))
        .py()?;
    let mut req = ImageSetsRequest::new(
        workspace,
        sets.into_iter().map(ImageSet::from).collect(),
        out,
    );
    req.list = Some(triplets);
    req.levels = levels;
    req.depth_range = depth_range;
    req.params = params;
    req.force = force;
    let shares = py.detach(|| vp_mvs::reconstruct_image_sets(&req, &mut |l| progress.line(l)));
    progress.finish()?;
    shares.map_err(|e| crate::errors::mvs(&e))
}

/// Depth (H, W), normal (H, W, 3) and cost (H, W) arrays of one map.
type MapArrays<'py> = (
    Bound<'py, PyArray2<f32>>,
    Bound<'py, PyArray3<f32>>,
    Bound<'py, PyArray2<f32>>,
);

fn map_arrays(py: Python<'_>, m: DepthNormalMap) -> PyResult<MapArrays<'_>> {
    let (w, h) = (m.width, m.height);
    let normal: Vec<f32> = m.normal.into_iter().flatten().collect();
    Ok((
        image2(py, w, h, m.depth)?,
        image3(py, (h as usize, w as usize, 3), normal)?,
        image2(py, w, h, m.cost)?,
    ))
}

/// PatchMatch on images in memory ([`vp_mvs::reconstruct`]): `images`
/// (H, W, 3) uint8 with their posed `cameras`, one depth range per image
/// (or one for all), `sources[i]` the source images of image i (default:
/// [`vp_mvs::frustum_sources`]). Returns per image (depth, normal, cost)
/// arrays, geometrically filtered (`filtered`) or photometric, or `None`
/// for an image without sources.
#[pyfunction]
#[pyo3(signature = (images, cameras, depth_ranges, sources = None, params = None, seed = None, filtered = true, algorithm = None, progress = None))]
#[allow(clippy::too_many_arguments)]
fn patch_match<'py>(
    py: Python<'py>,
    images: Vec<Bound<'py, PyAny>>,
    cameras: Vec<PyCamera>,
    depth_ranges: Vec<(f64, f64)>,
    sources: Option<Vec<Vec<usize>>>,
    params: Option<&Bound<'py, PyAny>>,
    seed: Option<u64>,
    filtered: bool,
    algorithm: Option<String>,
    progress: Option<Py<PyAny>>,
) -> PyResult<Vec<Option<MapArrays<'py>>>> {
    let mut progress = Progress::from_arg(py, progress)?;
    let p = params_with(params, seed, algorithm.as_deref())?;
    let n = images.len();
    if cameras.len() != n {
        return Err(value_error(format!(
            "{n} images and {} cameras: one camera per image",
            cameras.len()
        )));
    }
    let ranges = match depth_ranges.len() {
        1 => vec![depth_ranges[0]; n],
        m if m == n => depth_ranges,
        m => {
            return Err(value_error(format!(
                "depth_ranges: {m} ranges for {n} images (one per image, or one for all)"
            )))
        }
    };
    let mut views = Vec::with_capacity(n);
    for (i, (img, cam)) in images.iter().zip(&cameras).enumerate() {
        let rgb = crate::convert::rgb_like(img, &format!("images[{i}]"))?;
        let view = View::new(&format!("images[{i}]"), cam.0, rgb, ranges[i])
            .map_err(|e| crate::errors::mvs(&e))?;
        views.push(view);
    }
    let cams: Vec<_> = cameras.iter().map(|c| c.0).collect();
    let sources = sources.unwrap_or_else(|| vp_mvs::frustum_sources(&cams, &ranges, &p));
    if sources.len() != n {
        return Err(value_error(format!(
            "sources: {} lists for {n} images",
            sources.len()
        )));
    }
    let out = py.detach(|| vp_mvs::reconstruct(&views, &sources, &p, &mut |l| progress.line(l)));
    progress.finish()?;
    let out = out.map_err(|e| crate::errors::mvs(&e))?;
    let maps = if filtered {
        out.geometric
    } else {
        out.photometric
    };
    maps.into_iter()
        .map(|m| m.map(|m| map_arrays(py, m)).transpose())
        .collect()
}

/// Registers the submodule.
pub fn register(m: &Bound<'_, PyModule>) -> PyResult<()> {
    m.add_function(wrap_pyfunction!(patch_match, m)?)?;
    m.add_function(wrap_pyfunction!(run_workspace, m)?)?;
    m.add_function(wrap_pyfunction!(run_triplets, m)?)?;
    Ok(())
}
