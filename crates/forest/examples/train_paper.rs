//! Trains at the paper's configuration (Mostegel et al.: 20 trees, depth 20,
//! 5000 tests, 100 thresholds, 1000 samples per node, 4M samples per class)
//! on synthetic textures, to measure wall time and peak memory:
//!
//! `cargo build --release -p vp-forest --example train_paper &&
//!  /usr/bin/time -v target/release/examples/train_paper`
//!
//! Scaled runs for a budget check: `VP_TREES=1 VP_SAMPLES=250000` (trees,
//! samples per class; images are added until twice the samples are labelled).
//! Labels: textured blocks succeed below 20 deg, smooth ones always, so the
//! angle (which no split sees) keeps noisy nodes impure and trees deep, as
//! on real data.

use std::time::Instant;

use vp_forest::synthetic::{label_image, texture_image};
use vp_forest::{train_with_progress, TrainParams, TrainingSet};
use vp_scene::raster::Label;

fn env(name: &str, default: usize) -> usize {
    std::env::var(name)
        .ok()
        .and_then(|v| v.parse().ok())
        .unwrap_or(default)
}

fn main() {
    let params = TrainParams {
        n_trees: env("VP_TREES", 20),
        samples_per_class: env("VP_SAMPLES", 4_000_000),
        ..TrainParams::default()
    };
    let t = Instant::now();
    let mut set = TrainingSet::new();
    let mut labelled = 0;
    let mut s = 0;
    while labelled < 2 * params.samples_per_class {
        let img = texture_image(1024, 1024, 32, s);
        let labels = label_image(&img, 1, 50.0, 1000 + s, |noisy, angle| {
            if !noisy || angle < 20.0 {
                Label::Positive
            } else {
                Label::Negative
            }
        });
        set.add_image(&img.image, &[labels])
            .expect("synthetic labels are valid");
        labelled += 1024 * 1024;
        s += 1;
    }
    eprintln!(
        "{s} images, {labelled} labelled pixels in {:.1} s",
        t.elapsed().as_secs_f64()
    );
    let t = Instant::now();
    let forest = train_with_progress(&set, &params, 1, &|done| {
        eprintln!("tree {done} done at {:.1} s", t.elapsed().as_secs_f64());
    })
    .expect("valid parameters");
    let s = forest.summary();
    println!(
        "{} trees, {} samples per class: {:.1} s training, {} nodes, {} leaves, max depth {}, mean sample depth {:.1}",
        params.n_trees,
        params.samples_per_class,
        t.elapsed().as_secs_f64(),
        s.n_nodes,
        s.n_leaves,
        s.max_depth_reached,
        s.mean_sample_depth
    );
}
