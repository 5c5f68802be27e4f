//! What the CLI test binaries share: running `vpctl` and the test data.
#![allow(dead_code)]

use std::path::{Path, PathBuf};
use std::process::{Command, Output};

/// Runs the `vpctl` binary with `args`.
pub fn vpctl(args: &[&str]) -> Output {
    Command::new(env!("CARGO_BIN_EXE_vpctl"))
        .args(args)
        .output()
        .expect("vpctl runs")
}

/// Standard output as text.
pub fn stdout(o: &Output) -> String {
    String::from_utf8_lossy(&o.stdout).into_owned()
}

/// Standard error as text.
pub fn stderr(o: &Output) -> String {
    String::from_utf8_lossy(&o.stderr).into_owned()
}

/// Test data of vp-scene: real files written by MeshLab and COLMAP.
pub fn scene_data(rel: &str) -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("../scene/tests/data")
        .join(rel)
}
