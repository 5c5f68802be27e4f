//! The versioned plan file: ordered waypoints written by the planner, read by the mission crate.
