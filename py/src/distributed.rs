//! `vpctl._native.distributed`: the per-task calls of `vpctl.distributed`
//! (Dask). Each is one independent unit of the offline pipeline, reading its
//! inputs from paths (shared storage) and returning small results: a tree
//! as bytes, the support maps of a chunk of reconstructions as bytes, the
//! summary of a chunk of labels. The logic is the crates':
//! [`vp_forest::train_tree`] / [`vp_forest::assemble`],
//! [`vp_mvs::run_image_set`], [`vp_labelgen::load_label_run`] (the loading
//! `vpctl labelgen run` does), [`vp_labelgen::support_for`] /
//! [`vp_labelgen::labels_for`].

use std::path::PathBuf;

use pyo3::prelude::*;
use vp_forest::{Forest, TrainParams, TrainedTree, TrainingPlan, TrainingSet};
use vp_labelgen::{
    io, LabelParams, LabelRunRequest, LabelSummary, MissingPartMeshes, TripletReconstruction,
};
use vp_mvs::MvsParams;
use vp_scene::opensfm::ModelSource;

use crate::convert;
use crate::errors::{value_error, IntoPy};
use crate::forest::PyForest;

/// A training set loaded once per worker process from the layout `vpctl
/// train` reads (images folder, label folder), from which any tree of a
/// forest can be trained.
#[pyclass(name = "TrainingData", module = "vpctl.distributed", frozen)]
pub struct PyTrainingData(TrainingSet);

#[pymethods]
impl PyTrainingData {
    /// Loads images and `<image name>.vplabel` files as `vpctl train
    /// --images --labels [--max-per-label-image --seed]` does.
    #[staticmethod]
    #[pyo3(signature = (images_dir, labels_dir, seed = 0, max_per_label_image = None))]
    fn from_dirs(
        py: Python<'_>,
        images_dir: PathBuf,
        labels_dir: PathBuf,
        seed: u64,
        max_per_label_image: Option<usize>,
    ) -> PyResult<Self> {
        py.detach(|| {
            TrainingSet::from_label_dir(&images_dir, &labels_dir, max_per_label_image, seed)
        })
        .py()
        .map(PyTrainingData)
    }

    /// Trains tree `index` of the forest with these `params` and `seed`;
    /// returns it as bytes for [`assemble`].
    #[pyo3(signature = (index, params = None, seed = 0))]
    fn train_tree(
        &self,
        py: Python<'_>,
        index: usize,
        params: Option<&Bound<'_, PyAny>>,
        seed: u64,
    ) -> PyResult<std::borrow::Cow<'static, [u8]>> {
        let p: TrainParams = convert::from_py(params, "params")?;
        let set = &self.0;
        py.detach(|| {
            let plan = TrainingPlan::new(set, &p, seed)?;
            plan.train_tree(index).map(|t| t.to_bytes())
        })
        .py()
        .map(Into::into)
    }

    /// Number of images.
    #[getter]
    fn n_images(&self) -> usize {
        self.0.n_images()
    }

    /// Number of labelled pixels kept.
    #[getter]
    fn n_samples(&self) -> usize {
        self.0.len()
    }

    /// A digest of the data: equal on every worker that loaded the same files.
    #[getter]
    fn fingerprint(&self) -> u64 {
        self.0.fingerprint()
    }
}

/// A patch store on shared storage (`vp_forest::patch_store`), opened once
/// per worker process: labels and angles in memory, patches read chunk by
/// chunk as each tree needs them.
#[pyclass(name = "PatchStore", module = "vpctl.distributed", frozen)]
pub struct PyPatchStore(vp_forest::PatchStore);

#[pymethods]
impl PyPatchStore {
    /// Opens the store in `path` (manifest, labels, angles and chunk sizes
    /// checked).
    #[staticmethod]
    fn open(py: Python<'_>, path: PathBuf) -> PyResult<Self> {
        py.detach(|| vp_forest::PatchStore::open(&path))
            .py()
            .map(PyPatchStore)
    }

