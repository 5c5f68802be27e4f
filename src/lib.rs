//! `vpctl-suite`: one facade over the vpctl crates (as ripgrep's `grep`
//! facade), hosting the workspace integration tests and benchmarks.
//! Layers, bottom up: `scene`; then `forest`, `labelgen`, `planner`,
//! `mission`, `mvs`; then `sim`.

pub use vp_forest as forest;
pub use vp_labelgen as labelgen;
pub use vp_mission as mission;
pub use vp_mvs as mvs;
pub use vp_planner as planner;
pub use vp_scene as scene;
pub use vp_sim as sim;
