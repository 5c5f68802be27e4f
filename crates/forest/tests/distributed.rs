//! Trees trained one by one (as on separate Dask workers) and assembled
//! make the same model bytes as one process training the whole forest.

use std::path::Path;

use vp_forest::synthetic::{label_image, texture_image};
use vp_forest::{assemble, train, train_tree, TrainParams, TrainedTree, TrainingPlan, TrainingSet};
use vp_scene::raster::Label;

fn set(seed: u64) -> TrainingSet {
    let mut set = TrainingSet::new();
    for i in 0..2 {
        let img = texture_image(64, 48, 16, seed + i);
        let labels = label_image(&img, 2, 20.0 + 10.0 * i as f32, seed + i, |noisy, angle| {
            if noisy && angle > 15.0 {
                Label::Negative
            } else {
                Label::Positive
            }
        });
        set.add_image(&img.image, &[labels]).unwrap();
    }
    set
}

fn params() -> TrainParams {
    TrainParams {
        n_trees: 4,
        max_depth: 8,
        min_samples_split: 10,
        n_tests: 60,
        n_thresholds: 10,
        n_node_samples: 200,
        samples_per_class: 1500,
        ..TrainParams::default()
    }
}

/// Each tree travels as bytes, is trained from its own copy of the set and
/// arrives out of order: the assembled model is still `train`'s, byte for byte.
#[test]
fn assembled_trees_give_the_single_process_model_bytes() {
    let params = params();
    let whole = train(&set(3), &params, 9).unwrap().to_bytes();
    let mut trees: Vec<TrainedTree> = (0..params.n_trees)
        .rev()
        .map(|i| {
            let bytes = train_tree(&set(3), &params, 9, i).unwrap().to_bytes();
            TrainedTree::from_bytes(&bytes, Path::new("tree.bin")).unwrap()
        })
        .collect();
    trees.swap(0, 2);
    let assembled = assemble(trees).unwrap().to_bytes();
    assert!(
        assembled == whole,
        "assembled model bytes differ from train's"
    );
    // One plan, many trees: the same as one tree per process.
    let s = set(3);
    let plan = TrainingPlan::new(&s, &params, 9).unwrap();
    let again: Vec<TrainedTree> = (0..params.n_trees)
        .map(|i| plan.train_tree(i).unwrap())
        .collect();
    assert!(assemble(again).unwrap().to_bytes() == whole);
}

#[test]
fn trees_of_different_runs_or_incomplete_sets_are_refused() {
    let params = params();
    let s = set(3);
    let tree = |seed, i| train_tree(&s, &params, seed, i).unwrap();
    let all = |seed| -> Vec<TrainedTree> { (0..params.n_trees).map(|i| tree(seed, i)).collect() };

    let mut mixed = all(9);
    mixed[1] = tree(10, 1);
    let e = assemble(mixed).unwrap_err().to_string();
    assert!(e.contains("another training run"), "{e}");

    let other_data = train_tree(&set(4), &params, 9, 1).unwrap();
    let mut mixed = all(9);
    mixed[1] = other_data;
    let e = assemble(mixed).unwrap_err().to_string();
    assert!(e.contains("another training run"), "{e}");

    let mut missing = all(9);
    missing.remove(2);
    let e = assemble(missing).unwrap_err().to_string();
    assert!(e.contains("tree 2 is missing"), "{e}");

    let mut twice = all(9);
    twice[3] = tree(9, 2);
    let e = assemble(twice).unwrap_err().to_string();
    assert!(e.contains("tree 2 is given twice"), "{e}");

    let e = train_tree(&s, &params, 9, 4).unwrap_err().to_string();
    assert!(e.contains("tree index 4"), "{e}");
    assert!(assemble(Vec::new()).is_err());
}

#[test]
fn damaged_tree_bytes_are_rejected_with_the_source_named() {
    let bytes = train_tree(&set(3), &params(), 9, 0).unwrap().to_bytes();
    let mut bad = bytes.clone();
    let mid = bad.len() / 2;
    bad[mid] ^= 1;
    let e = TrainedTree::from_bytes(&bad, Path::new("t0.vptree"))
        .unwrap_err()
        .to_string();
    assert!(e.contains("t0.vptree"), "{e}");
    let e = TrainedTree::from_bytes(&bytes[..bytes.len() - 3], Path::new("t0.vptree"))
        .unwrap_err()
        .to_string();
    assert!(e.contains("t0.vptree"), "{e}");
}
