//! `vp-test-support`: the fixtures several test binaries share, in one
//! place instead of one copy per test file (dev-dependency only).
//!
//! - [`rock`]: the paper's initial flight, a nadir grid over the procedural
//!   rock (planner tests and benches, CLI tests).
//! - [`plans`]: small mission plans of triplet photos (mission tests).
//! - [`mission_json`]: mission items a Python peer printed as JSON
//!   (MAVSDK and pymavlink tests).
//! - [`python`]: finding a Python that imports a peer library (MAVSDK,
//!   pymavlink, litchi_wp) for the tests that check against one.
#![warn(missing_docs, unreachable_pub)]
// Test support: its "skipped: ..." lines are test output, like a test's own.
#![allow(clippy::print_stdout, clippy::missing_panics_doc)]

pub mod mission_json;
pub mod plans;
pub mod python;
pub mod rock;
