//! `vpctl._native.mvs`: vp-mvs (CPU PatchMatch multi-view stereo) on a
//! COLMAP dense workspace or on labelgen triplets, writing exactly the files
//! `vpctl mvs run` writes. The logic is [`vp_mvs::run_workspace`] and
//! [`vp_mvs::run_image_set`]; this module only translates arguments.

use std::collections::BTreeMap;
use std::path::PathBuf;

use pyo3::prelude::*;
use pyo3::types::PyDict;
use vp_mvs::{MvsError, MvsParams, RunOptions};

use crate::convert;
use crate::errors::IntoPy;

fn params_with_seed(params: Option<&Bound<'_, PyAny>>, seed: Option<u64>) -> PyResult<MvsParams> {
    let mut p: MvsParams = convert::from_py(params, "params")?;
    if let Some(seed) = seed {
        p.seed = seed;
    }
    Ok(p)
}

/// `vpctl mvs run --workspace W [--images --depth-range --seed --force]`:
/// writes `stereo/depth_maps`, `stereo/normal_maps` and `fused.ply` into the
/// workspace; returns the summary as a dict.
#[pyfunction]
#[pyo3(signature = (workspace, images = None, depth_range = None, params = None, seed = None, force = false))]
fn run_workspace<'py>(
    py: Python<'py>,
    workspace: PathBuf,
    images: Option<Vec<String>>,
    depth_range: Option<(f64, f64)>,
    params: Option<&Bound<'py, PyAny>>,
    seed: Option<u64>,
    force: bool,
) -> PyResult<Bound<'py, PyDict>> {
    let options = RunOptions {
        images,
        depth_range,
        params: params_with_seed(params, seed)?,
    };
    vp_scene::fsio::check_overwrite(&workspace.join("fused.ply"), force).py()?;
    let summary = py
        .detach(|| vp_mvs::run_workspace(&workspace, &options, &mut |_| {}))
        .map_err(|e| crate::errors::mvs(&e))?;
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
#[pyo3(signature = (workspace, triplets, out, levels = vec![1], depth_range = None, params = None, seed = None, force = false))]
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
) -> PyResult<BTreeMap<String, BTreeMap<u32, Vec<f64>>>> {
    let p = params_with_seed(params, seed)?;
    vp_scene::fsio::check_overwrite(&out, force).py()?;
    let list = py
        .detach(|| vp_labelgen::triplets::read_triplet_list(&triplets))
        .py()?;
    py.detach(|| {
        let ws = vp_mvs::Workspace::open(&workspace)?;
        for (i, t) in list.iter().enumerate() {
            ws.select(Some(&t.images)).map_err(|e| MvsError::Input {
                path: triplets.clone(),
                message: format!("triplet {}: {e}", vp_labelgen::triplets::triplet_id(i)),
            })?;
        }
        let mut shares = BTreeMap::new();
        for (i, t) in list.iter().enumerate() {
            let id = vp_labelgen::triplets::triplet_id(i);
            let mut per_level = BTreeMap::new();
            for &level in &levels {
                let dir = out.join(&id).join(format!("level{level}"));
                let s = vp_mvs::run_image_set(
                    &ws,
                    &t.images,
                    level,
                    depth_range,
                    &p,
                    &dir,
                    &mut |_| {},
                )?;
                per_level.insert(level, s);
            }
            shares.insert(id, per_level);
        }
        Ok::<_, MvsError>(shares)
    })
    .map_err(|e| crate::errors::mvs(&e))
}

/// Registers the submodule.
pub fn register(m: &Bound<'_, PyModule>) -> PyResult<()> {
    m.add_function(wrap_pyfunction!(run_workspace, m)?)?;
    m.add_function(wrap_pyfunction!(run_triplets, m)?)?;
    Ok(())
}