    /// Loads the training set as `TrainingData.from_dirs` does and writes the
    /// draw of `params` and `seed` as a store at `out` (atomically; an
    /// existing folder is refused unless `force`). Returns the manifest as
    /// JSON text.
    #[staticmethod]
    #[pyo3(signature = (images_dir, labels_dir, out, params = None, seed = 0,
                        max_per_label_image = None, chunk_len = vp_forest::patch_store::DEFAULT_CHUNK_LEN,
                        force = false))]
    #[allow(clippy::too_many_arguments)] // Python keyword arguments
    fn write(
        py: Python<'_>,
        images_dir: PathBuf,
        labels_dir: PathBuf,
        out: PathBuf,
        params: Option<&Bound<'_, PyAny>>,
        seed: u64,
        max_per_label_image: Option<usize>,
        chunk_len: usize,
        force: bool,
    ) -> PyResult<String> {
        let p: TrainParams = convert::from_py(params, "params")?;
        py.detach(|| {
            let set =
                TrainingSet::from_label_dir(&images_dir, &labels_dir, max_per_label_image, seed)?;
            vp_forest::write_patch_store(
                &set,
                &p,
                seed,
                &out,
                &[&images_dir, &labels_dir],
                chunk_len,
                force,
            )
        })
        .py()
        .map(|m| serde_json::to_string(&m).unwrap_or_default())
    }

    /// Trains tree `index` from the store with `params` (the store's seed),
    /// holding at most `budget_mb` MiB of patches; returns it as bytes for
    /// [`assemble`] and what it read (`chunk_reads`, `bytes_read`,
    /// `subtrees_loaded`, `peak_patch_bytes`).
    #[pyo3(signature = (index, params = None, budget_mb = 4096))]
    fn train_tree(
        &self,
        py: Python<'_>,
        index: usize,
        params: Option<&Bound<'_, PyAny>>,
        budget_mb: usize,
    ) -> PyResult<(std::borrow::Cow<'static, [u8]>, [u64; 4])> {
        let p: TrainParams = convert::from_py(params, "params")?;
        let store = &self.0;
        let budget = vp_forest::StoreBudget {
            resident_bytes: budget_mb << 20,
        };
        py.detach(|| store.train_tree_counted(&p, index, budget))
            .py()
            .map(|(t, r)| {
                (
                    t.to_bytes().into(),
                    [
                        r.chunk_reads,
                        r.bytes_read,
                        r.subtrees_loaded,
                        r.peak_patch_bytes,
                    ],
                )
            })
    }

    /// Samples in the store.
    #[getter]
    fn n_samples(&self) -> usize {
        self.0.len()
    }

    /// The seed of the store's draw (and of its trees).
    #[getter]
    fn seed(&self) -> u64 {
        self.0.manifest().seed
    }
}

/// The forest made of trees (bytes of `TrainingData.train_tree`, any
/// order): the same model as training in one process.
#[pyfunction]
fn assemble(py: Python<'_>, trees: Vec<Vec<u8>>) -> PyResult<PyForest> {
    py.detach(|| {
        let parsed = trees
            .iter()
            .enumerate()
            .map(|(i, b)| TrainedTree::from_bytes(b, &PathBuf::from(format!("tree bytes [{i}]"))))
            .collect::<Result<Vec<_>, _>>()?;
        vp_forest::assemble(parsed)
    })
    .py()
    .map(PyForest)
}

/// Reconstructs `images` of the dense workspace on their own at pyramid
/// `level` into `out_dir` (one `<triplet id>/level<L>` folder of the layout
/// `vpctl labelgen run` reads), as `vpctl mvs run --triplets` does for one
/// triplet and level. Returns the share of pixels with a geometric depth
/// per image. `params`: any subset of `vpctl mvs defaults`.
#[pyfunction]
#[pyo3(signature = (workspace, images, level, out_dir, params = None, depth_range = None))]
fn mvs_image_set(
    py: Python<'_>,
    workspace: PathBuf,
    images: Vec<String>,
    level: u32,
    out_dir: PathBuf,
    params: Option<&Bound<'_, PyAny>>,
    depth_range: Option<(f64, f64)>,
) -> PyResult<Vec<f64>> {
    let p: MvsParams = convert::from_py(params, "params")?;
    py.detach(|| {
        let ws = vp_mvs::Workspace::open(&workspace)?;
        vp_mvs::run_image_set(&ws, &images, level, depth_range, &p, &out_dir, &mut |_| {})
    })
    .map_err(|e| crate::errors::mvs(&e))
}

