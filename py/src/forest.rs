//! `vpctl.forest`: train, predict, save/load and score the confidence
//! forest (vp-forest); the `ConfidenceImage` the planner reads.

use std::path::PathBuf;

use numpy::{PyArray1, PyArray3, PyReadonlyArray1, PyReadonlyArray3};
use pyo3::prelude::*;
use vp_forest::{Forest, Scored, TrainParams, TrainingSet};
use vp_scene::fsio;
use vp_scene::raster::{AngleBins, ConfidenceImage};

use crate::convert::{self, image3, ArrayPair};
use crate::errors::{value_error, IntoPy};

/// Predicted MVS confidence of one image: b values per node of a grid with
/// step `step` pixels.
#[pyclass(
    name = "ConfidenceImage",
    module = "vpctl.forest",
    frozen,
    from_py_object
)]
#[derive(Clone)]
pub struct PyConfidence(pub ConfidenceImage);

#[pymethods]
impl PyConfidence {
    /// From grid values (gh, gw, b) float32 of a `width` x `height` image
    /// at grid step `step`, with b uniform angle bins over [0, gamma_max_deg).
    #[new]
    #[pyo3(signature = (values, width, height, step, gamma_max_deg = 45.0))]
    fn new(
        values: &Bound<'_, PyAny>,
        width: u32,
        height: u32,
        step: u32,
        gamma_max_deg: f32,
    ) -> PyResult<Self> {
        let values: PyReadonlyArray3<'_, f32> = convert::reals(values, "(gh, gw, b)", "values")?;
        let v = values.as_array();
        let (gh, gw, b) = v.dim();
        let bins = AngleBins::uniform(b, gamma_max_deg).py()?;
        let mut c = ConfidenceImage::zeros(width, height, step, bins).py()?;
        if c.grid_size() != (gw, gh) {
            return Err(value_error(format!(
                "values: grid {gw}x{gh} does not fit a {width}x{height} image at step {step} (needs {:?})",
                c.grid_size()
            )));
        }
        for (dst, src) in c.values_mut().iter_mut().zip(v.iter()) {
            *dst = *src;
        }
        Ok(PyConfidence(c))
    }

    /// The same confidence everywhere: `constant(1.0)` is prediction off (NP).
    #[staticmethod]
    fn constant(value: f32) -> Self {
        PyConfidence(ConfidenceImage::constant(value))
    }

    /// Reads a `.vpconf` file.
    #[staticmethod]
    fn load(path: PathBuf) -> PyResult<Self> {
        ConfidenceImage::load(&path).py().map(PyConfidence)
    }

    /// Writes a `.vpconf` file; refuses to overwrite unless `force`.
    #[pyo3(signature = (path, force = false))]
    fn save(&self, path: PathBuf, force: bool) -> PyResult<()> {
        fsio::check_overwrite(&path, force).py()?;
        self.0.save(&path).py()
    }

    /// Grid values, (gh, gw, b) float32 (a copy).
    #[getter]
    fn values<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyArray3<f32>>> {
        let (gw, gh) = self.0.grid_size();
        image3(py, (gh, gw, self.0.bins().len()), self.0.values().to_vec())
    }

    /// Grid step in pixels.
    #[getter]
    fn step(&self) -> u32 {
        self.0.step()
    }

    /// (width, height) of the image the grid covers.
    #[getter]
    fn size(&self) -> (u32, u32) {
        (self.0.width(), self.0.height())
    }

    /// Angle bin edges in degrees (b + 1).
    #[getter]
    fn bin_edges(&self) -> Vec<f32> {
        self.0.bins().edges().to_vec()
    }

    /// Confidence at pixel positions (N, 2) for angles (N,) in degrees,
    /// interpolated as the planner reads it.
    fn sample<'py>(
        &self,
        py: Python<'py>,
        pixels: &Bound<'_, PyAny>,
        angles_deg: &Bound<'_, PyAny>,
    ) -> PyResult<Bound<'py, PyArray1<f32>>> {
        let pixels = convert::f64_2d(pixels, "(N, 2)", "pixels")?;
        let angles_deg: PyReadonlyArray1<'_, f64> =
            convert::reals(angles_deg, "(N,)", "angles_deg")?;
        let (p, a) = (pixels.as_array(), angles_deg.as_array());
        if p.nrows() != a.len() {
            return Err(value_error(format!(
                "pixels {:?} and angles_deg {:?}: expected (N, 2) and (N,), one angle per pixel",
                p.shape(),
                a.shape()
            )));
        }
        let v: Vec<f32> = p
            .rows()
            .into_iter()
            .zip(a.iter())
            .map(|(r, &ang)| self.0.sample((r[0], r[1]), ang))
            .collect();
        Ok(PyArray1::from_vec(py, v))
    }
}

