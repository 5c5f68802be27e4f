//! `vpctl.labelgen`: triplet sampling and training labels from depth maps
//! (vp-labelgen).

use std::path::PathBuf;

use numpy::{PyArray2, PyReadonlyArray2};
use pyo3::prelude::*;
use pyo3::types::{PyDict, PyList};
use vp_labelgen::triplets::{self, Triplet, TripletParams};
use vp_labelgen::{
    io, LabelOutput, LabelParams, LabelRunRequest, LabelSummary, MissingPartMeshes, ReconLabels,
};
use vp_labelgen::{TripletReconstruction, View};
use vp_scene::fsio;
use vp_scene::opensfm::ModelSource;

use crate::convert::{self, label_arrays, points};
use crate::errors::{value_error, IntoPy};
use crate::scene::{depth_map, PyCamera, PyColmap, PyMesh, PyRayCaster};

/// Samples image triplets from the angle bins (edges 4, 8, ..., 128 deg by
/// default) of a COLMAP model, as `vpctl labelgen triplets` does. Returns
/// a list of {bin, angle_deg, images}.
#[pyfunction]
#[pyo3(signature = (model, per_bin = 10, seed = 0, min_shared_points = 20, min_shared_share = 0.1, min_equilateral = 0.5, bin_edges = None))]
fn sample_triplets<'py>(
    py: Python<'py>,
    model: PyRef<'_, PyColmap>,
    per_bin: usize,
    seed: u64,
    min_shared_points: usize,
    min_shared_share: f64,
    min_equilateral: f64,
    bin_edges: Option<Vec<f64>>,
) -> PyResult<Bound<'py, PyAny>> {
    let mut p = TripletParams {
        per_bin,
        seed,
        min_shared_points,
        min_shared_share,
        min_equilateral,
        ..TripletParams::default()
    };
    if let Some(e) = bin_edges {
        p.bin_edges = e;
    }
    let rec = &model.0;
    let t = py.detach(|| triplets::sample_triplets(rec, &p)).py()?;
    convert::to_py(py, &t)
}

fn triplet_list(obj: &Bound<'_, PyAny>) -> PyResult<Vec<Triplet>> {
    convert::from_py_required(obj, "triplets")
}

/// Writes a triplet list file (as `vpctl labelgen triplets --out`).
#[pyfunction]
#[pyo3(signature = (path, triplets, force = false))]
fn write_triplet_list(path: PathBuf, triplets: &Bound<'_, PyAny>, force: bool) -> PyResult<()> {
    let t = triplet_list(triplets)?;
    fsio::check_overwrite(&path, force).py()?;
    triplets::write_triplet_list(&path, &t).py()
}

/// Reads a triplet list file.
#[pyfunction]
fn read_triplet_list(py: Python<'_>, path: PathBuf) -> PyResult<Bound<'_, PyAny>> {
    let t = triplets::read_triplet_list(&path).py()?;
    convert::to_py(py, &t)
}

/// Id of the i-th triplet of a list (`t0000`, ...).
#[pyfunction]
fn triplet_id(i: usize) -> String {
    triplets::triplet_id(i)
}

/// Where `labelgen run` looks for the depth map of `image` in triplet `id`
/// at pyramid `level`.
#[pyfunction]
fn depth_map_path(depth_dir: PathBuf, id: &str, level: u32, image: &str) -> PathBuf {
    io::depth_map_path(&depth_dir, id, level, image)
}

/// A COLMAP model of known cameras [(name, Camera)] over a surface: every
/// point (N, 3) seen unoccluded by two or more cameras becomes a 3D point
/// with exact projections (what SfM would give; for tests and demos).
#[pyfunction]
fn sparse_model(
    py: Python<'_>,
    cameras: Vec<(String, PyCamera)>,
    caster: PyRef<'_, PyRayCaster>,
    pts: &Bound<'_, PyAny>,
) -> PyResult<PyColmap> {
    let cams: Vec<_> = cameras.into_iter().map(|(n, c)| (n, c.0)).collect();
    let p = points(&convert::f64_2d(pts, "(N, 3)", "pts")?, "pts")?;
    let c = &caster.0;
    Ok(PyColmap(py.detach(|| {
        vp_labelgen::synthetic::sparse_model(&cams, c, &p)
    })))
}

/// One MVS reconstruction of a triplet at one pyramid level: three views,
/// each a name, a camera and a depth map (H, W) float32 (0 = no depth).
#[pyclass(
    name = "TripletReconstruction",
    module = "vpctl.labelgen",
    frozen,
    from_py_object
)]
#[derive(Clone)]
pub struct PyRecon(TripletReconstruction);

