//! `vpctl.planner`: the paper's planner (M1-M4) and the grid baseline
//! (vp-planner); plans as Python objects and numpy arrays.

use std::path::PathBuf;

use nalgebra::Point3;
use numpy::{PyArray1, PyArray2};
use pyo3::prelude::*;
use pyo3::types::PyDict;
use vp_planner::free_space::observations_from_model;
use vp_planner::grid::GridParams;
use vp_planner::{
    AcquiredView, GridRequest, HomeSpec, ModelPlanRequest, Observation, PlanInputs, PlanResult,
    PlannerConfig, RoiSpec,
};
use vp_scene::opensfm::ModelSource;
use vp_scene::plan::{GeodeticOrigin, Plan, Role, VerticalDatum};
use vp_scene::roi::Roi;
use vp_scene::Mesh;

use crate::convert::{self, points_array};
use crate::errors::{value_error, IntoPy};
use crate::forest::PyConfidence;
use crate::scene::{PyCamera, PyColmap, PyMesh};

/// A plan: ordered views with the constraints they were planned under.
#[pyclass(name = "Plan", module = "vpctl.planner", frozen)]
#[derive(Clone)]
pub struct PyPlan(pub Plan);

#[pymethods]
impl PyPlan {
    /// Reads a plan file (JSON).
    #[staticmethod]
    fn load(path: PathBuf) -> PyResult<Self> {
        Plan::load(&path).py().map(PyPlan)
    }

    /// Parses a plan from JSON text.
    #[staticmethod]
    fn from_json(text: &str) -> PyResult<Self> {
        Plan::from_json(text, std::path::Path::new("<string>"))
            .py()
            .map(PyPlan)
    }

    /// Writes the plan as `vpctl plan --out` does (pretty JSON); without
    /// wall-clock timings when `no_timings` (same inputs and seed, same bytes).
    #[pyo3(signature = (path, force = false, no_timings = false))]
    fn save(&self, path: PathBuf, force: bool, no_timings: bool) -> PyResult<()> {
        self.maybe_stripped(no_timings).save(&path, force).py()
    }

    /// The plan as JSON text (what `save` writes, without the final newline).
    #[pyo3(signature = (no_timings = false))]
    fn to_json(&self, no_timings: bool) -> PyResult<String> {
        serde_json::to_string_pretty(&self.maybe_stripped(no_timings))
            .map_err(|e| value_error(format!("plan not serialisable: {e}")))
    }

    /// The plan as dicts and lists (the JSON structure).
    #[pyo3(signature = (no_timings = false))]
    fn to_dict<'py>(&self, py: Python<'py>, no_timings: bool) -> PyResult<Bound<'py, PyAny>> {
        convert::to_py(py, &self.maybe_stripped(no_timings))
    }

    /// Views in flight order, as dicts (position, yaw_deg, pitch_deg, role, ...).
    #[getter]
    fn waypoints<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyAny>> {
        convert::to_py(py, &self.0.waypoints)
    }

    /// View positions, (N, 3).
    #[getter]
    fn positions<'py>(&self, py: Python<'py>) -> Bound<'py, PyArray2<f64>> {
        let p: Vec<Point3<f64>> = self
            .0
            .waypoints
            .iter()
            .map(|w| Point3::from(w.position))
            .collect();
        points_array(py, &p)
    }

    /// (yaw_deg, pitch_deg) of each view, (N, 2).
    #[getter]
    fn angles<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyArray2<f64>>> {
        let a: Vec<f64> = self
            .0
            .waypoints
            .iter()
            .flat_map(|w| [w.yaw_deg, w.pitch_deg])
            .collect();
        convert::image2(py, 2, self.0.waypoints.len() as u32, a)
    }

    /// Whether planning stopped early, and why.
    #[getter]
    fn cut_short_reason(&self) -> Option<String> {
        self.0.cut_short_reason.clone()
    }

    fn __len__(&self) -> usize {
        self.0.waypoints.len()
    }
}

impl PyPlan {
    fn maybe_stripped(&self, no_timings: bool) -> Plan {
        let mut p = self.0.clone();
        if no_timings {
            vp_planner::strip_timings(&mut p);
        }
        p
    }
}

/// What a planning call produced besides the plan.
#[pyclass(name = "PlanResult", module = "vpctl.planner", frozen)]
pub struct PyPlanResult(PlanResult);

