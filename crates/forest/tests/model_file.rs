//! Damaged model files are rejected with a clear message, never a panic.

use std::path::Path;

use proptest::prelude::*;
use vp_forest::synthetic::{label_image, texture_image};
use vp_forest::{train, Forest, TrainParams, TrainingSet};
use vp_scene::binfile::fnv1a64;
use vp_scene::raster::Label;

fn model_bytes() -> Vec<u8> {
    model(1).to_bytes()
}

/// A small forest trained with `seed`.
fn model(seed: u64) -> Forest {
    let img = texture_image(48, 48, 16, 4);
    let labels = label_image(&img, 2, 50.0, 4, |noisy, _| {
        if noisy {
            Label::Negative
        } else {
            Label::Positive
        }
    });
    let mut set = TrainingSet::new();
    set.add_image(&img.image, &[labels]).unwrap();
    let params = TrainParams {
        n_trees: 2,
        max_depth: 5,
        min_samples_split: 10,
        n_tests: 30,
        n_thresholds: 10,
        n_node_samples: 100,
        ..TrainParams::default()
    };
    train(&set, &params, seed).unwrap()
}

fn error_of(bytes: &[u8]) -> String {
    Forest::from_bytes(bytes, Path::new("model.vpforest"))
        .unwrap_err()
        .to_string()
}

fn assert_error(bytes: &[u8], needle: &str) {
    let msg = error_of(bytes);
    assert!(msg.contains("model.vpforest"), "{msg}");
    assert!(msg.contains(needle), "'{msg}' should mention '{needle}'");
}

/// Replaces the checksum so a deliberate inconsistency gets past it.
fn reseal(mut bytes: Vec<u8>) -> Vec<u8> {
    let body = bytes.len() - 8;
    let sum = fnv1a64(&bytes[..body]);
    bytes[body..].copy_from_slice(&sum.to_le_bytes());
    bytes
}

/// The fingerprint campaign reports record is the checksum the model's
/// file ends with: the same after a save and a load, another for a forest
/// trained with another seed.
#[test]
fn the_fingerprint_is_the_files_checksum_and_tells_models_apart() {
    let forest = model(1);
    let bytes = forest.to_bytes();
    let body = bytes.len() - 8;
    assert_eq!(forest.fingerprint(), fnv1a64(&bytes[..body]));
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("m.vpforest");
    forest.save(&path).unwrap();
    let file = std::fs::read(&path).unwrap();
    assert_eq!(file[body..], forest.fingerprint().to_le_bytes());
    assert_eq!(
        Forest::load(&path).unwrap().fingerprint(),
        forest.fingerprint()
    );
    assert_eq!(model(1).fingerprint(), forest.fingerprint());
    assert_ne!(model(2).fingerprint(), forest.fingerprint());
}

#[test]
fn empty_file_is_rejected() {
    assert_error(&[], "empty file");
}

#[test]
fn non_model_files_are_rejected() {
    assert_error(
        b"\x89PNG\r\n\x1a\n0000000000000000",
        "not a vp-forest model",
    );
    assert_error(b"VPFORES", "not a vp-forest model");
}

#[test]
fn truncated_models_are_rejected() {
    let good = model_bytes();
    for len in [
        9,
        12,
        19,
        40,
        good.len() / 2,
        good.len() - 9,
        good.len() - 1,
    ] {
        let msg = error_of(&good[..len]);
        assert!(
            msg.contains("truncated") || msg.contains("checksum"),
            "length {len}: {msg}"
        );
    }
}

#[test]
fn flipped_bytes_are_rejected() {
    let good = model_bytes();
    for at in [12, 20, good.len() / 2, good.len() - 20, good.len() - 3] {
        let mut bad = good.clone();
        bad[at] ^= 0x04;
        assert_error(&bad, "checksum mismatch");
    }
}

#[test]
fn other_format_versions_are_rejected() {
    let mut bad = model_bytes();
    bad[8] = 2;
    assert_error(&bad, "format version 2");
}

#[test]
fn consistent_checksum_with_a_broken_tree_is_rejected() {
    let good = model_bytes();
    let header_len = u32::from_le_bytes([good[12], good[13], good[14], good[15]]) as usize;
    // First node of the first tree: after magic, version, header, tree count, node and leaf counts.
    let node = 16 + header_len + 4 + 8;
    let mut bad = good.clone();
    bad[node + 9..node + 13].copy_from_slice(&u32::MAX.to_le_bytes());
    assert_error(&reseal(bad), "tree 0");
    let mut bad = good.clone();
    bad[node + 2] = 9;
    assert_error(&reseal(bad), "unknown test type 9");
    let mut bad = good.clone();
    bad[16] = b'[';
    assert_error(&reseal(bad), "model header");
    let mut extra = good[..good.len() - 8].to_vec();
    extra.extend_from_slice(&[0; 4 + 8]); // 4 stray bytes, then room for the checksum
    assert_error(&reseal(extra), "unexpected bytes");
}

#[test]
fn saving_never_leaves_a_partial_file_and_missing_files_are_named() {
    let forest = Forest::from_bytes(&model_bytes(), Path::new("m")).unwrap();
    let dir = tempfile::tempdir().unwrap();
    let missing_dir = dir.path().join("no/such/dir/m.vpforest");
    assert!(forest.save(&missing_dir).is_err());
    let msg = Forest::load(&dir.path().join("absent.vpforest"))
        .unwrap_err()
        .to_string();
    assert!(msg.contains("absent.vpforest"), "{msg}");
    assert_eq!(std::fs::read_dir(dir.path()).unwrap().count(), 0);
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(48))]
    /// Any single damaged byte or cut gives an error, never a panic or a model.
    #[test]
    fn any_damage_is_an_error(at in 0usize..10_000, bit in 0u8..8, cut in proptest::bool::ANY) {
        let good = model_bytes();
        let at = at % good.len();
        let bad = if cut { good[..at].to_vec() } else {
            let mut b = good.clone();
            b[at] ^= 1 << bit;
            b
        };
        prop_assert!(Forest::from_bytes(&bad, Path::new("m")).is_err());
    }
}
