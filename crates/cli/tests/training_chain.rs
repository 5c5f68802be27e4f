//! The whole training chain on real photos, run as a user runs it:
//! `vpctl labelgen triplets -> vpctl mvs run --triplets -> vpctl labelgen run
//! -> vpctl train -> vpctl forest info` on the committed ViSP cube sequence
//! (tests/data/real-mvs/visp-cube, see its SOURCE.md). Pyramid level 3 only,
//! two PatchMatch iterations and a two-tree forest keep it at a few seconds;
//! every step still runs on the real images and the real COLMAP model.

use std::collections::{BTreeMap, BTreeSet};
use std::path::{Path, PathBuf};
use std::time::Instant;

use vp_scene::colmap::{read_depth_map, read_model};
use vp_scene::raster::{Label, LabelImage};

mod common;
use common::vpctl;

/// Runs `vpctl`, asserts exit 0 and returns stdout.
fn ok(args: &[&str]) -> String {
    let o = vpctl(args);
    assert_eq!(
        o.status.code(),
        Some(0),
        "vpctl {args:?}\nstdout: {}\nstderr: {}",
        String::from_utf8_lossy(&o.stdout),
        String::from_utf8_lossy(&o.stderr)
    );
    String::from_utf8_lossy(&o.stdout).into_owned()
}

/// `ok` on a command line split at whitespace (the temporary paths have none).
fn run(line: &str) -> String {
    ok(&line.split_whitespace().collect::<Vec<_>>())
}

fn copy_dir(from: &Path, to: &Path) {
    std::fs::create_dir_all(to).unwrap();
    for entry in std::fs::read_dir(from).unwrap() {
        let path = entry.unwrap().path();
        let dest = to.join(path.file_name().unwrap());
        if path.is_dir() {
            copy_dir(&path, &dest);
        } else {
            std::fs::copy(&path, &dest).unwrap();
        }
    }
}

/// Every file under `dir`, relative, sorted.
fn files(dir: &Path) -> BTreeSet<PathBuf> {
    let mut out = BTreeSet::new();
    let mut stack = vec![dir.to_path_buf()];
    while let Some(d) = stack.pop() {
        for entry in std::fs::read_dir(&d).unwrap() {
            let path = entry.unwrap().path();
            if path.is_dir() {
                stack.push(path);
            } else {
                out.insert(path.strip_prefix(dir).unwrap().to_path_buf());
            }
        }
    }
    out
}

/// Median depth (camera z) of the sparse points each image observes.
fn sparse_median_depths(sparse: &Path) -> BTreeMap<String, f64> {
    let rec = read_model(sparse).unwrap();
    let mut depths: BTreeMap<u32, Vec<f64>> = BTreeMap::new();
    for point in rec.points.values() {
        for &(id, _) in &point.track {
            let camera = rec.camera_of(id).unwrap();
            let z = camera.world_from_cam.inverse_transform_point(&point.xyz).z;
            depths.entry(id).or_default().push(z);
        }
    }
    depths
        .into_iter()
        .map(|(id, mut z)| {
            z.sort_by(f64::total_cmp);
            (rec.images[&id].name.clone(), z[z.len() / 2])
        })
        .collect()
}

/// Each triplet's level-3 depth maps: present, the size of the images
/// halved twice (rounded up), mostly filled, and at the depth of the sparse
/// points COLMAP triangulated in the same image (within 10 %).
fn check_depth_maps(depth: &Path, sparse: &Path, triplets: &[Vec<String>]) {
    let sparse_depth = sparse_median_depths(sparse);
    for (i, t) in triplets.iter().enumerate() {
        for name in t {
            let dir = depth.join(format!("t{i:04}/level3"));
            assert!(dir.join(format!("{name}.photometric.bin")).is_file());
            let map = read_depth_map(&dir.join(format!("{name}.geometric.bin"))).unwrap();
            assert_eq!((map.width, map.height), (97, 72), "t{i:04} {name}");
            let mut valid: Vec<f32> = map.data.iter().copied().filter(|d| *d > 0.0).collect();
            let share = valid.len() as f64 / map.data.len() as f64;
            assert!(
                share >= 0.3,
                "t{i:04} {name}: {:.1} % with depth",
                100.0 * share
            );
            valid.sort_by(f32::total_cmp);
            let median = f64::from(valid[valid.len() / 2]);
            let sparse = sparse_depth[name];
            assert!(
                (median - sparse).abs() <= 0.1 * sparse,
                "t{i:04} {name}: median depth {median:.2}, sparse points' {sparse:.2}"
            );
        }
    }
}