/// A trained Semantic Texton Forest with angle-binned leaves.
#[pyclass(name = "Forest", module = "vpctl.forest", frozen)]
pub struct PyForest(pub Forest);

#[pymethods]
impl PyForest {
    /// Reads a model file.
    #[staticmethod]
    fn load(py: Python<'_>, path: PathBuf) -> PyResult<Self> {
        py.detach(|| Forest::load(&path)).py().map(PyForest)
    }

    /// Writes the model; refuses to overwrite unless `force`.
    #[pyo3(signature = (path, force = false))]
    fn save(&self, py: Python<'_>, path: PathBuf, force: bool) -> PyResult<()> {
        fsio::check_overwrite(&path, force).py()?;
        py.detach(|| self.0.save(&path)).py()
    }

    /// The model file's bytes.
    fn to_bytes(&self) -> std::borrow::Cow<'static, [u8]> {
        self.0.to_bytes().into()
    }

    /// Number of trees.
    #[getter]
    fn n_trees(&self) -> usize {
        self.0.trees().len()
    }

    /// The training parameters, as a dict.
    #[getter]
    fn params<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyAny>> {
        convert::to_py(py, self.0.params())
    }

    /// What it was trained on, as a dict.
    #[getter]
    fn summary<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyAny>> {
        convert::to_py(py, self.0.summary())
    }

    /// Confidence image of an (H, W, 3) uint8 image on a grid of step `step`.
    #[pyo3(signature = (image, step = 8))]
    fn predict(
        &self,
        py: Python<'_>,
        image: &Bound<'_, PyAny>,
        step: u32,
    ) -> PyResult<PyConfidence> {
        let img = convert::rgb_like(image, "image")?;
        py.detach(|| self.0.predict_image(&img, step))
            .py()
            .map(PyConfidence)
    }

    /// Scores the labelled pixels of (labels, angles) on `image`:
    /// (confidence (N,) float32, positive (N,) bool), row-major pixel order.
    fn score<'py>(
        &self,
        py: Python<'py>,
        image: &Bound<'_, PyAny>,
        labels: &Bound<'_, PyAny>,
        angles: &Bound<'_, PyAny>,
    ) -> PyResult<ArrayPair<'py, PyArray1<f32>, PyArray1<bool>>> {
        let img = convert::rgb_like(image, "image")?;
        let lab = convert::label_image_like(labels, angles, "labels", "angles")?;
        let s = py.detach(|| self.0.score_labels(&img, &lab)).py()?;
        Ok((
            PyArray1::from_vec(py, s.iter().map(|x| x.confidence).collect()),
            PyArray1::from_vec(py, s.iter().map(|x| x.positive).collect()),
        ))
    }
}

/// Trains a forest from images (H, W, 3) uint8, labels (H, W) uint8 (0
/// unlabelled, 1 positive, 2 negative) and angles (H, W) float32 (degrees),
/// one label image per image. `params`: any subset of the training
/// parameters (n_trees, max_depth, ...; default the paper's). Same inputs
/// and seed, same model bytes.
#[pyfunction]
#[pyo3(signature = (images, labels, angles, params = None, seed = 0, max_per_label_image = None))]
fn train(
    py: Python<'_>,
    images: Vec<Bound<'_, PyAny>>,
    labels: Vec<Bound<'_, PyAny>>,
    angles: Vec<Bound<'_, PyAny>>,
    params: Option<&Bound<'_, PyAny>>,
    seed: u64,
    max_per_label_image: Option<usize>,
) -> PyResult<PyForest> {
    if images.len() != labels.len() || images.len() != angles.len() {
        return Err(value_error(format!(
            "{} images, {} label arrays and {} angle arrays: one of each per image",
            images.len(),
            labels.len(),
            angles.len()
        )));
    }
    let p: TrainParams = convert::from_py(params, "params")?;
    let mut set = match max_per_label_image {
        Some(n) => TrainingSet::with_cap_per_label_image(n, seed),
        None => TrainingSet::new(),
    };
    for (i, ((img, l), a)) in images.iter().zip(&labels).zip(&angles).enumerate() {
        let img = convert::rgb_like(img, &format!("images[{i}]"))?;
        let lab =
            convert::label_image_like(l, a, &format!("labels[{i}]"), &format!("angles[{i}]"))?;
        set.add_image(&img, &[lab]).py()?;
    }
    py.detach(|| vp_forest::train(&set, &p, seed))
        .py()
        .map(PyForest)
}