#[pymethods]
impl PyRecon {
    #[new]
    fn new(id: String, views: Vec<(String, PyCamera, Bound<'_, PyAny>)>) -> PyResult<Self> {
        let n = views.len();
        let v: Vec<View> = views
            .into_iter()
            .enumerate()
            .map(|(i, (name, camera, depth))| {
                let depth: PyReadonlyArray2<'_, f32> =
                    convert::reals(&depth, "(H, W)", &format!("views[{i}] depth"))?;
                Ok(View {
                    name,
                    camera: camera.0,
                    depth: depth_map(&depth),
                })
            })
            .collect::<PyResult<_>>()?;
        let views: [View; 3] = v
            .try_into()
            .map_err(|_| value_error(format!("reconstruction {id}: {n} views, expected 3")))?;
        let rec = TripletReconstruction { id, views };
        rec.validate().py()?;
        Ok(PyRecon(rec))
    }

    /// Its id.
    #[getter]
    fn id(&self) -> String {
        self.0.id.clone()
    }

    /// Image names of its three views.
    #[getter]
    fn names(&self) -> Vec<String> {
        self.0.views.iter().map(|v| v.name.clone()).collect()
    }
}

/// Loads every level of every triplet from a depth-map folder (the layout
/// of `vpctl labelgen run`).
#[pyfunction]
fn load_reconstructions(
    py: Python<'_>,
    model: PyRef<'_, PyColmap>,
    triplets: &Bound<'_, PyAny>,
    depth_dir: PathBuf,
) -> PyResult<Vec<PyRecon>> {
    let t = triplet_list(triplets)?;
    let m = &model.0;
    let recs = py
        .detach(|| io::load_reconstructions(m, &t, &depth_dir))
        .py()?;
    Ok(recs.into_iter().map(PyRecon).collect())
}

/// The labels of every view of every reconstruction, in id order.
#[pyclass(name = "Labels", module = "vpctl.labelgen", frozen)]
pub struct PyLabels(Vec<ReconLabels>);

#[pymethods]
impl PyLabels {
    fn __len__(&self) -> usize {
        self.0.len()
    }

    /// Reconstruction `i`: {id, names, labels: [(labels (H, W) uint8, angles
    /// (H, W) float32)] x 3, counts: [{measured, positive, negative_voted,
    /// negative_missing}] x 3}.
    fn __getitem__<'py>(&self, py: Python<'py>, key: usize) -> PyResult<Bound<'py, PyDict>> {
        let r = self.0.get(key).ok_or_else(|| {
            pyo3::exceptions::PyIndexError::new_err(format!("index {key} out of range"))
        })?;
        let labels = PyList::empty(py);
        for img in &r.labels {
            let pair: (Bound<'py, PyArray2<u8>>, Bound<'py, PyArray2<f32>>) =
                label_arrays(py, img)?;
            labels.append(pair)?;
        }
        let counts = PyList::empty(py);
        for c in &r.counts {
            let d = PyDict::new(py);
            d.set_item("measured", c.measured)?;
            d.set_item("positive", c.positive)?;
            d.set_item("negative_voted", c.negative_voted)?;
            d.set_item("negative_missing", c.negative_missing)?;
            counts.append(d)?;
        }
        let d = PyDict::new(py);
        d.set_item("id", &r.id)?;
        d.set_item("names", r.names.to_vec())?;
        d.set_item("labels", labels)?;
        d.set_item("counts", counts)?;
        Ok(d)
    }

    /// Totals over all views, as `summary.json`.
    fn summary<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyAny>> {
        convert::to_py(py, &LabelSummary::of(&self.0))
    }

    /// Writes the label images and summary.json as `vpctl labelgen run`;
    /// returns the summary. Refuses to overwrite unless `force`.
    #[pyo3(signature = (out_dir, force = false))]
    fn write<'py>(
        &self,
        py: Python<'py>,
        out_dir: PathBuf,
        force: bool,
    ) -> PyResult<Bound<'py, PyAny>> {
        let s = py
            .detach(|| io::write_labels(&out_dir, &self.0, force))
            .py()?;
        convert::to_py(py, &s)
    }
}

