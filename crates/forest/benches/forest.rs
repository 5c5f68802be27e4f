//! Time budgets of the forest.
//!
//! - `split/paper_node`: one node of the paper's size, 1000 samples x 5000
//!   tests x 100 thresholds (throughput in sample-test evaluations).
//! - `train/small_forest`: 4 trees, depth 12, 500 tests, on 40k samples.
//! - `lab/*`: the sRGB to Lab conversion alone.
//! - `predict/*`: dense prediction at step 8 with 20 trees grown to depth 20
//!   (reduced tests per node so the fixture trains in seconds; depth and
//!   node count are what prediction pays for): 1 Mpx, and the issue's
//!   16 Mpx (4912x3264) image: `grid_only` walks planes converted
//!   beforehand, `image` converts and walks band by band.
//!
//! The prediction fixture is trained once and cached in the system temp
//! directory (the training is deterministic, the file name carries the seed);
//! see [`prediction_forest`] for its two tiers.
//! Run: `cargo bench -p vp-forest -- --quick`
//! (paper-size trees: `VP_FOREST_BENCH=paper cargo bench -p vp-forest -- --quick predict`).

use std::hint::black_box;
use std::path::PathBuf;
use std::time::{Duration, Instant};

use criterion::{criterion_group, criterion_main, Criterion, Throughput};
use rand::{Rng, SeedableRng};
use vp_forest::patch::{gather_columns, SplitTest};
use vp_forest::split::{best_split, NodeData};
use vp_forest::synthetic::{label_image, texture_image};
use vp_forest::{train, Forest, LabPlanes, TrainParams, TrainingSet};
use vp_scene::raster::Label;

fn angle_rule(noisy: bool, angle: f32) -> Label {
    if !noisy || angle < 20.0 {
        Label::Positive
    } else {
        Label::Negative
    }
}

fn training_set(n_images: u64, size: u32, stride: u32) -> TrainingSet {
    let mut set = TrainingSet::new();
    for s in 0..n_images {
        let img = texture_image(size, size, 32, s);
        let labels = label_image(&img, stride, 50.0, 1000 + s, angle_rule);
        set.add_image(&img.image, &[labels]).unwrap();
    }
    set
}

/// Noise labels: a pseudo-random outcome per pixel (from its random angle),
/// so trees keep splitting until their leaves are small, as on real data.
fn noise_rule(_noisy: bool, angle: f32) -> Label {
    if ((angle * 1000.0) as u32).is_multiple_of(2) {
        Label::Positive
    } else {
        Label::Negative
    }
}

/// A prediction forest of `size`, trained with few tests per
/// node (prediction pays for depth and node count, not for test quality).
/// Tier `fast` (default): 300k samples, about 19k nodes per tree, mean
/// sample depth 16, 6 MB compiled; trains in about 15 s. Tier `paper`
/// (`VP_FOREST_BENCH=paper`): 2M noise-labelled samples, about 49k nodes
/// per tree, nearly every walk 20 levels deep, 16 MB compiled (the paper's
/// trees on 8M samples are likely larger still); trains in about 90 s.
/// Both are trained once and cached in the temp directory (deterministic).
/// `size` is (trees, depth): the paper's 20x20 and the default
/// (`TrainParams::default`, 10x16) are both timed, so the 16 Mpx goal is
/// measured on the model users run as well as on the paper's.
fn prediction_forest((n_trees, max_depth): (usize, usize)) -> (Forest, &'static str) {
    let paper = std::env::var("VP_FOREST_BENCH").is_ok_and(|v| v == "paper");
    let tier = if paper { "paper" } else { "fast" };
    let seed = 20;
    let path: PathBuf = std::env::temp_dir().join(format!(
        "vp-forest-bench-v2-{tier}-{seed}-{n_trees}x{max_depth}.vpforest"
    ));
    if let Ok(f) = Forest::load(&path) {
        return (f, tier);
    }
    let params = TrainParams {
        n_trees,
        max_depth,
        min_samples_split: if paper { 10 } else { 2 },
        n_tests: 20,
        n_thresholds: 10,
        n_node_samples: 200,
        samples_per_class: if paper { 1_000_000 } else { 150_000 },
        ..TrainParams::default()
    };
    let t = Instant::now();
    let set = if paper {
        let mut set = TrainingSet::new();
        for s in 0..8 {
            let img = texture_image(512, 512, 32, s);
            set.add_image(
                &img.image,
                &[label_image(&img, 1, 50.0, 1000 + s, noise_rule)],
            )
            .unwrap();
        }
        set
    } else {
        training_set(12, 256, 1)
    };
    let forest = train(&set, &params, seed).unwrap();
    let s = forest.summary();
    eprintln!(
        "prediction fixture ({tier}): {} nodes, {} leaves, max depth {}, mean sample depth {:.1}, trained in {:.1} s",
        s.n_nodes,
        s.n_leaves,
        s.max_depth_reached,
        s.mean_sample_depth,
        t.elapsed().as_secs_f64()
    );
    let _ = forest.save(&path);
    (forest, tier)
}