#[pymethods]
impl PyPlanResult {
    /// The plan.
    #[getter]
    fn plan(&self) -> PyPlan {
        PyPlan(self.0.plan.clone())
    }

    /// Per flown triplet: {iteration (its triplet_id), f_before, f_after,
    /// coverage, time_s}; a dropped triplet is not among them.
    #[getter]
    fn iterations<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyAny>> {
        convert::to_py(py, &self.0.iterations)
    }

    /// Gain of each flown triplet, when chosen.
    #[getter]
    fn triplet_gains(&self) -> Vec<f64> {
        self.0.triplet_gains.clone()
    }

    /// Wall time per module, seconds.
    #[getter]
    fn module_time_s(&self) -> std::collections::BTreeMap<String, f64> {
        self.0.module_time_s.clone()
    }

    /// Why fewer than k triplets are flown, or None.
    #[getter]
    fn cut_short_reason(&self) -> Option<String> {
        self.0.cut_short_reason.clone()
    }

    /// Triplets chosen but left out of the path: one of their images is
    /// unsafe or no safe route reaches it (`plan.to_json()`'s
    /// `dropped_triplets` has each with its replacement).
    #[getter]
    fn dropped_triplets(&self) -> Vec<u32> {
        self.0.dropped_triplets.clone()
    }

    /// Why each of `dropped_triplets` was left out, in the same order,
    /// naming waypoints of the plan, ending "replaced by triplet N" or
    /// "not replaced".
    #[getter]
    fn dropped_reasons(&self) -> Vec<String> {
        self.0.dropped_reasons.clone()
    }

    /// The sampled triangles: dict of centroid (N, 3), normal (N, 3), f (N,),
    /// selected (N,) bool, parent (N,) int64 (face of the input mesh).
    #[getter]
    fn sampled<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyDict>> {
        let s = &self.0.sampled;
        let d = PyDict::new(py);
        let c: Vec<Point3<f64>> = s.iter().map(|x| x.centroid).collect();
        let n: Vec<Point3<f64>> = s.iter().map(|x| Point3::from(x.normal)).collect();
        d.set_item("centroid", points_array(py, &c))?;
        d.set_item("normal", points_array(py, &n))?;
        d.set_item("f", PyArray1::from_vec(py, s.iter().map(|x| x.f).collect()))?;
        d.set_item(
            "selected",
            PyArray1::from_vec(py, s.iter().map(|x| x.selected).collect()),
        )?;
        d.set_item(
            "parent",
            PyArray1::from_vec(py, s.iter().map(|x| i64::from(x.parent)).collect()),
        )?;
        Ok(d)
    }
}

/// The configuration: a dict (any subset of the fields of
/// `default_config()`), a TOML file path, or None (the paper's defaults).
pub fn config(obj: Option<&Bound<'_, PyAny>>) -> PyResult<PlannerConfig> {
    let Some(obj) = obj.filter(|o| !o.is_none()) else {
        return Ok(PlannerConfig::default());
    };
    if obj.is_instance_of::<PyDict>() {
        let cfg: PlannerConfig = convert::from_py_required(obj, "config")?;
        cfg.validate().py()?;
        return Ok(cfg);
    }
    let path: PathBuf = obj
        .extract()
        .map_err(|_| value_error("config: expected a dict, a TOML file path or None"))?;
    PlannerConfig::load(&path).py()
}

fn mesh_of(obj: &Bound<'_, PyAny>) -> PyResult<Mesh> {
    if let Ok(m) = obj.cast::<PyMesh>() {
        return Ok(m.get().0.clone());
    }
    let path: PathBuf = obj
        .extract()
        .map_err(|_| value_error("mesh: expected a Mesh or a file path"))?;
    crate::errors::read_mesh(obj.py(), &path)
}

