//! Workspace integration tests: the crates together on procedural sites.
//! One test binary (CONVENTIONS.md), one module per concern.

mod labels;
mod mvs;
mod mvs_guards;
mod mvs_real;
mod mvs_workspace;
mod scene;
