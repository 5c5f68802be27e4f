//! A patch store at the paper's sample counts (4 M patches per class, 17.5
//! GB of patches) from synthetic textures, and trees trained from it in
//! bounded memory, for docs/performance.md:
//!
//! ```text
//! cargo build --release -p vp-forest --example store_paper
//! B=$CARGO_TARGET_DIR/release/examples/store_paper
//! $B write /scratch/paper-store            # the store (set as train_paper's)
//! /usr/bin/time -v $B train /scratch/paper-store 0   # tree 0, peak RSS
//! $B check /scratch/paper-store 0          # ... and the same tree in memory: equal bytes?
//! ```
//!
//! `VP_SAMPLES` (per class, default 4 M) scales the set, `VP_DEPTH` the
//! trees' depth (default the paper's 20), `VP_BUDGET_MB` the patches a
//! subtree may hold (default 4096).

use std::path::Path;
use std::time::Instant;

use vp_forest::synthetic::{label_image, texture_image};
use vp_forest::{train_tree, write_patch_store, PatchStore, StoreBudget, TrainParams, TrainingSet};
use vp_scene::raster::Label;

fn env(name: &str, default: usize) -> usize {
    std::env::var(name)
        .ok()
        .and_then(|v| v.parse().ok())
        .unwrap_or(default)
}

const SEED: u64 = 1;

fn params() -> TrainParams {
    TrainParams {
        samples_per_class: env("VP_SAMPLES", 4_000_000),
        max_depth: env("VP_DEPTH", 20),
        ..TrainParams::paper()
    }
}

/// train_paper's set: 1024x1024 textures, every pixel labelled, until
/// both classes have the samples per class (negatives are about a third).
fn set(params: &TrainParams) -> TrainingSet {
    let mut set = TrainingSet::new();
    let mut s = 0;
    while set.n_positive().min(set.n_negative()) < params.samples_per_class {
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
        s += 1;
    }
    set
}

fn main() -> Result<(), Box<dyn std::error::Error>> {
    let args: Vec<String> = std::env::args().collect();
    let usage = "usage: store_paper write|train|check STORE [TREE]";
    let (mode, dir) = match (args.get(1), args.get(2)) {
        (Some(m), Some(d)) => (m.as_str(), Path::new(d)),
        _ => return Err(usage.into()),
    };
    let tree: usize = args.get(3).map_or(Ok(0), |t| t.parse())?;
    let p = params();
    let budget = StoreBudget {
        resident_bytes: env("VP_BUDGET_MB", 4096) << 20,
    };
    let t = Instant::now();
    match mode {
        "write" => {
            let set = set(&p);
            let m = write_patch_store(&set, &p, SEED, dir, &[], 16384, false)?;
            println!(
                "store: {} samples ({} positive), {} chunks, {:.1} s",
                m.n_samples,
                m.n_positive,
                m.chunks.len(),
                t.elapsed().as_secs_f64()
            );
        }
        "train" | "check" => {
            let store = PatchStore::open(dir)?;
            let (trained, reads) = store.train_tree_counted(&p, tree, budget)?;
            println!(
                "tree {tree} from the store: {:.1} s, {} nodes, {} chunk reads, {:.1} GB read, \
                 {} subtrees loaded, {:.0} MB of patches held at most",
                t.elapsed().as_secs_f64(),
                trained.tree().nodes().len(),
                reads.chunk_reads,
                reads.bytes_read as f64 / 1e9,
                reads.subtrees_loaded,
                reads.peak_patch_bytes as f64 / 1e6
            );
            if mode == "check" {
                drop(store);
                let t = Instant::now();
                let in_memory = train_tree(&set(&p), &p, SEED, tree)?;
                let same = in_memory.to_bytes() == trained.to_bytes();
                println!(
                    "tree {tree} in memory: {:.1} s; same bytes: {same}",
                    t.elapsed().as_secs_f64()
                );
                if !same {
                    return Err("the trees differ".into());
                }
            }
        }
        _ => return Err(usage.into()),
    }
    Ok(())
}
