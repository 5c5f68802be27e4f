//! `vp-mission`: plan -> MAVLink mission.
#![warn(missing_docs)]
pub mod error;
pub mod geodesy;
pub mod items;
pub mod protocol;
pub mod testing;
pub use error::{MissionError, Result};
