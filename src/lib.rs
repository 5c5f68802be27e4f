pub use vp_scene as scene;
