//! Finding a Python that imports a peer library, for the tests that check
//! vpctl's output against an independent implementation.

use std::path::Path;
use std::process::{Command, Stdio};

/// Whether `python` can import `module`.
#[must_use]
pub fn imports(python: &str, module: &str) -> bool {
    Command::new(python)
        .args(["-c", &format!("import {module}")])
        .stderr(Stdio::null())
        .status()
        .is_ok_and(|s| s.success())
}

/// The Python in `python_env` (default `python3`) if it imports `module`.
/// Otherwise `None`, after printing why the caller skips, or a panic when
/// `require_env` is set (CI), so that a missing peer is a failure there
/// instead of a silent pass.
#[must_use]
pub fn optional_peer(module: &str, python_env: &str, require_env: &str) -> Option<String> {
    let py = std::env::var(python_env).unwrap_or_else(|_| "python3".into());
    if imports(&py, module) {
        return Some(py);
    }
    assert!(
        std::env::var_os(require_env).is_none(),
        "{require_env} is set but {py} cannot import {module}"
    );
    println!("skipped: {py} cannot import {module} (set {python_env})");
    None
}

/// `VP_MAVSDK_PYTHON` (default `python3`) if it imports `mavsdk`; see
/// [`optional_peer`] (`VP_REQUIRE_MAVSDK`).
#[must_use]
pub fn mavsdk_python() -> Option<String> {
    optional_peer("mavsdk", "VP_MAVSDK_PYTHON", "VP_REQUIRE_MAVSDK")
}

/// `VP_LITCHI_PYTHON` (default `python3`) if it imports `litchi_wp`; see
/// [`optional_peer`] (`VP_REQUIRE_LITCHI`).
#[must_use]
pub fn litchi_python() -> Option<String> {
    optional_peer("litchi_wp", "VP_LITCHI_PYTHON", "VP_REQUIRE_LITCHI")
}

/// A Python with pymavlink: `VP_PYMAVLINK_PYTHON`, else the workspace's
/// `.venv/bin/python` (which `scripts/test.sh` fills), else `python3`.
/// Panics when it cannot import pymavlink: the signing tests do not skip.
#[must_use]
pub fn pymavlink_python() -> String {
    let venv = Path::new(env!("CARGO_MANIFEST_DIR")).join("../../.venv/bin/python");
    let py = std::env::var("VP_PYMAVLINK_PYTHON").unwrap_or_else(|_| {
        if venv.exists() {
            venv.to_string_lossy().into_owned()
        } else {
            "python3".into()
        }
    });
    assert!(
        imports(&py, "pymavlink"),
        "{py} cannot import pymavlink: run `python3 -m venv .venv && .venv/bin/pip install -r \
         crates/mission/tests/pymavlink/requirements.txt` (scripts/test.sh does) or set \
         VP_PYMAVLINK_PYTHON"
    );
    py
}