/// Labels every view by consistency voting (support, voting, missing
/// parts with `mesh`). `params`: any subset of alpha_min_deg, s_min,
/// sigma_px, k_sigma, min_support, max_splat_radius, mesh_iterations.
#[pyfunction]
#[pyo3(signature = (reconstructions, mesh = None, params = None))]
fn generate_labels(
    py: Python<'_>,
    reconstructions: Vec<PyRecon>,
    mesh: Option<PyRef<'_, PyMesh>>,
    params: Option<&Bound<'_, PyAny>>,
) -> PyResult<PyLabels> {
    let p: LabelParams = convert::from_py(params, "params")?;
    p.validate().py()?;
    let recs: Vec<TripletReconstruction> = reconstructions.into_iter().map(|r| r.0).collect();
    let m = mesh.as_ref().map(|m| &m.0);
    let labels = py
        .detach(|| {
            let meshes = m.map(|m| MissingPartMeshes::new(m, p.mesh_iterations));
            vp_labelgen::generate_labels(&recs, meshes.as_ref(), &p)
        })
        .py()?;
    Ok(PyLabels(labels))
}

/// `vpctl labelgen run --colmap MODEL --triplets T --depth-dir D --out OUT
/// [--mesh --frame-unchecked --force]` ([`vp_labelgen::run_labelling`]):
/// loads, labels and writes the label folder and `summary.json`; returns
/// the summary. `params`: any subset of `vpctl labelgen defaults`.
/// `model`: a COLMAP model folder or an OpenSfM reconstruction (told apart
/// by their files, as `vpctl.planner.plan` does).
#[pyfunction]
#[pyo3(signature = (model, triplets, depth_dir, out, mesh = None, params = None, frame_unchecked = false, force = false))]
fn run<'py>(
    py: Python<'py>,
    model: PathBuf,
    triplets: PathBuf,
    depth_dir: PathBuf,
    out: PathBuf,
    mesh: Option<PathBuf>,
    params: Option<&Bound<'py, PyAny>>,
    frame_unchecked: bool,
    force: bool,
) -> PyResult<Bound<'py, PyAny>> {
    let mut req = LabelRunRequest::new(ModelSource::detect(&model), triplets, depth_dir);
    req.mesh = mesh;
    req.params = convert::from_py(params, "params")?;
    req.frame_unchecked = frame_unchecked;
    let output = LabelOutput {
        out,
        inputs: Vec::new(),
        force,
    };
    let (s, warnings) = py
        .detach(|| vp_labelgen::run_labelling(&req, &output))
        .py()?;
    crate::errors::warn_all(py, &warnings)?;
    convert::to_py(py, &s)
}

/// Registers the submodule.
pub fn register(m: &Bound<'_, PyModule>) -> PyResult<()> {
    m.add_class::<PyRecon>()?;
    m.add_class::<PyLabels>()?;
    m.add_function(wrap_pyfunction!(sample_triplets, m)?)?;
    m.add_function(wrap_pyfunction!(write_triplet_list, m)?)?;
    m.add_function(wrap_pyfunction!(read_triplet_list, m)?)?;
    m.add_function(wrap_pyfunction!(triplet_id, m)?)?;
    m.add_function(wrap_pyfunction!(depth_map_path, m)?)?;
    m.add_function(wrap_pyfunction!(sparse_model, m)?)?;
    m.add_function(wrap_pyfunction!(load_reconstructions, m)?)?;
    m.add_function(wrap_pyfunction!(generate_labels, m)?)?;
    m.add_function(wrap_pyfunction!(run, m)?)?;
    Ok(())
}
