pub use vp_scene as scene;
pub use vp_mission as mission;
pub use vp_planner as planner;
