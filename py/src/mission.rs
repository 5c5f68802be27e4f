//! `vpctl.mission`: plans to MAVLink missions, QGC `.plan` / WPL export,
//! upload and download with timeouts (the GIL released while waiting), and
//! a simulated vehicle for notebooks and tests (vp-mission).

use std::path::PathBuf;

use num_traits::ToPrimitive;
use pyo3::prelude::*;
use pyo3::types::{PyDict, PyList};
// The keyword defaults are written as literals (pyo3 shows a constant as
// `...` in help()); keep them equal to vp_mission::heights::DEFAULT_CEILING_M
// and DEFAULT_MIN_HEIGHT_M.
use vp_mission::heights::{HeightLimits, UserMissionOptions};
use vp_mission::sim_vehicle::{spawn_udp_vehicle, UdpVehicle, VehicleConfig};
use vp_mission::{
    build_mission, export_flights, export_wpl, one_flight, write_flights, Autopilot,
    ConnectOptions, ExportFormat, Mission, MissionItem, MissionOptions,
};
use vp_scene::fsio;
use vp_scene::plan::{GeodeticOrigin, Plan};

use crate::convert::home_of;
use crate::errors::{value_error, IntoPy};
use crate::planner::PyPlan;

fn autopilot(name: &str) -> PyResult<Autopilot> {
    match name.to_ascii_lowercase().as_str() {
        "px4" => Ok(Autopilot::Px4),
        "ardupilot" => Ok(Autopilot::ArduPilot),
        other => Err(value_error(format!(
            "autopilot {other:?}: expected \"px4\" or \"ardupilot\""
        ))),
    }
}

/// The keywords every mission call shares, as `vpctl mission` flags.
struct Keywords {
    hold: f32,
    speed: Option<f32>,
    takeoff: f32,
    rtl: bool,
}

/// Mission options for `plan` as `vpctl mission` builds them from its flags
/// (vp-mission's `UserMissionOptions`).
fn options(
    plan: &Plan,
    autopilot_name: &str,
    k: Keywords,
    home: Option<&Bound<'_, PyAny>>,
    ceiling: f64,
    min_height: f64,
) -> PyResult<MissionOptions> {
    UserMissionOptions {
        autopilot: autopilot(autopilot_name)?,
        hold_s: k.hold,
        speed_m_s: k.speed,
        takeoff_m: k.takeoff,
        return_to_launch: k.rtl,
        home: home_of(home, "(lat, lon, alt) or (lat, lon, alt, datum)")?,
        limits: HeightLimits {
            min_height_m: min_height,
            ceiling_m: ceiling,
        },
    }
    .resolve(plan)
    .py()
}

fn item_dict<'py>(py: Python<'py>, item: &MissionItem) -> PyResult<Bound<'py, PyDict>> {
    let d = PyDict::new(py);
    d.set_item("command", format!("{:?}", item.command))?;
    d.set_item("command_id", item.command.to_u32())?;
    d.set_item("frame", format!("{:?}", item.frame))?;
    d.set_item("params", item.params.to_vec())?;
    d.set_item("x", item.x)?;
    d.set_item("y", item.y)?;
    d.set_item("z", item.z)?;
    d.set_item("autocontinue", item.autocontinue)?;
    Ok(d)
}

fn items_list<'py>(py: Python<'py>, items: &[MissionItem]) -> PyResult<Bound<'py, PyList>> {
    let l = PyList::empty(py);
    for it in items {
        l.append(item_dict(py, it)?)?;
    }
    Ok(l)
}

/// A mission ready to upload or export.
#[pyclass(name = "Mission", module = "vpctl.mission", frozen)]
pub struct PyMission(Mission);

#[pymethods]
impl PyMission {
    /// Items in sequence order: dicts of command, command_id, frame,
    /// params, x, y, z, autocontinue.
    #[getter]
    fn items<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyList>> {
        items_list(py, &self.0.items)
    }

    /// Number of photo items.
    #[getter]
    fn photos(&self) -> usize {
        self.0.photos
    }

    /// "Px4" or "ArduPilot".
    #[getter]
    fn autopilot(&self) -> String {
        format!("{:?}", self.0.autopilot)
    }