/// Each image of each triplet has a level-3 label image of its depth map's
/// size; returns the positive and negative pixels of all of them.
fn count_labels(labels: &Path, triplets: &[Vec<String>]) -> (u64, u64) {
    let (mut positive, mut negative) = (0, 0);
    for (i, t) in triplets.iter().enumerate() {
        for name in t {
            let rel = format!("t{i:04}/level3/{name}.vplabel");
            let label = LabelImage::load(&labels.join(&rel)).unwrap();
            assert_eq!((label.width(), label.height()), (97, 72), "{rel}");
            positive += label.count(Label::Positive) as u64;
            negative += label.count(Label::Negative) as u64;
        }
    }
    (positive, negative)
}

#[test]
fn labelgen_mvs_labelgen_train_chain_runs_on_the_real_sequence() {
    let start = Instant::now();
    let data = Path::new(env!("CARGO_MANIFEST_DIR")).join("../../tests/data/real-mvs/visp-cube");
    let tmp = tempfile::tempdir().unwrap();
    let ws = tmp.path().join("ws");
    copy_dir(&data, &ws);
    let ws_files = files(&ws);
    let t = tmp.path().to_str().unwrap();
    let w = ws.to_str().unwrap();

    // 1. Triplets. The cameras lie on a line, so the default
    // --min-equilateral 0.5 finds none (SOURCE.md); 0.45 finds some.
    run(&format!(
        "labelgen triplets --model {w}/sparse --out {t}/t.txt --per-bin 2 --min-equilateral 0.45 --seed 0"
    ));
    let list = std::fs::read_to_string(tmp.path().join("t.txt")).unwrap();
    let triplets: Vec<Vec<String>> = list
        .lines()
        .filter(|l| !l.starts_with('#'))
        .map(|l| l.split('\t').skip(2).map(str::to_string).collect())
        .collect();
    assert_eq!(triplets.len(), 5, "{list}");
    let images: BTreeSet<&String> = triplets.iter().flatten().collect();
    for name in &images {
        assert!(
            ws.join("images").join(name).is_file(),
            "{name} not in images/"
        );
    }
    assert!(triplets.iter().all(|t| t.len() == 3), "{list}");

    // 2. PatchMatch on every triplet at pyramid level 3, 2 iterations.
    std::fs::write(tmp.path().join("mvs.toml"), "iterations = 2\n").unwrap();
    run(&format!(
        "mvs run --workspace {w} --triplets {t}/t.txt --levels 3 --out {t}/depth --config {t}/mvs.toml"
    ));
    assert_eq!(
        files(&ws),
        ws_files,
        "mvs run --triplets wrote into the workspace"
    );
    check_depth_maps(&tmp.path().join("depth"), &ws.join("sparse"), &triplets);

    // 3. Labels from the depth maps (the SfM gauge is not metric ENU).
    run(&format!(
        "labelgen run --model {w}/sparse --frame-unchecked --triplets {t}/t.txt --depth-dir {t}/depth --out-dir {t}/labels"
    ));
    let (positive, negative) = count_labels(&tmp.path().join("labels"), &triplets);
    let summary: serde_json::Value = serde_json::from_str(
        &std::fs::read_to_string(tmp.path().join("labels/summary.json")).unwrap(),
    )
    .unwrap();
    let n = |key: &str| {
        summary[key]
            .as_u64()
            .unwrap_or_else(|| panic!("{key}: {summary}"))
    };
    assert_eq!(n("reconstructions"), 5);
    assert_eq!(n("positive"), positive);
    assert_eq!(n("negative_voted") + n("negative_missing"), negative);
    assert!(positive > 10_000, "{positive} positive pixels");
    // Without a mesh every negative comes from voting between triplets.
    assert!(n("negative_voted") > 0, "{summary}");

    // 4. Train on the real images and their labels; the model reads back.
    std::fs::write(
        tmp.path().join("forest.toml"),
        "n_tests = 50\nn_thresholds = 10\n",
    )
    .unwrap();
    run(&format!(
        "train --images {w}/images --labels {t}/labels --out {t}/model.vpforest --trees 2 --max-depth 4 --config {t}/forest.toml --seed 0"
    ));
    let info: serde_json::Value =
        serde_json::from_str(&run(&format!("forest info --json {t}/model.vpforest"))).unwrap();
    assert_eq!(info["params"]["n_trees"], 2, "{info}");
    let s = &info["summary"];
    assert_eq!(s["n_images"].as_u64(), Some(images.len() as u64), "{info}");
    assert_eq!(s["n_label_images"], 15, "{info}");
    assert_eq!(s["n_positive"].as_u64(), Some(positive), "{info}");
    assert_eq!(s["n_negative"].as_u64(), Some(negative), "{info}");
    let text = run(&format!("forest info {t}/model.vpforest"));
    assert!(text.contains("trees: 2"), "{text}");
    eprintln!("whole chain: {:.1} s", start.elapsed().as_secs_f64());
}
