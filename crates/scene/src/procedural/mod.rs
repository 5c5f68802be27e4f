//! Procedural scenes: test shapes and aerial sites with materials, deterministic by seed.