/// Every reconstruction of a labelling run (model, triplet list, depth-map
/// folder as `vpctl labelgen run` reads them), loaded once per worker
/// process: every chunk of queries needs all of them as references.
#[pyclass(name = "LabelData", module = "vpctl.distributed", frozen)]
pub struct PyLabelData {
    recs: Vec<TripletReconstruction>,
    meshes: Option<MissingPartMeshes>,
    params: LabelParams,
}

#[pymethods]
impl PyLabelData {
    /// Loads as `vpctl labelgen run --model --triplets --depth-dir [--mesh
    /// --config --frame-unchecked]`; `params` as a dict (any subset).
    #[staticmethod]
    #[pyo3(signature = (model, triplets, depth_dir, mesh = None, params = None, frame_unchecked = false))]
    fn load(
        py: Python<'_>,
        model: PathBuf,
        triplets: PathBuf,
        depth_dir: PathBuf,
        mesh: Option<PathBuf>,
        params: Option<&Bound<'_, PyAny>>,
        frame_unchecked: bool,
    ) -> PyResult<Self> {
        let mut req = LabelRunRequest::new(ModelSource::detect(&model), triplets, depth_dir);
        req.mesh = mesh;
        req.params = convert::from_py(params, "params")?;
        req.frame_unchecked = frame_unchecked;
        let run = py.detach(|| vp_labelgen::load_label_run(&req)).py()?;
        crate::errors::warn_all(py, &run.warnings)?;
        Ok(PyLabelData {
            recs: run.reconstructions,
            meshes: run.meshes,
            params: run.params,
        })
    }

    /// Ids of the reconstructions (`t0000/level1`, ...), in id order.
    fn ids(&self) -> Vec<String> {
        let mut ids: Vec<String> = self.recs.iter().map(|r| r.id.clone()).collect();
        ids.sort();
        ids
    }

    /// {id: ids of its references}: whose support `label` needs for it.
    fn references(
        &self,
        py: Python<'_>,
    ) -> PyResult<std::collections::BTreeMap<String, Vec<String>>> {
        let refs = py
            .detach(|| vp_labelgen::references_of(&self.recs, &self.params))
            .py()?;
        Ok(refs.into_iter().collect())
    }

    /// Stage 1 for `queries`: per id, the support of its three views as
    /// little-endian u16 bytes, concatenated view after view.
    fn support(
        &self,
        py: Python<'_>,
        queries: Vec<String>,
    ) -> PyResult<Vec<(String, std::borrow::Cow<'static, [u8]>)>> {
        let maps = py
            .detach(|| vp_labelgen::support_for(&self.recs, &queries, &self.params))
            .py()?;
        Ok(maps
            .into_iter()
            .map(|(id, views)| {
                let bytes: Vec<u8> = views
                    .iter()
                    .flat_map(|v| v.iter().flat_map(|s| s.to_le_bytes()))
                    .collect();
                (id, bytes.into())
            })
            .collect())
    }

