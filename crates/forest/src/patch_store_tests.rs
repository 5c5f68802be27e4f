//! The patch store: same trees as training in memory, memory bounded by
//! the budget and one chunk, clear errors and no partial output.

use std::path::Path;

use super::*;
use crate::synthetic::{label_image, texture_image};
use crate::{train, train_tree, StoreBudget};
use vp_scene::raster::Label;

/// Two textured images with sparse labels (angle-dependent on noisy blocks,
/// so nodes stay impure and trees grow deep).
fn set() -> TrainingSet {
    let mut set = TrainingSet::new();
    for s in 0..2 {
        let img = texture_image(120, 90, 16, s);
        let labels = label_image(&img, 2, 50.0, 100 + s, |noisy, angle| {
            if !noisy || angle < 20.0 {
                Label::Positive
            } else {
                Label::Negative
            }
        });
        set.add_image(&img.image, &[labels]).unwrap();
    }
    set
}

fn params() -> TrainParams {
    TrainParams {
        n_trees: 3,
        max_depth: 10,
        min_samples_split: 10,
        n_tests: 60,
        n_thresholds: 20,
        n_node_samples: 120,
        samples_per_class: 1200,
        ..TrainParams::default()
    }
}

const CHUNK: usize = 97;

fn write(set: &TrainingSet, dir: &Path) -> Manifest {
    write_patch_store(set, &params(), 7, dir, &[], CHUNK, false).unwrap()
}

#[test]
fn trees_from_the_store_are_the_trees_trained_in_memory_at_any_budget() {
    let set = set();
    let tmp = tempfile::tempdir().unwrap();
    let dir = tmp.path().join("store");
    let m = write(&set, &dir);
    assert_eq!(m.n_positive, 1200);
    assert_eq!(m.n_negative, 1200);
    assert_eq!(m.chunks.len(), 2400usize.div_ceil(CHUNK));
    let store = PatchStore::open(&dir).unwrap();
    let p = params();
    // 0: every node streams; 300 patches: subtrees load below the root;
    // the default: the root's subtree (the whole tree) loads at once.
    for resident_bytes in [0, 300 * PATCH_LEN, 4 << 30] {
        let budget = StoreBudget { resident_bytes };
        for t in 0..p.n_trees {
            let (from_store, reads) = store.train_tree_counted(&p, t, budget).unwrap();
            let in_memory = train_tree(&set, &p, 7, t).unwrap();
            assert_eq!(
                from_store.to_bytes(),
                in_memory.to_bytes(),
                "tree {t}, budget {resident_bytes}"
            );
            assert!(reads.chunk_reads > 0);
            // Bounded by construction: the budget, one chunk, one node's
            // evaluation samples, whatever the store's size.
            let bound = resident_bytes.min(store.len() * PATCH_LEN)
                + (CHUNK + p.n_node_samples) * PATCH_LEN;
            assert!(
                reads.peak_patch_bytes <= bound as u64,
                "held {} bytes, bound {bound}",
                reads.peak_patch_bytes
            );
            if resident_bytes == 0 {
                assert_eq!(reads.subtrees_loaded, 0);
            } else {
                assert!(reads.subtrees_loaded >= 1);
            }
        }
    }
    let forest = store.train(&p, StoreBudget::default()).unwrap();
    assert_eq!(forest.to_bytes(), train(&set, &p, 7).unwrap().to_bytes());
}

#[test]
fn a_store_refuses_parameters_of_another_draw() {
    let tmp = tempfile::tempdir().unwrap();
    let dir = tmp.path().join("store");
    write(&set(), &dir);
    let store = PatchStore::open(&dir).unwrap();
    let p = TrainParams {
        samples_per_class: 999,
        ..params()
    };
    let e = store.train_tree(&p, 0, StoreBudget::default()).unwrap_err();
    assert!(e.to_string().contains("samples_per_class = 1200"), "{e}");
    let e = store
        .train_tree(&params(), 3, StoreBudget::default())
        .unwrap_err();
    assert!(e.to_string().contains("tree index 3"), "{e}");
}

