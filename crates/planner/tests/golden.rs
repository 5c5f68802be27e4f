//! Speed-ups must not change plans: the plans of a few seeded procedural
//! scenarios are compared bit for bit with a golden file made by the
//! planner before its performance work (issue 19).
//!
//! The golden holds everything a call decides (waypoints, gains, visit
//! counts, T, f(t) of every sampled triangle) with floats as bit patterns.
//! A change that is meant to alter plans regenerates it, and says so in
//! its commit:
//! `VP_PLANNER_UPDATE_GOLDEN=1 cargo test -p vp-planner --test golden`.

mod common;

use std::path::PathBuf;

use common::{initial_views, plan_rock, site, test_config};
use serde_json::{json, Value};
use vp_planner::{strip_timings, AcquiredView, PlannerConfig, UnknownSpace};
use vp_scene::procedural::Site;
use vp_scene::raster::{AngleBins, ConfidenceImage};

fn golden_path() -> PathBuf {
    PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("tests/data/golden_plans.json")
}

/// A confidence image that varies over the image and the angle bins, so
/// that every camera gives a triangle a different curve (the closest-image
/// rules then matter).
fn patterned(view: &AcquiredView, salt: usize) -> ConfidenceImage {
    let k = view.camera.intrinsics;
    let mut img = ConfidenceImage::zeros(k.width, k.height, 50, AngleBins::paper()).unwrap();
    for (i, v) in img.values_mut().iter_mut().enumerate() {
        let node = i / 9 + salt;
        let bin = i % 9;
        *v = 0.35 + 0.65 * (((node * 37 + bin * 11) % 23) as f32 / 22.0);
    }
    img
}

/// Everything a call decided, floats as bits.
fn fingerprint(s: &Site, acquired: &[AcquiredView], cfg: &PlannerConfig) -> Value {
    let r = plan_rock(s, acquired, cfg).unwrap();
    let mut plan = r.plan.clone();
    strip_timings(&mut plan);
    let bits =
        |v: &[f64]| -> Vec<String> { v.iter().map(|x| format!("{:016x}", x.to_bits())).collect() };
    let f: Vec<f64> = r.sampled.iter().map(|t| t.f).collect();
    json!({
        "plan": serde_json::to_value(&plan).unwrap(),
        "gains": bits(&r.triplet_gains),
        "visited": r.visited,
        "selected_faces": r.selected_faces,
        "f": bits(&f),
        "dropped_triplets": r.dropped_triplets,
        "cut_short_reason": r.cut_short_reason,
    })
}

fn scenarios() -> Value {
    let s = site(4, 30_000);
    let np = initial_views(&s);
    let predicted: Vec<AcquiredView> = np
        .iter()
        .enumerate()
        .map(|(i, v)| AcquiredView {
            camera: v.camera,
            confidence: Some(patterned(v, i)),
        })
        .collect();
    let base = PlannerConfig {
        n_triplets: 4,
        ..test_config(&s)
    };
    let exhaustive = PlannerConfig {
        m3_early_stop: false,
        n_triplets: 2,
        seed: 3,
        ..base.clone()
    };
    let free = PlannerConfig {
        unknown_space: UnknownSpace::Free,
        seed: 7,
        ..base.clone()
    };
    json!({
        "np": fingerprint(&s, &np, &base),
        "predicted": fingerprint(&s, &predicted, &base),
        "exhaustive": fingerprint(&s, &np, &exhaustive),
        "free_predicted": fingerprint(&s, &predicted, &free),
    })
}

#[test]
fn plans_equal_the_golden_from_before_the_speedups() {
    let got = serde_json::to_string_pretty(&scenarios()).unwrap();
    let path = golden_path();
    if std::env::var_os("VP_PLANNER_UPDATE_GOLDEN").is_some() {
        std::fs::create_dir_all(path.parent().unwrap()).unwrap();
        std::fs::write(&path, &got).unwrap();
        return;
    }
    let want = std::fs::read_to_string(&path).unwrap();
    // Compared as text: serde_json's default float parsing is not exact.
    // Both sides are parsed the same way only to say what differs first.
    let (g, w): (Value, Value) = (
        serde_json::from_str(&got).unwrap(),
        serde_json::from_str(&want).unwrap(),
    );
    for (name, wv) in w.as_object().unwrap() {
        for (key, wk) in wv.as_object().unwrap() {
            assert_eq!(
                &g[name][key], wk,
                "scenario {name}: {key} differs from the golden"
            );
        }
    }
    assert!(got == want, "plans differ from the golden");
}
