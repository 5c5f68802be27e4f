//! `vpctl.sim.run_campaign`: closed-loop campaigns (vp-sim `campaign`), the
//! table as a list of dicts (one per strategy, pandas-friendly).

use std::path::PathBuf;

use pyo3::prelude::*;
use pyo3::types::PyDict;
use vp_sim::campaign::{self, CampaignConfig};

use crate::convert;
use crate::errors::{value_error, IntoPy};
use crate::progress::Progress;

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
/// rock coverage; mean and std over sites). `progress`: see
/// [`crate::progress`] (by default each step is a line on `sys.stderr`). The GIL is released while the campaign runs
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
    let mut progress = Progress::from_arg(py, progress)?;
    let report = py.detach(|| campaign::run_campaign(&cfg, &mut |line: &str| progress.line(line)));
    progress.finish()?;
    convert::to_py(py, &report.py()?.rows)
}

/// Registers the campaign functions in `vpctl.sim`.
pub fn register(m: &Bound<'_, PyModule>) -> PyResult<()> {
    m.add_function(wrap_pyfunction!(run_campaign, m)?)?;
    m.add_function(wrap_pyfunction!(campaign_config, m)?)?;
    Ok(())
}
