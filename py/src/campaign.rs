//! `vpctl.sim.run_campaign`: closed-loop campaigns (vp-sim `campaign`), the
//! table as a list of dicts (one per strategy, pandas-friendly).

use std::path::PathBuf;

use pyo3::prelude::*;
use pyo3::types::PyDict;
use vp_sim::campaign::{self, CampaignConfig};

use crate::convert;
use crate::errors::{value_error, IntoPy};

/// The configuration: a preset, changed by a dict, or a TOML file.
fn config(obj: Option<&Bound<'_, PyAny>>, preset_name: &str) -> PyResult<CampaignConfig> {
    let base = CampaignConfig::preset(preset_name).py()?;
    let Some(obj) = obj.filter(|o| !o.is_none()) else {
        return Ok(base);
    };
    if obj.is_instance_of::<PyDict>() {
        let over: serde_json::Value = convert::from_py_required(obj, "config")?;
        return base.with_overrides(over).py();
    }
    let path: PathBuf = obj
        .extract()
        .map_err(|_| value_error("config: expected a dict, a TOML file path or None"))?;
    CampaignConfig::load(&path).py()
}

/// A campaign configuration as a dict: `preset` ("demo", "quick" or
/// "paper") with `config` (a dict of changes, or a TOML path) applied.
#[pyfunction]
#[pyo3(signature = (config = None, preset = "demo"))]
fn campaign_config<'py>(
    py: Python<'py>,
    config: Option<&Bound<'_, PyAny>>,
    preset: &str,
) -> PyResult<Bound<'py, PyAny>> {
    convert::to_py(py, &self::config(config, preset)?)
}

/// Runs a closed-loop campaign (train the forest on training sites, fly and
/// evaluate every strategy on the held-out sites) and returns the table:
/// one dict per strategy (coverage, f_res, f_unc, f, triplet success, images,
/// rock coverage; mean and std over sites). `progress(line)` hears each
/// step; by default (`None`) each step is a line on `sys.stderr`, and
/// `progress=False` is silent. The GIL is released while the campaign runs
/// (minutes for "demo").
#[pyfunction]
#[pyo3(signature = (config = None, preset = "demo", progress = None))]
fn run_campaign<'py>(
    py: Python<'py>,
    config: Option<&Bound<'_, PyAny>>,
    preset: &str,
    progress: Option<Py<PyAny>>,
) -> PyResult<Bound<'py, PyAny>> {
    let cfg = self::config(config, preset)?;
    let progress: Option<Py<PyAny>> = match progress {
        None => Some(default_progress(py)?),
        Some(p) if p.bind(py).is_instance_of::<pyo3::types::PyBool>() => {
            if p.bind(py).is_truthy()? {
                Some(default_progress(py)?)
            } else {
                None
            }
        }
        Some(p) => {
            if !p.bind(py).is_callable() {
                return Err(crate::errors::type_error(
                    "progress: expected a callable taking one str, None (log lines on stderr) \
                     or False (silent)",
                ));
            }
            Some(p)
        }
    };
    let mut callback_error: Option<PyErr> = None;
    let report = py.detach(|| {
        campaign::run_campaign(&cfg, &mut |line: &str| {
            if let (Some(cb), None) = (&progress, &callback_error) {
                // Only the callback itself runs with the GIL.
                if let Err(e) = Python::attach(|py| cb.call1(py, (line,)).map(drop)) {
                    callback_error = Some(e);
                }
            }
        })
    });
    if let Some(e) = callback_error {
        return Err(e);
    }
    convert::to_py(py, &report.py()?.rows)
}

/// Progress as log lines on `sys.stderr` (`[vpctl] <step>`), flushed.
fn default_progress(py: Python<'_>) -> PyResult<Py<PyAny>> {
    let code = c"import sys\ndef progress(line):\n    print('[vpctl]', line, file=sys.stderr, flush=True)\n";
    let m = PyModule::from_code(py, code, c"vpctl_progress.py", c"vpctl_progress")?;
    Ok(m.getattr("progress")?.unbind())
}

/// Registers the campaign functions in `vpctl.sim`.
pub fn register(m: &Bound<'_, PyModule>) -> PyResult<()> {
    m.add_function(wrap_pyfunction!(run_campaign, m)?)?;
    m.add_function(wrap_pyfunction!(campaign_config, m)?)?;
    Ok(())
}
