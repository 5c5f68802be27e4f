//! Rust errors to Python exceptions, with the Rust message.
//!
//! The mapping follows what a Python user expects: a file that cannot be
//! opened, read or written is an `OSError` (its `FileNotFoundError` and
//! `FileExistsError` subclasses where they apply), a bad value or malformed
//! content is a `ValueError`, a vehicle that does not answer in time a
//! `TimeoutError`, and a refusal of the algorithm itself a `RuntimeError`.

use pyo3::exceptions::{
    PyConnectionError, PyFileExistsError, PyFileNotFoundError, PyOSError, PyRuntimeError,
    PyTimeoutError, PyValueError,
};
use pyo3::PyErr;
use vp_forest::ForestError;
use vp_labelgen::LabelgenError;
use vp_mission::MissionError;
use vp_mvs::MvsError;
use vp_planner::PlannerError;
use vp_scene::SceneError;
use vp_sim::SimError;

/// The message of an error with its chain of causes, as the CLI prints it.
fn message(e: &dyn std::error::Error) -> String {
    let mut m = e.to_string();
    let mut src = e.source();
    while let Some(s) = src {
        let s_text = s.to_string();
        // thiserror's Io variants already embed the source's text.
        if !m.contains(&s_text) {
            m.push_str(": ");
            m.push_str(&s_text);
        }
        src = s.source();
    }
    m
}

fn io_error(e: &SceneError, kind: std::io::ErrorKind) -> PyErr {
    let m = message(e);
    match kind {
        std::io::ErrorKind::NotFound => PyFileNotFoundError::new_err(m),
        std::io::ErrorKind::AlreadyExists => PyFileExistsError::new_err(m),
        _ => PyOSError::new_err(m),
    }
}

/// Converts a vp-scene error.
pub fn scene(e: &SceneError) -> PyErr {
    match e {
        SceneError::Io { source, .. } => io_error(e, source.kind()),
        SceneError::Image { source, .. } => match source {
            image::ImageError::IoError(io) => io_error(e, io.kind()),
            _ => PyValueError::new_err(message(e)),
        },
        SceneError::AlreadyExists { .. } => PyFileExistsError::new_err(message(e)),
        SceneError::Parse { .. }
        | SceneError::InvalidMesh(_)
        | SceneError::InvalidArgument(_)
        | SceneError::Surface(_)
        // An output folder that is an input, its parent or someone else's:
        // a bad argument, whatever is on the disk.
        | SceneError::OutputRefused { .. } => PyValueError::new_err(message(e)),
    }
}

/// Converts a vp-forest error.
pub fn forest(e: &ForestError) -> PyErr {
    match e {
        ForestError::Scene(s) => scene(s),
        ForestError::InvalidParams(_) | ForestError::InvalidInput(_) => {
            PyValueError::new_err(message(e))
        }
    }
}

/// Converts a vp-labelgen error.
pub fn labelgen(e: &LabelgenError) -> PyErr {
    match e {
        LabelgenError::Scene(s) => scene(s),
        _ => PyValueError::new_err(message(e)),
    }
}

/// Converts a vp-planner error.
pub fn planner(e: &PlannerError) -> PyErr {
    match e {
        PlannerError::Scene(s) => scene(s),
        PlannerError::Config(_) | PlannerError::Input(_) => PyValueError::new_err(message(e)),
        PlannerError::Refused(_) => PyRuntimeError::new_err(message(e)),
        PlannerError::Output { .. } => PyOSError::new_err(message(e)),
    }
}

