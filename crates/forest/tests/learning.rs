//! The forest learns planted texture and angle dependences, deterministically.

use vp_forest::synthetic::{label_image, texture_image, TextureImage};
use vp_forest::{accuracy, sparsification, train, Forest, LabPlanes, TrainParams, TrainingSet};
use vp_scene::raster::{Label, LabelImage};

fn small_params() -> TrainParams {
    TrainParams {
        n_trees: 3,
        max_depth: 8,
        min_samples_split: 20,
        n_tests: 120,
        n_thresholds: 20,
        n_node_samples: 300,
        ..TrainParams::default()
    }
}

fn images(seeds: std::ops::Range<u64>) -> Vec<TextureImage> {
    seeds.map(|s| texture_image(96, 96, 24, s)).collect()
}

fn set_of(imgs: &[TextureImage], rule: fn(bool, f32) -> Label) -> TrainingSet {
    let mut set = TrainingSet::new();
    for (i, img) in imgs.iter().enumerate() {
        let labels = label_image(img, 2, 50.0, 1000 + i as u64, rule);
        set.add_image(&img.image, &[labels]).unwrap();
    }
    set
}

fn texture_rule(noisy: bool, _angle: f32) -> Label {
    if noisy {
        Label::Negative
    } else {
        Label::Positive
    }
}

/// Smooth always succeeds; noisy succeeds only below 20 deg.
fn angle_rule(noisy: bool, angle: f32) -> Label {
    if !noisy || angle < 20.0 {
        Label::Positive
    } else {
        Label::Negative
    }
}

#[test]
fn separable_textures_are_learned_to_over_95_percent_on_held_out_images() {
    let forest = train(&set_of(&images(0..6), texture_rule), &small_params(), 7).unwrap();
    let mut scored = Vec::new();
    for (i, img) in images(100..104).iter().enumerate() {
        let labels = label_image(img, 3, 50.0, 50 + i as u64, texture_rule);
        scored.extend(forest.score_labels(&img.image, &labels).unwrap());
    }
    let acc = accuracy(&scored, 0.5).unwrap();
    let sp = sparsification(&scored, 20).unwrap();
    eprintln!(
        "held-out accuracy {acc:.4}, relative AUSC {:.3} (random {:.3})",
        sp.relative_ausc, sp.random_relative_ausc
    );
    assert!(acc > 0.95, "held-out accuracy {acc}");
    assert!(sp.relative_ausc < 0.5 * sp.random_relative_ausc, "{sp:?}");
    let s = forest.summary();
    assert_eq!(s.n_images, 6);
    assert!(s.train_accuracy > 0.95 && s.max_depth_reached <= 8, "{s:?}");
}

/// Mean per-bin confidence over held-out pixels at least 4 px inside blocks
/// of the given texture.
fn mean_bins(forest: &Forest, imgs: &[TextureImage], noisy: bool) -> Vec<f32> {
    let b = forest.bins().len();
    let mut sum = vec![0.0f64; b];
    let mut n = 0;
    for img in imgs {
        let planes = LabPlanes::from_rgb(&img.image);
        let (w, h) = img.image.dimensions();
        let pixels: Vec<(u32, u32)> = (0..h)
            .flat_map(|y| (0..w).map(move |x| (x, y)))
            .filter(|&(x, y)| img.is_noisy(x, y) == noisy && img.border_distance(x, y) >= 4)
            .collect();
        for v in forest
            .predict_pixels(&planes, &pixels)
            .unwrap()
            .chunks_exact(b)
        {
            for (s, x) in sum.iter_mut().zip(v) {
                *s += f64::from(*x);
            }
            n += 1;
        }
    }
    sum.iter().map(|s| (s / f64::from(n)) as f32).collect()
}

#[test]
fn leaf_bins_reproduce_the_planted_angle_dependence() {
    // Larger leaves: the noisy class cannot be split by angle, so its leaves
    // hold both outcomes and the bins must tell them apart.
    let params = TrainParams {
        min_samples_split: 200,
        max_depth: 6,
        ..small_params()
    };
    let forest = train(&set_of(&images(10..16), angle_rule), &params, 3).unwrap();
    assert!(forest.summary().n_beyond_gamma_max > 0);
    let held_out = images(200..203);
    let noisy = mean_bins(&forest, &held_out, true);
    let smooth = mean_bins(&forest, &held_out, false);
    eprintln!("noisy bins {noisy:.3?}\nsmooth bins {smooth:.3?}");
    // Tolerance: 0.2 around the planted 1 / 0; smooth flat within 0.1.
    for (i, c) in noisy.iter().enumerate() {
        if i < 4 {
            assert!(*c > 0.8, "noisy bin {i} below 20 deg: {c} ({noisy:?})");
        } else {
            assert!(*c < 0.2, "noisy bin {i} at 20+ deg: {c} ({noisy:?})");
        }
    }
    let (lo, hi) = smooth
        .iter()
        .fold((1.0f32, 0.0f32), |(l, h), c| (l.min(*c), h.max(*c)));
    assert!(lo > 0.8 && hi - lo < 0.1, "smooth bins {smooth:?}");
    // The confidence image carries the same dependence, read at any angle.
    let img = &held_out[0];
    let conf = forest.predict_image(&img.image, 8).unwrap();
    let (i, j) = (0..conf.grid_size().1)
        .flat_map(|j| (0..conf.grid_size().0).map(move |i| (i, j)))
        .find(|&(i, j)| {
            let (x, y) = conf.node_pixel(i, j);
            img.is_noisy(x, y) && img.border_distance(x, y) >= 6
        })
        .unwrap();
    let (x, y) = conf.node_pixel(i, j);
    let at = |a: f64| conf.sample((f64::from(x) + 0.5, f64::from(y) + 0.5), a);
    assert!(at(5.0) > at(30.0) + 0.4, "{} vs {}", at(5.0), at(30.0));
    assert!(
        (at(45.0) - at(80.0)).abs() < 1e-9,
        "angles beyond gamma_max read the last bin"
    );
}