    /// The mission as `QGC WPL 110` text.
    fn to_wpl(&self) -> PyResult<String> {
        export_wpl(&self.0).py()
    }

    fn __len__(&self) -> usize {
        self.0.items.len()
    }
}

/// Builds the MAVLink mission of a plan (options as `vpctl mission` flags).
#[pyfunction]
#[pyo3(name = "build_mission", signature = (plan, autopilot = "px4", hold = 2.0, speed = None, takeoff = 20.0, rtl = true, home = None, ceiling = 120.0, min_height = 2.0))]
#[allow(clippy::too_many_arguments)] // Python keywords, one per `vpctl mission` flag
fn py_build_mission(
    plan: PyRef<'_, PyPlan>,
    autopilot: &str,
    hold: f32,
    speed: Option<f32>,
    takeoff: f32,
    rtl: bool,
    home: Option<&Bound<'_, PyAny>>,
    ceiling: f64,
    min_height: f64,
) -> PyResult<PyMission> {
    let k = Keywords {
        hold,
        speed,
        takeoff,
        rtl,
    };
    let o = options(&plan.0, autopilot, k, home, ceiling, min_height)?;
    build_mission(&plan.0, &o).py().map(PyMission)
}

/// The plan as an export: QGroundControl `.plan` JSON (`format="qgc"`),
/// `QGC WPL 110` (`"wpl"`), a DJI WPML `.kmz` (`"wpml"`, needs `drone`:
/// "m3e", "m30t", ...; `dji_heights` "relative" or "wgs84"), a Litchi CSV
/// (`"litchi"`, `split` over 99 waypoints) or a KML preview (`"kml"`);
/// without `format`, from the extension of `out` as `vpctl mission export`,
/// which refuses the same files; QGC when there is no `out`. Written to `out`
/// when given, atomically, refusing to overwrite unless `force` (same
/// bytes as `vpctl mission export`). A plan split into flights gives a
/// list, one text per flight, written to `out`'s numbered files
/// (`m-1.plan`, `m-2.plan`, ...).
#[pyfunction]
#[pyo3(signature = (plan, format = None, out = None, force = false, autopilot = "px4", hold = 2.0, speed = None, takeoff = 20.0, rtl = true, home = None, ceiling = 120.0, min_height = 2.0, drone = None, dji_heights = "relative", split = false))]
#[allow(clippy::too_many_arguments)] // Python keywords, one per `vpctl mission` flag
fn export(
    py: Python<'_>,
    plan: PyRef<'_, PyPlan>,
    format: Option<&str>,
    out: Option<PathBuf>,
    force: bool,
    autopilot: &str,
    hold: f32,
    speed: Option<f32>,
    takeoff: f32,
    rtl: bool,
    home: Option<&Bound<'_, PyAny>>,
    ceiling: f64,
    min_height: f64,
    drone: Option<&str>,
    dji_heights: &str,
    split: bool,
) -> PyResult<Py<PyAny>> {
    let format = format.map(ExportFormat::from_name).transpose().py()?;
    let format = ExportFormat::for_output(out.as_deref(), format).py()?;
    if let Some(p) = &out {
        fsio::check_overwrite(p, force).py()?;
    }
    let k = Keywords {
        hold,
        speed,
        takeoff,
        rtl,
    };
    let o = options(&plan.0, autopilot, k, home, ceiling, min_height)?;
    let dji = vp_mission::DjiOptions {
        drone: drone
            .map(str::parse::<vp_mission::wpml::Drone>)
            .transpose()
            .py()?,
        heights: dji_heights.parse::<vp_mission::wpml::WpmlHeights>().py()?,
        split,
        // WPML's createTime/updateTime: the wall clock, as the CLI writes.
        time_ms: std::time::SystemTime::now()
            .duration_since(std::time::UNIX_EPOCH)
            .map_or(0, |d| u64::try_from(d.as_millis()).unwrap_or(0)),
    };
    let files = export_flights(&plan.0, format, &o, &dji, out.as_deref()).py()?;
    write_flights(&files, force).py()?;
    // Text formats as str, the others (a .kmz) as bytes.
    let mut objs = Vec::with_capacity(files.len());
    for f in files {
        objs.push(if format.is_text() {
            String::from_utf8_lossy(&f.bytes)
                .into_owned()
                .into_pyobject(py)?
                .into_any()
                .unbind()
        } else {
            pyo3::types::PyBytes::new(py, &f.bytes).into_any().unbind()
        });
    }
    if objs.len() == 1 {
        return Ok(objs.remove(0));
    }
    Ok(objs.into_pyobject(py)?.into_any().unbind())
}

