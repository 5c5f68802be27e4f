//! The `progress` argument of every long call (a campaign, dense stereo, a
//! simulated flight, a mission upload): what the CLI shows as a bar and
//! timestamped lines, Python hears as lines. `None` (the default) prints
//! each line on `sys.stderr` as `[vpctl] <line>`, flushed, as a notebook
//! user sees a long cell work; `False` is silent; a callable receives each
//! line as one str.
//!
//! The GIL is released while the library works; only the callback runs
//! with it. An exception raised by the callback stops further calls and is
//! raised when the call returns.

use pyo3::prelude::*;
use pyo3::types::PyBool;

/// A resolved `progress` argument and the first error its callback raised.
pub struct Progress {
    callback: Option<Py<PyAny>>,
    error: Option<PyErr>,
}

impl Progress {
    /// Resolves the argument; a non-callable that is not a bool is a
    /// TypeError naming what is accepted.
    pub fn from_arg(py: Python<'_>, arg: Option<Py<PyAny>>) -> PyResult<Self> {
        let callback = match arg {
            None => Some(stderr_lines(py)?),
            Some(p) if p.bind(py).is_instance_of::<PyBool>() => {
                if p.bind(py).is_truthy()? {
                    Some(stderr_lines(py)?)
                } else {
                    None
                }
            }
            Some(p) if p.bind(py).is_callable() => Some(p),
            Some(_) => {
                return Err(crate::errors::type_error(
                    "progress: expected a callable taking one str, None (log lines on stderr) \
                     or False (silent)",
                ))
            }
        };
        Ok(Progress {
            callback,
            error: None,
        })
    }

    /// Hands one line to the callback (taking the GIL for it).
    pub fn line(&mut self, line: &str) {
        if let (Some(cb), None) = (&self.callback, &self.error) {
            if let Err(e) = Python::attach(|py| cb.call1(py, (line,)).map(drop)) {
                self.error = Some(e);
            }
        }
    }

    /// The callback's error, if it raised one: call after the work returns.
    pub fn finish(self) -> PyResult<()> {
        self.error.map_or(Ok(()), Err)
    }
}

/// Progress as log lines on `sys.stderr` (`[vpctl] <line>`), flushed.
fn stderr_lines(py: Python<'_>) -> PyResult<Py<PyAny>> {
    let code = c"import sys\ndef progress(line):\n    print('[vpctl]', line, file=sys.stderr, flush=True)\n";
    let m = PyModule::from_code(py, code, c"vpctl_progress.py", c"vpctl_progress")?;
    Ok(m.getattr("progress")?.unbind())
}