/// `roi=` or `roi_polygon=` (with `roi_name=`, `roi_heights=`), as
/// `--roi`/`--roi-box` or `--roi-polygon` (one library call for the file).
fn roi_of(obj: Option<&Bound<'_, PyAny>>, area: &AreaArgs) -> PyResult<RoiSpec> {
    let obj = obj.filter(|o| !o.is_none());
    if let Some(path) = &area.file {
        if obj.is_some() {
            return Err(value_error("give roi or roi_polygon, not both"));
        }
        return RoiSpec::from_area_file(path, area.name.as_deref(), area.heights).py();
    }
    if area.name.is_some() || area.heights.is_some() {
        return Err(value_error("roi_name and roi_heights need roi_polygon"));
    }
    let Some(obj) = obj else {
        return Ok(RoiSpec::All);
    };
    if let Ok(b) = obj.extract::<[f64; 6]>() {
        return Ok(RoiSpec::Region(Roi::from_box(b).py()?));
    }
    let roi: Roi = convert::from_py_required(obj, "roi")?;
    Ok(RoiSpec::Region(roi))
}

/// The `roi_polygon=` keywords.
struct AreaArgs {
    file: Option<PathBuf>,
    name: Option<String>,
    heights: Option<(f64, f64)>,
}

fn origin_of(obj: Option<(f64, f64, f64)>) -> PyResult<Option<GeodeticOrigin>> {
    obj.map(|(lat, lon, alt)| GeodeticOrigin::new(lat, lon, alt).py())
        .transpose()
}

/// The acquired views from a ColmapModel / model folder (with an optional
/// confidence folder) or a list of Cameras (with an optional list of
/// ConfidenceImages, None entries meaning no prediction).
fn acquired_of(
    cameras: &Bound<'_, PyAny>,
    confidence: Option<&Bound<'_, PyAny>>,
) -> PyResult<(Vec<AcquiredView>, Vec<Observation>)> {
    let confidence = confidence.filter(|c| !c.is_none());
    if let Ok(list) = cameras.extract::<Vec<PyCamera>>() {
        let conf: Vec<Option<PyConfidence>> = match confidence {
            None => vec![None; list.len()],
            Some(c) => c.extract().map_err(|_| {
                value_error(
                    "confidence: with a list of cameras, give a list of ConfidenceImage or None",
                )
            })?,
        };
        if conf.len() != list.len() {
            return Err(value_error(format!(
                "{} cameras but {} confidence images",
                list.len(),
                conf.len()
            )));
        }
        let views = list
            .into_iter()
            .zip(conf)
            .map(|(c, k)| AcquiredView {
                camera: c.0,
                confidence: k.map(|k| k.0),
            })
            .collect();
        return Ok((views, Vec::new()));
    }
    let rec = if let Ok(m) = cameras.cast::<PyColmap>() {
        m.get().0.clone()
    } else {
        let path: PathBuf = cameras.extract().map_err(|_| {
            value_error("cameras: expected a ColmapModel, a model folder or a list of Camera")
        })?;
        ModelSource::detect(&path).read().py()?
    };
    let dir: Option<PathBuf> = confidence
        .map(|c| {
            c.extract().map_err(|_| {
                value_error("confidence: with a COLMAP model, give a folder of .vpconf files")
            })
        })
        .transpose()?;
    let views = vp_planner::acquired_from_model(&rec, dir.as_deref()).py()?;
    let observations = observations_from_model(&rec).py()?;
    Ok((views, observations))
}

/// `home=(lat, lon, alt)` or `(lat, lon, alt, datum)`, or "first_image".
fn home_spec(home: Option<&Bound<'_, PyAny>>) -> PyResult<HomeSpec> {
    let Some(home) = home.filter(|h| !h.is_none()) else {
        return Ok(HomeSpec::Unset);
    };
    if let Ok(s) = home.extract::<String>() {
        return if s == "first_image" {
            Ok(HomeSpec::FirstImage)
        } else {
            Err(value_error(format!(
                "home {s:?}: expected (lat, lon, alt[, datum]) or \"first_image\""
            )))
        };
    }
    let expected = "(lat, lon, alt), (lat, lon, alt, datum) or \"first_image\"";
    Ok(match crate::convert::home_of(Some(home), expected)? {
        Some((position, datum)) => HomeSpec::At { position, datum },
        None => HomeSpec::Unset,
    })
}

fn datum_of(datum: Option<&str>) -> PyResult<Option<VerticalDatum>> {
    datum.map(|d| d.parse::<VerticalDatum>().py()).transpose()
}

