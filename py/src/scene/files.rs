//! COLMAP models, depth maps, images and label images for `vpctl.scene`.

use std::path::PathBuf;

use nalgebra::Point3;
use numpy::{PyArray2, PyArray3, PyReadonlyArray2};
use pyo3::prelude::*;
use vp_scene::colmap::{self, DepthMap, Reconstruction};
use vp_scene::fsio;
use vp_scene::raster::{self, LabelImage};

use super::PyCamera;
use crate::convert::{self, image2, points_array, ArrayPair};
use crate::errors::{value_error, IntoPy};

/// A COLMAP sparse model (cameras, images, points).
#[pyclass(name = "ColmapModel", module = "vpctl.scene", frozen)]
pub struct PyColmap(pub Reconstruction);

#[pymethods]
impl PyColmap {
    /// Reads a model folder (binary or text, detected).
    #[staticmethod]
    fn load(py: Python<'_>, path: PathBuf) -> PyResult<Self> {
        py.detach(|| colmap::read_model(&path)).py().map(PyColmap)
    }

    /// Writes the model into the folder `path` as `binary` (or `bin`) or
    /// `text` (or `txt`, the CLI's `--output-type` names) files; refuses to
    /// overwrite existing model files unless `force`.
    #[pyo3(signature = (path, format = "binary", force = false))]
    fn save(&self, py: Python<'_>, path: PathBuf, format: &str, force: bool) -> PyResult<()> {
        let kind = match format {
            "binary" | "bin" => colmap::ModelFormat::Binary,
            "text" | "txt" => colmap::ModelFormat::Text,
            other => {
                return Err(value_error(format!(
                    "format: {other:?} is not \"binary\" (\"bin\") or \"text\" (\"txt\")"
                )))
            }
        };
        for f in kind.files(&path) {
            fsio::check_overwrite(&f, force).py()?;
        }
        match kind {
            colmap::ModelFormat::Binary => py.detach(|| colmap::write_binary(&path, &self.0)).py(),
            colmap::ModelFormat::Text => py.detach(|| colmap::write_text(&path, &self.0)).py(),
        }
    }

    /// Image names in id order.
    #[getter]
    fn image_names(&self) -> Vec<String> {
        self.0.images.values().map(|i| i.name.clone()).collect()
    }

    /// One camera per image, in id order.
    fn cameras(&self) -> PyResult<Vec<PyCamera>> {
        self.0
            .images
            .keys()
            .map(|&id| self.0.camera_of(id).py().map(PyCamera))
            .collect()
    }

    /// 3D points, (N, 3).
    #[getter]
    fn points<'py>(&self, py: Python<'py>) -> Bound<'py, PyArray2<f64>> {
        let p: Vec<Point3<f64>> = self.0.points.values().map(|p| p.xyz).collect();
        points_array(py, &p)
    }

    fn __len__(&self) -> usize {
        self.0.images.len()
    }
}

/// Reads a COLMAP depth map (.bin) as an (H, W) float32 array.
#[pyfunction]
pub(super) fn read_depth_map(py: Python<'_>, path: PathBuf) -> PyResult<Bound<'_, PyArray2<f32>>> {
    let d = py.detach(|| colmap::read_depth_map(&path)).py()?;
    image2(py, d.width, d.height, d.data)
}

/// Writes an (H, W) real array as a COLMAP depth map (.bin, float32);
/// refuses to overwrite unless `force`.
#[pyfunction]
#[pyo3(signature = (path, depth, force = false))]
pub(super) fn write_depth_map(
    path: PathBuf,
    depth: &Bound<'_, PyAny>,
    force: bool,
) -> PyResult<()> {
    let depth: PyReadonlyArray2<'_, f32> = crate::convert::reals(depth, "(H, W)", "depth")?;
    fsio::check_overwrite(&path, force).py()?;
    colmap::write_depth_map(&path, &depth_map(&depth)).py()
}

/// An (H, W) float32 array as a depth map.
pub fn depth_map(a: &PyReadonlyArray2<'_, f32>) -> DepthMap {
    let v = a.as_array();
    DepthMap {
        width: v.ncols() as u32,
        height: v.nrows() as u32,
        data: v.iter().copied().collect(),
    }
}

/// Reads an image file (PNG, JPEG, TIFF) as an (H, W, 3) uint8 array.
#[pyfunction]
pub(super) fn load_image(py: Python<'_>, path: PathBuf) -> PyResult<Bound<'_, PyArray3<u8>>> {
    let img = py.detach(|| raster::load_rgb(&path)).py()?;
    convert::rgb_array(py, &img)
}

/// Writes an (H, W, 3) uint8 array as an image file (format from the
/// extension); refuses to overwrite unless `force`.
#[pyfunction]
#[pyo3(signature = (path, image, force = false))]
pub(super) fn save_image(path: PathBuf, image: &Bound<'_, PyAny>, force: bool) -> PyResult<()> {
    let img = convert::rgb_like(image, "image")?;
    fsio::check_overwrite(&path, force).py()?;
    raster::save_rgb(&img, &path).py()
}

/// Writes labels (H, W) uint8 (0 unlabelled, 1 positive, 2 negative) and
/// angles (H, W) float32 (degrees) as a `.vplabel` file.
#[pyfunction]
#[pyo3(signature = (path, labels, angles, force = false))]
pub(super) fn write_label_image(
    path: PathBuf,
    labels: &Bound<'_, PyAny>,
    angles: &Bound<'_, PyAny>,
    force: bool,
) -> PyResult<()> {
    let img = convert::label_image_like(labels, angles, "labels", "angles")?;
    fsio::check_overwrite(&path, force).py()?;
    img.save(&path).py()
}

/// Reads a `.vplabel` file as (labels (H, W) uint8, angles (H, W) float32).
#[pyfunction]
pub(super) fn read_label_image(
    py: Python<'_>,
    path: PathBuf,
) -> PyResult<ArrayPair<'_, PyArray2<u8>, PyArray2<f32>>> {
    let img = LabelImage::load(&path).py()?;
    convert::label_arrays(py, &img)
}
