//! The rules of stages 1 and 2 on small constructed cases: who may support
//! whom, similar viewpoints counting once, and order independence.

mod common;

use common::{reconstruct, scene, triplet_cameras, world, Errors, World};
use proptest::prelude::*;
use vp_labelgen::{generate_labels, support_maps, LabelParams, TripletReconstruction};
use vp_scene::Intrinsics;

const CLEAN: Errors = Errors {
    blobs: 0,
    holes: 0,
    radius: 0.0,
    noise_sigma: 0.0,
};

fn k() -> Intrinsics {
    Intrinsics::from_hfov(64, 48, 60.0).unwrap()
}

fn rec(w: &World, id: &str, names: [&str; 3], cx: f64, cy: f64, rot: f64) -> TripletReconstruction {
    let cams = triplet_cameras(cx, cy, 35.0, 15.0, rot, k());
    reconstruct(w, id, names, &cams, 1.0, CLEAN, 7).0
}

fn max_support(maps: &[(String, [Vec<u16>; 3])], id: &str) -> u16 {
    let (_, m) = maps.iter().find(|(i, _)| i == id).unwrap();
    m.iter().flatten().copied().max().unwrap_or(0)
}

#[test]
fn a_reference_sharing_an_image_never_supports() {
    let w = world();
    let a = rec(&w, "a", ["a0", "a1", "a2"], 0.0, 0.0, 0.0);
    // Same place, different viewpoint, but one image in common with `a`.
    let shares = rec(&w, "b", ["a1", "b1", "b2"], 14.0, 0.0, 0.5);
    let params = LabelParams::default();
    let maps = support_maps(&[a.clone(), shares.clone()], &params).unwrap();
    assert_eq!(max_support(&maps, "a"), 0);
    assert_eq!(max_support(&maps, "b"), 0);
    // Without support nobody votes: nothing is labelled.
    let labels = generate_labels(&[a.clone(), shares], None, &params).unwrap();
    assert!(labels
        .iter()
        .all(|l| l.counts.iter().all(|c| c.positive + c.negative_voted == 0)));
    // The same reference with its own images supports.
    let independent = rec(&w, "c", ["c0", "c1", "c2"], 14.0, 0.0, 0.5);
    let maps = support_maps(&[a, independent], &params).unwrap();
    assert_eq!(max_support(&maps, "a"), 1);
}

#[test]
fn references_from_similar_viewpoints_count_once() {
    let w = world();
    let a = rec(&w, "a", ["a0", "a1", "a2"], 0.0, 0.0, 0.0);
    // Two independent reconstructions from (nearly) the same viewpoint.
    let r1 = rec(&w, "r1", ["r10", "r11", "r12"], 14.0, 0.0, 0.5);
    let r2 = rec(&w, "r2", ["r20", "r21", "r22"], 14.5, 0.5, 0.6);
    let params = LabelParams::default();
    let maps = support_maps(&[a.clone(), r1.clone(), r2.clone()], &params).unwrap();
    assert_eq!(max_support(&maps, "a"), 1);
    // A third one from another direction counts again.
    let r3 = rec(&w, "r3", ["r30", "r31", "r32"], -12.0, 8.0, 0.2);
    let maps = support_maps(&[a, r1, r2, r3], &params).unwrap();
    assert_eq!(max_support(&maps, "a"), 2);
}

#[test]
fn a_reference_from_the_same_viewpoint_does_not_support() {
    let w = world();
    let a = rec(&w, "a", ["a0", "a1", "a2"], 0.0, 0.0, 0.0);
    let same = rec(&w, "s", ["s0", "s1", "s2"], 0.5, 0.0, 0.1);
    let maps = support_maps(&[a, same], &LabelParams::default()).unwrap();
    assert_eq!(max_support(&maps, "a"), 0);
}

/// Reconstruction id and the bytes of its three label files.
type FileBytes = (String, Vec<Vec<u8>>);

/// Label files' bytes per reconstruction, and the number of labelled pixels.
fn label_bytes(recs: &[TripletReconstruction]) -> (Vec<FileBytes>, usize) {
    let labels = generate_labels(recs, None, &LabelParams::default()).unwrap();
    let labelled = labels
        .iter()
        .flat_map(|l| l.counts)
        .map(|c| c.positive + c.negative_voted)
        .sum();
    let bytes = labels
        .into_iter()
        .map(|l| {
            (
                l.id,
                l.labels
                    .iter()
                    .map(vp_scene::raster::LabelImage::to_bytes)
                    .collect(),
            )
        })
        .collect();
    (bytes, labelled)
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(12))]
    #[test]
    fn labels_do_not_depend_on_input_order(perm in Just((0..6usize).collect::<Vec<_>>()).prop_shuffle()) {
        let w = world();
        let (recs, _) = scene(&w, 6, 1, 48, Errors::default());
        let expected = label_bytes(&recs);
        prop_assert!(expected.1 > 1000, "only {} pixels labelled", expected.1);
        let shuffled: Vec<TripletReconstruction> = perm.iter().map(|&i| recs[i].clone()).collect();
        prop_assert_eq!(label_bytes(&shuffled), expected);
    }
}

#[test]
fn bad_in_memory_input_is_refused_with_the_place() {
    let w = world();
    let mut a = rec(&w, "a", ["a0", "a1", "a2"], 0.0, 0.0, 0.0);
    let params = LabelParams::default();
    let dup = generate_labels(&[a.clone(), a.clone()], None, &params)
        .unwrap_err()
        .to_string();
    assert!(dup.contains("id a given twice"), "{dup}");
    a.views[1].depth.data[64 * 3 + 2] = f32::NAN;
    let nan = generate_labels(&[a], None, &params)
        .unwrap_err()
        .to_string();
    assert!(
        nan.contains("image a1") && nan.contains("pixel (2, 3)"),
        "{nan}"
    );
    let bad = LabelParams {
        k_sigma: -1.0,
        ..LabelParams::default()
    };
    assert!(generate_labels(&[], None, &bad).is_err());
    // Defaults as docs/design.md#training-labels-labelgen states them.
    let d = LabelParams::default();
    assert_eq!(
        (d.alpha_min_deg, d.s_min, d.sigma_px, d.mesh_iterations),
        (10.0, 1.5, 1.0, 3)
    );
}