/// Plans the next camera triplets (M1-M4) as `vpctl plan` does: `mesh` a
/// Mesh or file, `cameras` the acquired views, `confidence` their
/// confidence images (folder, list, or None for no prediction), `config` a
/// dict, TOML path or None, `roi` a box (xmin, ymin, zmin, xmax, ymax,
/// zmax) or a dict as `--roi` JSON, or `roi_polygon` a .kml/.kmz/.geojson
/// area in lon/lat (`roi_name` picks one of several, `roi_heights` (min,
/// max) limits it) as `--roi-polygon`, `origin` (lat, lon, alt) with its
/// `datum` ("egm96", "ellipsoid", "takeoff"), `home` (lat, lon, alt[,
/// datum]) or "first_image" (as `--home-from-first-image`).
///
/// With a model folder as `cameras` this is the very call `vpctl plan`
/// makes (vp-planner's `plan_from_model`), with a COLMAP model (`--colmap`)
/// or an OpenSfM reconstruction (`--opensfm`: an OpenDroneMap project, its
/// `opensfm` folder or `reconstruction.json`, told apart by their files):
/// the frame check (unless
/// `frame_unchecked`), the free space from the model's tracks, the home.
/// A ColmapModel object or a list of Cameras has no frame.json to check:
/// they plan as `frame_unchecked` (a ColmapModel's tracks still carve the
/// free space). The GIL is released while planning.
#[pyfunction]
#[pyo3(signature = (mesh, cameras, confidence = None, config = None, roi = None, origin = None, datum = None, home = None, frame_unchecked = false, roi_polygon = None, roi_name = None, roi_heights = None))]
#[allow(clippy::too_many_arguments)] // Python keywords, one per `vpctl plan` flag
fn plan(
    py: Python<'_>,
    mesh: &Bound<'_, PyAny>,
    cameras: &Bound<'_, PyAny>,
    confidence: Option<&Bound<'_, PyAny>>,
    config: Option<&Bound<'_, PyAny>>,
    roi: Option<&Bound<'_, PyAny>>,
    origin: Option<(f64, f64, f64)>,
    datum: Option<&str>,
    home: Option<&Bound<'_, PyAny>>,
    frame_unchecked: bool,
    roi_polygon: Option<PathBuf>,
    roi_name: Option<String>,
    roi_heights: Option<(f64, f64)>,
) -> PyResult<PyPlanResult> {
    let cfg = self::config(config)?;
    let mesh = mesh_of(mesh)?;
    let area = AreaArgs {
        file: roi_polygon,
        name: roi_name,
        heights: roi_heights,
    };
    let roi = roi_of(roi, &area)?;
    let origin = origin_of(origin)?;
    let datum = datum_of(datum)?;
    let home = home_spec(home)?;
    let is_object =
        cameras.cast::<PyColmap>().is_ok() || cameras.extract::<Vec<PyCamera>>().is_ok();
    if !is_object {
        let model: PathBuf = cameras.extract().map_err(|_| {
            value_error("cameras: expected a ColmapModel, a model folder or a list of Camera")
        })?;
        let conf_dir: Option<PathBuf> = confidence
            .filter(|c| !c.is_none())
            .map(|c| {
                c.extract().map_err(|_| {
                    value_error("confidence: with a model folder, give a folder of .vpconf files")
                })
            })
            .transpose()?;
        let job = py
            .detach(|| {
                vp_planner::plan_from_model(&ModelPlanRequest {
                    mesh: &mesh,
                    model: &ModelSource::detect(&model),
                    confidence_dir: conf_dir.as_deref(),
                    config: &cfg,
                    roi,
                    origin: origin.map(|o| (o, datum)),
                    home,
                    frame_unchecked,
                })
            })
            .py()?;
        return Ok(PyPlanResult(job.result));
    }
    let (acquired, observations) = acquired_of(cameras, confidence)?;
    let r = py
        .detach(|| -> vp_planner::Result<PlanResult> {
            let first = acquired
                .first()
                .map(|v| ("the first camera", v.camera.center()));
            let home_at = vp_planner::resolve_home(&mesh, origin, datum, &home, first)?;
            let mut r = vp_planner::plan(&PlanInputs {
                mesh: &mesh,
                acquired: &acquired,
                roi,
                config: &cfg,
                origin,
                // A model's tracks carve the free space, as `vpctl plan`'s;
                // without tracks, rays of the cameras to the mesh.
                observations: (!observations.is_empty()).then_some(&observations[..]),
                home: vp_planner::request::home_enu(origin, home_at.as_ref())?,
            })?;
            r.plan.vertical_datum = datum;
            r.plan.home = home_at;
            Ok(r)
        })
        .py()?;
    Ok(PyPlanResult(r))
}