/// Converts a vp-mission error.
pub fn mission(e: &MissionError) -> PyErr {
    // The class follows the failure itself (a timeout stays TimeoutError);
    // the message keeps what was added around it, e.g. what the vehicle
    // holds after a failed upload.
    if let MissionError::HomeOffset(h) = e {
        // The next steps as a Python caller takes them.
        return PyValueError::new_err(h.message(
            "home=(lat, lon, alt), the CLI's --home",
            "accept_home_offset=True (the CLI's --accept-home-offset)",
        ));
    }
    match e.root() {
        MissionError::Scene(s) => scene(s),
        MissionError::InvalidInput(_)
        | MissionError::HomeOffset(_)
        | MissionError::BadUrl { .. } => PyValueError::new_err(message(e)),
        MissionError::Connect { .. } | MissionError::Link(_) => {
            PyConnectionError::new_err(message(e))
        }
        MissionError::NoVehicle { .. } | MissionError::Timeout { .. } => {
            PyTimeoutError::new_err(message(e))
        }
        _ => PyRuntimeError::new_err(message(e)),
    }
}

/// Converts a vp-sim error.
pub fn sim(e: &SimError) -> PyErr {
    match e {
        SimError::Scene(s) => scene(s),
        SimError::Forest(f) => forest(f),
        SimError::Planner(p) => planner(p),
        SimError::Labelgen(l) => labelgen(l),
        SimError::Mission(m) => mission(m),
        SimError::InvalidArgument(_) => PyValueError::new_err(message(e)),
        SimError::Mvs(m) if m.is_input_error() => PyValueError::new_err(message(e)),
        SimError::Mvs(_) | SimError::Campaign(_) => PyRuntimeError::new_err(message(e)),
    }
}

/// Extension trait: `.py()?` on a crate result.
pub trait IntoPy<T> {
    /// The value, or the error as a Python exception.
    fn py(self) -> pyo3::PyResult<T>;
}

macro_rules! into_py {
    ($err:ty, $f:ident) => {
        impl<T> IntoPy<T> for Result<T, $err> {
            fn py(self) -> pyo3::PyResult<T> {
                self.map_err(|e| $f(&e))
            }
        }
    };
}
into_py!(SceneError, scene);
into_py!(ForestError, forest);
into_py!(LabelgenError, labelgen);
into_py!(PlannerError, planner);
into_py!(MissionError, mission);
into_py!(SimError, sim);

/// A `TypeError` with `msg`.
pub fn type_error(msg: impl Into<String>) -> PyErr {
    pyo3::exceptions::PyTypeError::new_err(msg.into())
}

/// Converts a vp-mvs error: file errors as vp-scene's, a missing file as
/// `FileNotFoundError`, the user's other mistakes as `ValueError`.
pub fn mvs(e: &MvsError) -> PyErr {
    match e {
        MvsError::Scene(s) => scene(s),
        MvsError::Io { source, .. } => match source.kind() {
            std::io::ErrorKind::NotFound => PyFileNotFoundError::new_err(message(e)),
            _ => PyOSError::new_err(message(e)),
        },
        _ if e.is_input_error() => PyValueError::new_err(message(e)),
        _ => PyRuntimeError::new_err(message(e)),
    }
}

/// A `ValueError` with `msg`.
pub fn value_error(msg: impl Into<String>) -> PyErr {
    PyValueError::new_err(msg.into())
}

/// Issues each reader warning as a Python `UserWarning` (the library
/// returns them; Python's `warnings` module decides whether to show them).
pub fn warn_all(
    py: pyo3::Python<'_>,
    warnings: &[vp_scene::io::ReadWarning],
) -> pyo3::PyResult<()> {
    let category = py.get_type::<pyo3::exceptions::PyUserWarning>();
    for w in warnings {
        let text = std::ffi::CString::new(w.to_string().replace('\0', " ")).unwrap_or_default();
        PyErr::warn(py, category.as_any(), &text, 1)?;
    }
    Ok(())
}

/// [`vp_scene::io::read_mesh`] with its warnings issued as Python warnings.
pub fn read_mesh(py: pyo3::Python<'_>, path: &std::path::Path) -> pyo3::PyResult<vp_scene::Mesh> {
    use self::IntoPy as _;
    let (mesh, warnings) = py
        .detach(|| vp_scene::io::read_mesh_with_warnings(path))
        .py()?;
    warn_all(py, &warnings)?;
    Ok(mesh)
}