/// Trains as `vpctl train` does: images from `images_dir`, label images
/// `<image name>.vplabel` found under `labels_dir` (the layout `vpctl
/// labelgen run` writes). Same files, parameters and seed: same model bytes.
#[pyfunction]
#[pyo3(signature = (images_dir, labels_dir, params = None, seed = 0, max_per_label_image = None))]
fn train_dirs(
    py: Python<'_>,
    images_dir: PathBuf,
    labels_dir: PathBuf,
    params: Option<&Bound<'_, PyAny>>,
    seed: u64,
    max_per_label_image: Option<usize>,
) -> PyResult<PyForest> {
    let p: TrainParams = convert::from_py(params, "params")?;
    p.validate().py()?;
    py.detach(|| {
        let set = TrainingSet::from_label_dir(&images_dir, &labels_dir, max_per_label_image, seed)?;
        vp_forest::train(&set, &p, seed)
    })
    .py()
    .map(PyForest)
}

/// The training parameters of a preset, as a dict: `"default"` (10 trees
/// of depth 16, the size chosen by measured held-out accuracy) or
/// `"paper"` (20 trees of depth 20), as `vpctl forest defaults --preset`.
#[pyfunction]
#[pyo3(signature = (preset = "default"))]
fn default_params<'py>(py: Python<'py>, preset: &str) -> PyResult<Bound<'py, PyAny>> {
    let p: vp_forest::Preset = preset
        .parse()
        .map_err(|e: String| value_error(format!("preset: {e}")))?;
    convert::to_py(py, &TrainParams::preset(p))
}

fn scored(confidence: &Bound<'_, PyAny>, positive: &Bound<'_, PyAny>) -> PyResult<Vec<Scored>> {
    let confidence: PyReadonlyArray1<'_, f32> = convert::reals(confidence, "(N,)", "confidence")?;
    let positive: PyReadonlyArray1<'_, bool> = convert::bools(positive, "(N,)", "positive")?;
    let (c, p) = (confidence.as_array(), positive.as_array());
    if c.len() != p.len() {
        return Err(value_error(format!(
            "{} confidences but {} labels",
            c.len(),
            p.len()
        )));
    }
    Ok(c.iter()
        .zip(p.iter())
        .map(|(&confidence, &positive)| Scored {
            confidence,
            positive,
        })
        .collect())
}

/// Share of samples whose (confidence >= threshold) matches their label.
#[pyfunction]
#[pyo3(signature = (confidence, positive, threshold = 0.5))]
fn accuracy(
    confidence: &Bound<'_, PyAny>,
    positive: &Bound<'_, PyAny>,
    threshold: f32,
) -> PyResult<f64> {
    vp_forest::accuracy(&scored(confidence, positive)?, threshold).py()
}

/// Sparsification curve and AUSC (absolute, optimal, relative, random).
#[pyfunction]
#[pyo3(signature = (confidence, positive, curve_points = 100))]
fn sparsification<'py>(
    py: Python<'py>,
    confidence: &Bound<'_, PyAny>,
    positive: &Bound<'_, PyAny>,
    curve_points: usize,
) -> PyResult<Bound<'py, PyAny>> {
    let s = vp_forest::sparsification(&scored(confidence, positive)?, curve_points).py()?;
    convert::to_py(py, &s)
}

/// Registers the submodule.
pub fn register(m: &Bound<'_, PyModule>) -> PyResult<()> {
    m.add_class::<PyForest>()?;
    m.add_class::<PyConfidence>()?;
    m.add_function(wrap_pyfunction!(train, m)?)?;
    m.add_function(wrap_pyfunction!(train_dirs, m)?)?;
    m.add_function(wrap_pyfunction!(default_params, m)?)?;
    m.add_function(wrap_pyfunction!(accuracy, m)?)?;
    m.add_function(wrap_pyfunction!(sparsification, m)?)?;
    Ok(())
}
