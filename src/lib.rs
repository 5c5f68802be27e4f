pub use vp_scene as scene;
pub use vp_forest as forest;
