//! `vpctl.sim`: the simulated world (vp-sim): rendered images of a
//! procedural site and a virtual MVS whose failures depend on material and
//! triangulation angle; closed-loop campaigns (see [`crate::campaign`]).

use std::path::PathBuf;

use numpy::PyArray2;
use pyo3::prelude::*;
use pyo3::types::PyDict;
use vp_sim::flight::{FlightRequest, FlyOptions};
use vp_sim::{MvsProfile, RenderParams, VirtualMvs};

use crate::convert::{self, image2, rgb_array};
use crate::errors::{value_error, IntoPy};
use crate::progress::Progress;
use crate::scene::{PyCamera, PyMesh, PyRayCaster};

/// Renders `camera`'s view of `mesh` (per-material solid textures, sun
/// shading): dict of rgb (H, W, 3) uint8, depth (H, W) float32 (0 where no
/// surface) and face_id (H, W) int64 (-1). `params`: any subset of
/// sun_azimuth_deg, sun_elevation_deg, ambient, shadows, texture_seed, sky.
#[pyfunction]
#[pyo3(signature = (mesh, caster, camera, params = None))]
fn render<'py>(
    py: Python<'py>,
    mesh: PyRef<'_, PyMesh>,
    caster: PyRef<'_, PyRayCaster>,
    camera: PyRef<'_, PyCamera>,
    params: Option<&Bound<'_, PyAny>>,
) -> PyResult<Bound<'py, PyDict>> {
    let p: RenderParams = convert::from_py_strict(params, "params")?;
    let (m, c, cam) = (&mesh.0, &caster.0, &camera.0);
    let r = py.detach(|| vp_sim::render(m, c, cam, &p)).py()?;
    let face: Vec<i64> = r
        .face_id
        .iter()
        .map(|&f| if f == u32::MAX { -1 } else { i64::from(f) })
        .collect();
    let d = PyDict::new(py);
    d.set_item("rgb", rgb_array(py, &r.rgb)?)?;
    d.set_item(
        "depth",
        image2(py, r.depth.width, r.depth.height, r.depth.data)?,
    )?;
    d.set_item("face_id", image2(py, r.depth.width, r.depth.height, face)?)?;
    Ok(d)
}

/// A virtual dense MVS: one depth map per image of a camera triplet, failing
/// by material, triangulation angle and resolution.
#[pyclass(name = "VirtualMvs", module = "vpctl.sim", frozen)]
pub struct PyVirtualMvs(VirtualMvs);

#[pymethods]
impl PyVirtualMvs {
    /// `profile`: "sure" (SURE-like, default), "pmvs" (PMVS-like) or a dict
    /// of a full profile.
    #[new]
    #[pyo3(signature = (profile = None))]
    fn new(profile: Option<&Bound<'_, PyAny>>) -> PyResult<Self> {
        let p = match profile {
            None => MvsProfile::sure_like(),
            Some(o) => match o.extract::<String>() {
                Ok(s) if s == "sure" => MvsProfile::sure_like(),
                Ok(s) if s == "pmvs" => MvsProfile::pmvs_like(),
                Ok(s) => {
                    return Err(value_error(format!(
                        "profile {s:?}: expected \"sure\", \"pmvs\" or a dict"
                    )))
                }
                Err(_) => convert::from_py_required(o, "profile")?,
            },
        };
        VirtualMvs::new(p).py().map(PyVirtualMvs)
    }

    /// The profile, as a dict.
    #[getter]
    fn profile<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyAny>> {
        convert::to_py(py, self.0.profile())
    }

    /// Depth maps (H, W) float32 of the three cameras of a triplet at
    /// pyramid `level` (1 = full resolution); same inputs and seed, same maps.
    #[pyo3(signature = (mesh, caster, cameras, level = 1, seed = 0))]
    fn reconstruct<'py>(
        &self,
        py: Python<'py>,
        mesh: PyRef<'_, PyMesh>,
        caster: PyRef<'_, PyRayCaster>,
        cameras: Vec<PyCamera>,
        level: u8,
        seed: u64,
    ) -> PyResult<Vec<Bound<'py, PyArray2<f32>>>> {
        let [a, b, c]: [PyCamera; 3] = cameras
            .try_into()
            .map_err(|v: Vec<PyCamera>| value_error(format!("{} cameras, expected 3", v.len())))?;
        let (m, k) = (&mesh.0, &caster.0);
        let maps = py
            .detach(|| self.0.reconstruct(m, k, [&a.0, &b.0, &c.0], level, seed))
            .py()?;
        maps.into_iter()
            .map(|d| image2(py, d.width, d.height, d.data))
            .collect()
    }
}

/// `vpctl sim fly PLANS --site SITE --out OUT [--exact --output-type
/// --max-points --force]` ([`vp_sim::flight::write_flight`]): flies the plan
/// files in order over the config's site and writes `images/` and the
/// COLMAP model `sparse/` with its `frame.json`, byte for byte as the CLI.
/// Returns {images_dir, images, sparse_dir, points, min_views}.
#[pyfunction]
#[pyo3(signature = (plans, site, out, exact = false, output_type = "txt", max_points = 20_000, force = false, progress = None))]
#[allow(clippy::too_many_arguments)]
fn fly<'py>(
    py: Python<'py>,
    plans: Vec<PathBuf>,
    site: PathBuf,
    out: PathBuf,
    exact: bool,
    output_type: &str,
    max_points: usize,
    force: bool,
    progress: Option<Py<PyAny>>,
) -> PyResult<Bound<'py, PyDict>> {
    let binary = match output_type {
        "txt" => false,
        "bin" => true,
        other => {
            return Err(value_error(format!(
                "output_type {other:?}: expected \"txt\" or \"bin\""
            )))
        }
    };
    let mut req = FlightRequest::new(plans, site, out);
    req.options = FlyOptions { exact, max_points };
    req.binary = binary;
    req.force = force;
    let mut progress = Progress::from_arg(py, progress)?;
    let s = py.detach(|| vp_sim::flight::write_flight(&req, &mut |l| progress.line(l)));
    progress.finish()?;
    let s = s.py()?;
    let d = PyDict::new(py);
    d.set_item("images_dir", s.images_dir)?;
    d.set_item("images", s.images)?;
    d.set_item("sparse_dir", s.sparse_dir)?;
    d.set_item("points", s.points)?;
    d.set_item("min_views", s.min_views)?;
    Ok(d)
}

/// Registers the submodule.
pub fn register(m: &Bound<'_, PyModule>) -> PyResult<()> {
    m.add_class::<PyVirtualMvs>()?;
    m.add_function(wrap_pyfunction!(render, m)?)?;
    m.add_function(wrap_pyfunction!(fly, m)?)?;
    crate::campaign::register(m)
}