fn train_in_pool(threads: usize, set: &TrainingSet, params: &TrainParams, seed: u64) -> Vec<u8> {
    let pool = rayon::ThreadPoolBuilder::new()
        .num_threads(threads)
        .build()
        .unwrap();
    pool.install(|| train(set, params, seed).unwrap().to_bytes())
}

#[test]
fn same_seed_gives_identical_model_bytes_on_one_and_two_threads() {
    let set = set_of(&images(20..23), angle_rule);
    // Enough node work that tests run in parallel inside nodes too.
    let params = TrainParams {
        n_tests: 1000,
        n_node_samples: 400,
        ..small_params()
    };
    let one = train_in_pool(1, &set, &params, 11);
    let two = train_in_pool(2, &set, &params, 11);
    assert!(one == two, "model bytes differ between 1 and 2 threads");
    assert_ne!(one, train_in_pool(2, &set, &params, 12));
}

#[test]
fn saved_models_load_with_equal_predictions() {
    let forest = train(&set_of(&images(30..32), angle_rule), &small_params(), 5).unwrap();
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("m.vpforest");
    forest.save(&path).unwrap();
    let back = Forest::load(&path).unwrap();
    assert_eq!(back, forest);
    let img = texture_image(64, 48, 16, 99);
    let a = forest.predict_image(&img.image, 8).unwrap();
    let b = back.predict_image(&img.image, 8).unwrap();
    assert_eq!(a, b);
    a.save(&dir.path().join("c.vpconf")).unwrap();
    assert_eq!(
        vp_scene::raster::ConfidenceImage::load(&dir.path().join("c.vpconf")).unwrap(),
        b
    );
}

#[test]
fn unusable_training_input_is_rejected_with_a_reason() {
    let img = texture_image(32, 32, 16, 1);
    let mut set = TrainingSet::new();
    let wrong = LabelImage::new(31, 32);
    assert!(set
        .add_image(&img.image, &[wrong])
        .unwrap_err()
        .to_string()
        .contains("31x32"));
    let only_positive = label_image(&img, 2, 40.0, 1, |_, _| Label::Positive);
    set.add_image(&img.image, &[only_positive]).unwrap();
    let err = train(&set, &small_params(), 1).unwrap_err().to_string();
    assert!(err.contains("both classes"), "{err}");
    let bad = TrainParams {
        n_trees: 0,
        ..small_params()
    };
    assert!(train(&set, &bad, 1)
        .unwrap_err()
        .to_string()
        .contains("n_trees"));
}

/// Four positives to one negative, unrelated to the texture (as a
/// well-matched surface gives): a calibrated forest predicts about 0.8.
fn four_to_one_labels(w: u32, h: u32) -> LabelImage {
    let mut labels = LabelImage::new(w, h);
    for y in 0..h {
        for x in 0..w {
            let l = if (x + y) % 5 == 0 {
                Label::Negative
            } else {
                Label::Positive
            };
            labels.set(x, y, l, 10.0).unwrap();
        }
    }
    labels
}

#[test]
fn per_label_image_cap_bounds_the_samples_and_keeps_the_class_ratio() {
    let img = texture_image(64, 64, 16, 2);
    let labels = four_to_one_labels(64, 64);
    let mut set = TrainingSet::with_cap_per_label_image(500, 9);
    set.add_image(&img.image, &[labels.clone(), labels])
        .unwrap();
    assert_eq!(set.n_label_images(), 2);
    assert_eq!(set.n_positive() + set.n_negative(), 1000);
    // A uniform subset keeps the share near 0.8 (a per-class cap would make
    // it 0.5 and every learned confidence uncalibrated).
    let share = set.n_positive() as f64 / 1000.0;
    assert!((share - 0.8).abs() < 0.05, "positive share {share}");
}

#[test]
fn unbalanced_training_predicts_the_label_rate_whatever_samples_per_class_keeps() {
    let img = texture_image(64, 64, 16, 3);
    let mut set = TrainingSet::new();
    set.add_image(&img.image, &[four_to_one_labels(64, 64)])
        .unwrap();
    // 3277 positives and 819 negatives: drawing 500 of each would make the
    // drawn set half positive and the forest predict about 0.5.
    let params = TrainParams {
        samples_per_class: 500,
        balance_classes: false,
        ..small_params()
    };
    let forest = train(&set, &params, 5).unwrap();
    let planes = LabPlanes::from_rgb(&img.image);
    let pixels: Vec<(u32, u32)> = (0..64).flat_map(|y| (0..64).map(move |x| (x, y))).collect();
    let conf = forest.predict_pixels(&planes, &pixels).unwrap();
    let bin = forest.bins().bin_of(10.0).unwrap();
    let b = forest.bins().len();
    let mean = pixels
        .iter()
        .enumerate()
        .map(|(i, _)| f64::from(conf[i * b + bin]))
        .sum::<f64>()
        / pixels.len() as f64;
    assert!(
        (mean - 0.8).abs() < 0.06,
        "mean confidence {mean}, labels say 0.8"
    );
}
