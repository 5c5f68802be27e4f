pub use vp_scene as scene;
pub use vp_mission as mission;