fn connect_options(heartbeat_timeout: f64, timeout_scale: f64) -> PyResult<ConnectOptions> {
    ConnectOptions::from_user(heartbeat_timeout, timeout_scale).py()
}

/// Connects to `url` (udpout:HOST:PORT, udpin:..., tcpout:..., serial:DEV:BAUD),
/// uploads the plan's mission and verifies it by reading it back. The GIL
/// is released while waiting on the vehicle. Returns a report dict.
#[pyfunction]
#[pyo3(signature = (plan, url, heartbeat_timeout = 5.0, timeout_scale = 1.0, autopilot = "px4", hold = 2.0, speed = None, takeoff = 20.0, rtl = true, home = None, ceiling = 120.0, min_height = 2.0, flight = None, accept_home_offset = false))]
#[allow(clippy::too_many_arguments)] // Python keywords, one per `vpctl mission` flag
fn upload<'py>(
    py: Python<'py>,
    plan: PyRef<'_, PyPlan>,
    url: &str,
    heartbeat_timeout: f64,
    timeout_scale: f64,
    autopilot: &str,
    hold: f32,
    speed: Option<f32>,
    takeoff: f32,
    rtl: bool,
    home: Option<&Bound<'_, PyAny>>,
    ceiling: f64,
    min_height: f64,
    flight: Option<usize>,
    accept_home_offset: bool,
) -> PyResult<Bound<'py, PyDict>> {
    let k = Keywords {
        hold,
        speed,
        takeoff,
        rtl,
    };
    let plan = one_flight(&plan.0, flight).py()?;
    let o = options(&plan, autopilot, k, home, ceiling, min_height)?;
    let m = build_mission(&plan, &o).py()?;
    // The vehicle's home against the plan's, as `vpctl mission upload`.
    let opts = ConnectOptions {
        home_check: Some(vp_mission::HomePolicy {
            datum: plan.vertical_datum,
            accept_offset: accept_home_offset,
        }),
        ..connect_options(heartbeat_timeout, timeout_scale)?
    };
    let (report, info) = py
        .detach(|| vp_mission::upload(url, &m, &opts, &mut |_| {}))
        .py()?;
    let d = PyDict::new(py);
    d.set_item("items", m.items.len())?;
    d.set_item("photos", m.photos)?;
    d.set_item("elapsed_s", report.upload.elapsed.as_secs_f64())?;
    d.set_item("attempts", report.upload.attempts)?;
    d.set_item("resends", report.upload.resends)?;
    d.set_item("verified", report.verified)?;
    d.set_item("home", report.home.map(|h| h.to_string()))?;
    d.set_item("system", info.target.system)?;
    d.set_item("component", info.target.component)?;
    Ok(d)
}

/// Connects to `url` and reads the vehicle's mission (item dicts); the GIL
/// is released while waiting.
#[pyfunction]
#[pyo3(signature = (url, heartbeat_timeout = 5.0, timeout_scale = 1.0))]
fn download<'py>(
    py: Python<'py>,
    url: &str,
    heartbeat_timeout: f64,
    timeout_scale: f64,
) -> PyResult<Bound<'py, PyList>> {
    let opts = connect_options(heartbeat_timeout, timeout_scale)?;
    let (items, _, _) = py
        .detach(|| vp_mission::download(url, &opts, &mut |_| {}))
        .py()?;
    items_list(py, &items)
}

/// Connects to `url` and deletes the vehicle's mission.
#[pyfunction]
#[pyo3(signature = (url, heartbeat_timeout = 5.0, timeout_scale = 1.0))]
fn clear(py: Python<'_>, url: &str, heartbeat_timeout: f64, timeout_scale: f64) -> PyResult<()> {
    let opts = connect_options(heartbeat_timeout, timeout_scale)?;
    py.detach(|| vp_mission::clear(url, &opts)).py()?;
    Ok(())
}

