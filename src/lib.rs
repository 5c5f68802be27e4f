pub use vp_mission as mission;
pub use vp_scene as scene;
pub use vp_forest as forest;
pub use vp_sim as sim;
pub use vp_labelgen as labelgen;
pub use vp_planner as planner;