    /// Stages 2 and 3 for `queries`, given `supports` {id: bytes of
    /// `support`} of at least their references; writes their label files
    /// under `out_dir` (each atomically; refuses to overwrite unless
    /// `force`) and returns the chunk's summary as JSON text (combine
    /// with `write_summary`).
    #[pyo3(signature = (queries, supports, out_dir, force = false))]
    fn label(
        &self,
        py: Python<'_>,
        queries: Vec<String>,
        supports: std::collections::BTreeMap<String, Vec<u8>>,
        out_dir: PathBuf,
        force: bool,
    ) -> PyResult<String> {
        let mut maps = Vec::with_capacity(supports.len());
        for (id, bytes) in supports {
            let Some(rec) = self.recs.iter().find(|r| r.id == id) else {
                return Err(value_error(format!(
                    "support given for {id}, which is not a reconstruction"
                )));
            };
            let sizes = rec.views.each_ref().map(|v| v.depth.data.len());
            if bytes.len() != 2 * sizes.iter().sum::<usize>() {
                return Err(value_error(format!(
                    "support of {id}: {} bytes, its views have {sizes:?} pixels",
                    bytes.len()
                )));
            }
            let values: Vec<u16> = bytes
                .chunks_exact(2)
                .map(|c| u16::from_le_bytes([c[0], c[1]]))
                .collect();
            let (a, rest) = values.split_at(sizes[0]);
            let (b, c) = rest.split_at(sizes[1]);
            maps.push((id, [a.to_vec(), b.to_vec(), c.to_vec()]));
        }
        let summary = py
            .detach(|| {
                let labels = vp_labelgen::labels_for(
                    &self.recs,
                    &maps,
                    &queries,
                    self.meshes.as_ref(),
                    &self.params,
                )?;
                io::write_label_images(&out_dir, &labels, force)
            })
            .py()?;
        serde_json::to_string(&summary).map_err(|e| value_error(format!("summary: {e}")))
    }
}

/// Combines the chunks' summaries (JSON texts of `LabelData.label`) into
/// `<out_dir>/summary.json`, as `vpctl labelgen run` writes it; returns it
/// as a dict.
#[pyfunction]
fn write_summary(
    py: Python<'_>,
    out_dir: PathBuf,
    parts: Vec<String>,
) -> PyResult<Bound<'_, PyAny>> {
    let parts = parts
        .iter()
        .map(|t| serde_json::from_str::<LabelSummary>(t))
        .collect::<Result<Vec<_>, _>>()
        .map_err(|e| value_error(format!("label summary: {e}")))?;
    let s = LabelSummary::combine(&parts);
    io::write_summary(&out_dir, &s).py()?;
    convert::to_py(py, &s)
}

/// The images `vpctl predict` would take from these paths: files as they
/// are, folders searched recursively; (path, name) pairs.
#[pyfunction]
fn find_images(py: Python<'_>, paths: Vec<PathBuf>) -> PyResult<Vec<(PathBuf, String)>> {
    py.detach(|| vp_scene::image_files::find_images(&paths))
        .py()
}

/// Loads a model file and predicts `images` ((path, name) pairs of
/// `find_images`) into `out_dir` as `vpctl predict` does (`.vpconf` per
/// image, PNG previews unless `previews` is false); returns the confidence
/// files written.
#[pyfunction]
#[pyo3(signature = (model, images, out_dir, step = 8, previews = true, force = false))]
fn predict_files(
    py: Python<'_>,
    model: PathBuf,
    images: Vec<(PathBuf, String)>,
    out_dir: PathBuf,
    step: u32,
    previews: bool,
    force: bool,
) -> PyResult<Vec<PathBuf>> {
    py.detach(|| {
        let forest = Forest::load(&model)?;
        let options = vp_forest::BatchOptions {
            step,
            previews,
            force,
        };
        let done = vp_forest::predict_files(&forest, &images, &out_dir, &options)?;
        Ok::<Vec<PathBuf>, vp_forest::ForestError>(
            done.into_iter().map(|p| p.confidence_file).collect(),
        )
    })
    .py()
}

/// Registers the submodule.
pub fn register(m: &Bound<'_, PyModule>) -> PyResult<()> {
    m.add_class::<PyTrainingData>()?;
    m.add_class::<PyLabelData>()?;
    m.add_class::<PyPatchStore>()?;
    m.add_function(wrap_pyfunction!(assemble, m)?)?;
    m.add_function(wrap_pyfunction!(mvs_image_set, m)?)?;
    m.add_function(wrap_pyfunction!(write_summary, m)?)?;
    m.add_function(wrap_pyfunction!(find_images, m)?)?;
    m.add_function(wrap_pyfunction!(predict_files, m)?)?;
    Ok(())
}