#[test]
fn missing_corrupt_and_truncated_stores_are_named_errors() {
    let tmp = tempfile::tempdir().unwrap();
    let dir = tmp.path().join("store");
    let e = PatchStore::open(&dir).unwrap_err().to_string();
    assert!(
        e.contains("no patch store here") && e.contains("vpctl-dask store"),
        "{e}"
    );
    write(&set(), &dir);
    let manifest = dir.join("manifest.json");
    let good = std::fs::read(&manifest).unwrap();
    std::fs::write(&manifest, &good[..good.len() / 2]).unwrap();
    let e = PatchStore::open(&dir).unwrap_err().to_string();
    assert!(
        e.contains("manifest.json") && e.contains("not a patch store manifest"),
        "{e}"
    );
    std::fs::write(&manifest, &good).unwrap();
    let chunk = dir.join("chunk-00003.bin");
    let bytes = std::fs::read(&chunk).unwrap();
    std::fs::write(&chunk, &bytes[..100]).unwrap();
    let e = PatchStore::open(&dir).unwrap_err().to_string();
    assert!(
        e.contains("chunk-00003.bin") && e.contains("truncated"),
        "{e}"
    );
    std::fs::write(&chunk, &bytes).unwrap();
    let cols = dir.join("cols-00001.bin");
    let bytes = std::fs::read(&cols).unwrap();
    std::fs::write(&cols, &bytes[..bytes.len() - 1]).unwrap();
    let e = PatchStore::open(&dir).unwrap_err().to_string();
    assert!(
        e.contains("cols-00001.bin") && e.contains("truncated"),
        "{e}"
    );
    std::fs::write(&cols, &bytes).unwrap();
    let labels = dir.join("labels.u8");
    let mut l = std::fs::read(&labels).unwrap();
    l[5] ^= 1;
    std::fs::write(&labels, &l).unwrap();
    let e = PatchStore::open(&dir).unwrap_err().to_string();
    assert!(e.contains("labels.u8") && e.contains("digest"), "{e}");
}

#[test]
fn a_failed_write_leaves_nothing_and_an_existing_store_is_kept() {
    let tmp = tempfile::tempdir().unwrap();
    let dir = tmp.path().join("store");
    // One class only: the draw fails before anything is written.
    let img = texture_image(40, 40, 8, 1);
    let labels = label_image(&img, 2, 50.0, 2, |_, _| Label::Positive);
    let mut one_class = TrainingSet::new();
    one_class.add_image(&img.image, &[labels]).unwrap();
    let e = write_patch_store(&one_class, &params(), 7, &dir, &[], CHUNK, false).unwrap_err();
    assert!(e.to_string().contains("both classes"), "{e}");
    assert_eq!(std::fs::read_dir(tmp.path()).unwrap().count(), 0);
    let m = write(&set(), &dir);
    let e = write_patch_store(&set(), &params(), 8, &dir, &[], CHUNK, false).unwrap_err();
    assert!(e.to_string().contains("earlier"), "{e}");
    assert_eq!(PatchStore::open(&dir).unwrap().manifest(), &m);
    let e = write_patch_store(
        &set(),
        &params(),
        7,
        &tmp.path().join("no/store"),
        &[],
        CHUNK,
        false,
    )
    .unwrap_err();
    assert!(e.to_string().contains("mkdir -p"), "{e}");
}

/// `--force` replaces only what vpctl wrote: a folder of someone else's
/// files (or the current folder) is refused even with it, and an earlier
/// store is replaced with the user's own file beside it kept.
#[test]
fn force_never_deletes_what_vpctl_did_not_write() {
    let tmp = tempfile::tempdir().unwrap();
    let theirs = tmp.path().join("theirs");
    std::fs::create_dir(&theirs).unwrap();
    std::fs::write(theirs.join("thesis.tex"), "precious").unwrap();
    let e = write_patch_store(&set(), &params(), 7, &theirs, &[], CHUNK, true).unwrap_err();
    assert!(e.to_string().contains("not a vpctl output"), "{e}");
    assert_eq!(
        std::fs::read_to_string(theirs.join("thesis.tex")).unwrap(),
        "precious"
    );
    assert_eq!(std::fs::read_dir(&theirs).unwrap().count(), 1);

    let dir = tmp.path().join("store");
    write(&set(), &dir);
    std::fs::write(dir.join("notes.txt"), "mine").unwrap();
    let m = write_patch_store(&set(), &params(), 8, &dir, &[], CHUNK, true).unwrap();
    assert_eq!(PatchStore::open(&dir).unwrap().manifest(), &m);
    assert_eq!(
        std::fs::read_to_string(dir.join("notes.txt")).unwrap(),
        "mine"
    );
    // Nothing left beside it (the staging and the old folder are gone).
    assert_eq!(std::fs::read_dir(tmp.path()).unwrap().count(), 2);
}