/// A lawnmower grid flight over the region of interest, as `vpctl plan grid`.
#[pyfunction]
#[pyo3(signature = (mesh, roi = None, height = 50.0, gsd = None, overlap = 0.8, side_overlap = None, pitch = -90.0, yaw = 0.0, initial = false, config = None, origin = None, datum = None, home = None, roi_polygon = None, roi_name = None, roi_heights = None),
    // pyo3 writes a negative default as `...`: help() would show Ellipsis.
    text_signature = "(mesh, roi=None, height=50.0, gsd=None, overlap=0.8, side_overlap=None, pitch=-90.0, yaw=0.0, initial=False, config=None, origin=None, datum=None, home=None, roi_polygon=None, roi_name=None, roi_heights=None)")]
fn plan_grid(
    py: Python<'_>,
    mesh: &Bound<'_, PyAny>,
    roi: Option<&Bound<'_, PyAny>>,
    height: f64,
    gsd: Option<f64>,
    overlap: f64,
    side_overlap: Option<f64>,
    pitch: f64,
    yaw: f64,
    initial: bool,
    config: Option<&Bound<'_, PyAny>>,
    origin: Option<(f64, f64, f64)>,
    datum: Option<&str>,
    home: Option<&Bound<'_, PyAny>>,
    roi_polygon: Option<PathBuf>,
    roi_name: Option<String>,
    roi_heights: Option<(f64, f64)>,
) -> PyResult<PyPlan> {
    let cfg = self::config(config)?;
    let mesh = mesh_of(mesh)?;
    let area = AreaArgs {
        file: roi_polygon,
        name: roi_name,
        heights: roi_heights,
    };
    let roi = roi_of(roi, &area)?;
    let origin = origin_of(origin)?;
    let datum = datum_of(datum)?;
    let home = home_spec(home)?;
    let params = GridParams {
        height_m: height,
        gsd_m: gsd,
        front_overlap: overlap,
        side_overlap: side_overlap.unwrap_or(overlap),
        pitch_deg: pitch,
        yaw_deg: yaw,
        role: if initial { Role::Initial } else { Role::Grid },
    };
    py.detach(|| {
        vp_planner::plan_grid_job(&GridRequest {
            mesh: &mesh,
            roi: &roi,
            params: &params,
            config: &cfg,
            origin: origin.map(|o| (o, datum)),
            home,
        })
    })
    .py()
    .map(PyPlan)
}

/// The planner configuration with every default, as a dict.
#[pyfunction]
fn default_config(py: Python<'_>) -> PyResult<Bound<'_, PyAny>> {
    convert::to_py(py, &PlannerConfig::default())
}

/// The defaults as commented TOML (`vpctl config --defaults`).
#[pyfunction]
fn default_config_toml() -> &'static str {
    PlannerConfig::default_toml()
}

/// The cameras of a plan's views, with the configured camera's intrinsics.
#[pyfunction]
#[pyo3(signature = (plan, config = None))]
fn plan_cameras(
    plan: PyRef<'_, PyPlan>,
    config: Option<&Bound<'_, PyAny>>,
) -> PyResult<Vec<PyCamera>> {
    let k = self::config(config)?.camera.intrinsics();
    Ok(plan
        .0
        .waypoints
        .iter()
        .map(|w| PyCamera(w.to_camera(k)))
        .collect())
}

/// Registers the submodule.
pub fn register(m: &Bound<'_, PyModule>) -> PyResult<()> {
    m.add_class::<PyPlan>()?;
    m.add_class::<PyPlanResult>()?;
    m.add_function(wrap_pyfunction!(plan, m)?)?;
    m.add_function(wrap_pyfunction!(plan_grid, m)?)?;
    m.add_function(wrap_pyfunction!(default_config, m)?)?;
    m.add_function(wrap_pyfunction!(default_config_toml, m)?)?;
    m.add_function(wrap_pyfunction!(plan_cameras, m)?)?;
    Ok(())
}