/// A simulated vehicle (the MAVLink mission protocol, vehicle side) on a
/// loopback UDP port, for notebooks and tests without a drone. Stops when
/// closed or garbage-collected.
#[pyclass(name = "SimulatedVehicle", module = "vpctl.mission", frozen)]
pub struct PyVehicle(std::sync::Mutex<Option<UdpVehicle>>);

impl PyVehicle {
    fn with<T>(&self, f: impl FnOnce(&UdpVehicle) -> T) -> PyResult<T> {
        let g = self
            .0
            .lock()
            .map_err(|_| pyo3::exceptions::PyRuntimeError::new_err("vehicle lock poisoned"))?;
        g.as_ref()
            .map(f)
            .ok_or_else(|| value_error("the simulated vehicle is closed"))
    }
}

#[pymethods]
impl PyVehicle {
    /// Listens on `bind` (port 0: any free port) as a PX4 or ArduPilot
    /// vehicle. `home=(lat, lon, alt)` (altitude above mean sea level) makes
    /// it report that HOME_POSITION, as a vehicle with a GNSS fix does, so
    /// `upload` compares it with the plan's home; without it the vehicle
    /// has no fix and reports none.
    #[new]
    #[pyo3(signature = (bind = "127.0.0.1:0", autopilot = "px4", home = None))]
    fn new(bind: &str, autopilot: &str, home: Option<(f64, f64, f64)>) -> PyResult<Self> {
        let default = VehicleConfig::default();
        let cfg = VehicleConfig {
            autopilot: self::autopilot(autopilot)?,
            home: home.map_or(default.home, |(lat_deg, lon_deg, alt_m)| GeodeticOrigin {
                lat_deg,
                lon_deg,
                alt_m,
            }),
            reports_home: home.is_some(),
            ..default
        };
        let v = spawn_udp_vehicle(bind, cfg).py()?;
        Ok(PyVehicle(std::sync::Mutex::new(Some(v))))
    }

    /// The URL a ground station connects with (`udpout:HOST:PORT`).
    #[getter]
    fn url(&self) -> PyResult<String> {
        self.with(|v| format!("udpout:{}", v.addr()))
    }

    /// The stored mission (item dicts).
    fn mission<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyList>> {
        let items = self.with(UdpVehicle::mission)?;
        items_list(py, &items)
    }

    /// (completed, abandoned) uploads so far.
    fn upload_counts(&self) -> PyResult<(u32, u32)> {
        self.with(UdpVehicle::upload_counts)
    }

    /// Stops the vehicle (idempotent).
    fn close(&self, py: Python<'_>) -> PyResult<()> {
        let v = self
            .0
            .lock()
            .map_err(|_| pyo3::exceptions::PyRuntimeError::new_err("vehicle lock poisoned"))?
            .take();
        // Joining the vehicle's thread can take a poll interval: without the GIL.
        py.detach(move || drop(v));
        Ok(())
    }

    fn __enter__(slf: Py<Self>) -> Py<Self> {
        slf
    }

    fn __exit__(
        &self,
        py: Python<'_>,
        t: &Bound<'_, PyAny>,
        v: &Bound<'_, PyAny>,
        tb: &Bound<'_, PyAny>,
    ) -> PyResult<bool> {
        // The exception, if any, propagates (return False).
        let _ = (t, v, tb);
        self.close(py)?;
        Ok(false)
    }
}

/// Registers the submodule.
pub fn register(m: &Bound<'_, PyModule>) -> PyResult<()> {
    m.add_class::<PyMission>()?;
    m.add_class::<PyVehicle>()?;
    m.add_function(wrap_pyfunction!(py_build_mission, m)?)?;
    m.add_function(wrap_pyfunction!(export, m)?)?;
    m.add_function(wrap_pyfunction!(upload, m)?)?;
    m.add_function(wrap_pyfunction!(download, m)?)?;
    m.add_function(wrap_pyfunction!(clear, m)?)?;
    Ok(())
}
