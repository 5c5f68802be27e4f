//! `vpctl._native`: the Python extension module of vpctl (pyo3).
//!
//! One submodule per crate (`scene`, `forest`, `labelgen`, `planner`,
//! `mission`, `sim`, `mvs`), re-exported by the pure-Python package `vpctl`. The
//! bindings convert arguments and results (numpy arrays, dicts through
//! serde) and call the crates; they hold no algorithm of their own. Long
//! calls release the GIL; every Rust error becomes a Python exception
//! carrying the Rust message (see [`errors`]).
#![warn(missing_docs)]
// pyo3 extracts every argument by value (arrays, lists, PyRef), so the
// pedantic by-reference advice cannot apply to #[pyfunction]s; and the
// Python signatures mirror the CLI's flags, one keyword each.
#![allow(clippy::needless_pass_by_value, clippy::too_many_arguments)]

use pyo3::prelude::*;

mod campaign;
mod convert;
mod distributed;
mod errors;
mod forest;
mod labelgen;
mod mission;
mod mvs;
mod planner;
mod progress;
mod scene;
mod sim;

/// Adds `vpctl._native.<name>` and registers it in `sys.modules`, so that
/// `import vpctl._native.scene` works as well as attribute access.
fn submodule(
    parent: &Bound<'_, PyModule>,
    name: &str,
    register: fn(&Bound<'_, PyModule>) -> PyResult<()>,
) -> PyResult<()> {
    let py = parent.py();
    let m = PyModule::new(py, name)?;
    register(&m)?;
    parent.add_submodule(&m)?;
    py.import("sys")?
        .getattr("modules")?
        .set_item(format!("vpctl._native.{name}"), &m)?;
    Ok(())
}

#[pymodule]
fn _native(m: &Bound<'_, PyModule>) -> PyResult<()> {
    m.add("__version__", env!("CARGO_PKG_VERSION"))?;
    submodule(m, "scene", scene::register)?;
    submodule(m, "forest", forest::register)?;
    submodule(m, "labelgen", labelgen::register)?;
    submodule(m, "planner", planner::register)?;
    submodule(m, "mission", mission::register)?;
    submodule(m, "sim", sim::register)?;
    submodule(m, "mvs", mvs::register)?;
    submodule(m, "distributed", distributed::register)?;
    Ok(())
}