fn bench_split(c: &mut Criterion) {
    let set_img = texture_image(256, 256, 32, 1);
    let planes = LabPlanes::from_rgb(&set_img.image);
    let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(1);
    let m = 1000;
    let pixels: Vec<(u32, u32)> = (0..m)
        .map(|_| (rng.random_range(0..256), rng.random_range(0..256)))
        .collect();
    let at: Vec<_> = pixels
        .iter()
        .map(|&(x, y)| (&planes, planes.base(x, y)))
        .collect();
    let mut columns = Vec::new();
    gather_columns(&at, &mut columns);
    let labels: Vec<u8> = pixels
        .iter()
        .map(|&(x, y)| u8::from(!set_img.is_noisy(x, y)))
        .collect();
    let tests: Vec<(SplitTest, u64)> = (0..5000)
        .map(|_| (SplitTest::random(&mut rng), rng.random()))
        .collect();
    let data = NodeData {
        columns: &columns,
        row_of: None,
        labels: &labels,
        weights: [1.0, 1.0],
    };
    let mut g = c.benchmark_group("split");
    g.throughput(Throughput::Elements((m * tests.len()) as u64));
    g.sample_size(10);
    g.bench_function("paper_node_1000x5000x100", |b| {
        b.iter(|| black_box(best_split(black_box(&data), &tests, 100, true)));
    });
    g.finish();
}

fn bench_train(c: &mut Criterion) {
    let set = training_set(4, 128, 1);
    let params = TrainParams {
        n_trees: 4,
        max_depth: 12,
        min_samples_split: 50,
        n_tests: 500,
        n_thresholds: 100,
        n_node_samples: 1000,
        samples_per_class: 20_000,
        ..TrainParams::default()
    };
    let mut g = c.benchmark_group("train");
    g.sample_size(10);
    g.measurement_time(Duration::from_secs(20));
    g.throughput(Throughput::Elements(40_000));
    g.bench_function("small_forest_4x12_500tests_40k_samples", |b| {
        b.iter(|| black_box(train(&set, &params, 1).unwrap()));
    });
    g.finish();
}

fn bench_predict(c: &mut Criterion) {
    let paper = prediction_forest((20, 20));
    let d = TrainParams::default();
    let default = prediction_forest((d.n_trees, d.max_depth));
    let size = format!("{}x{}", d.n_trees, d.max_depth);
    let tier = paper.1;
    let (forest, small) = (paper.0, default.0);
    let mut g = c.benchmark_group(format!("predict_{tier}"));
    g.sample_size(10);
    for (name, w, h) in [
        ("1mpx_1024x1024", 1024, 1024),
        ("16mpx_4912x3264", 4912, 3264),
    ] {
        let img = texture_image(w, h, 64, 7).image;
        g.throughput(Throughput::Elements(u64::from(w * h)));
        // Prediction converts to the three Lab planes; time exactly that.
        let planes = LabPlanes::from_rgb(&img);
        g.bench_function(format!("lab_{name}"), |b| {
            b.iter(|| black_box(LabPlanes::from_rgb(black_box(&img))));
        });
        g.bench_function(format!("grid_only_{name}_step8_20x20"), |b| {
            b.iter(|| black_box(forest.predict_lab(&planes, 8).unwrap()));
        });
        g.bench_function(format!("image_{name}_step8_20x20"), |b| {
            b.iter(|| black_box(forest.predict_image(&img, 8).unwrap()));
        });
        g.bench_function(format!("image_{name}_step8_{size}_default"), |b| {
            b.iter(|| black_box(small.predict_image(&img, 8).unwrap()));
        });
    }
    g.finish();
}

criterion_group!(benches, bench_split, bench_train, bench_predict);
criterion_main!(benches);
