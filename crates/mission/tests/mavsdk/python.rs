//! Finding a Python with MAVSDK, for the tests that use it as a peer: this
//! crate's `mavsdk_peer.rs` and the CLI's `real_recipe.rs` (which includes
//! this file by path).

use std::process::{Command, Stdio};

/// `VP_MAVSDK_PYTHON` (default `python3`) if it can import `mavsdk`.
/// Otherwise `None`, after printing why the caller skips, or a panic when
/// `VP_REQUIRE_MAVSDK` is set (CI), so that a missing peer is a failure
/// there instead of a silent pass.
pub fn mavsdk_python() -> Option<String> {
    let py = std::env::var("VP_MAVSDK_PYTHON").unwrap_or_else(|_| "python3".into());
    let ok = Command::new(&py)
        .args(["-c", "import mavsdk"])
        .stderr(Stdio::null())
        .status()
        .is_ok_and(|s| s.success());
    if ok {
        return Some(py);
    }
    assert!(
        std::env::var_os("VP_REQUIRE_MAVSDK").is_none(),
        "VP_REQUIRE_MAVSDK is set but {py} cannot import mavsdk"
    );
    println!("skipped: {py} cannot import mavsdk (set VP_MAVSDK_PYTHON)");
    None
}
