//! Label quality on a procedural world where the truth is known.

mod common;

use common::{scene, world, Errors, Truth};
use vp_labelgen::{generate_labels, LabelParams, LabelSummary, MissingPartMeshes};
use vp_scene::raster::Label;

#[derive(Default, Debug)]
struct Tally {
    surface: usize,
    labelled: usize,
    right: usize,
    pos_right: usize,
    pos_wrong: usize,
    wrong_px: usize,
    wrong_neg: usize,
    hole_px: usize,
    hole_neg: usize,
    invisible_labelled: usize,
    sky_labelled: usize,
}

#[test]
fn labels_are_accurate_and_cover_a_third_of_the_surface() {
    let w = world();
    let (recs, truths) = scene(&w, 8, 2, 128, Errors::default());
    let params = LabelParams::default();
    let meshes = MissingPartMeshes::new(&w.mesh, params.mesh_iterations);
    let labels = generate_labels(&recs, Some(&meshes), &params).unwrap();
    let mut t = Tally::default();
    for (rl, truth) in labels.iter().zip(&truths) {
        for (img, truth) in rl.labels.iter().zip(truth) {
            let width = img.width() as usize;
            for (i, &tr) in truth.iter().enumerate() {
                let label = img.label((i % width) as u32, (i / width) as u32);
                let labelled = label != Label::Unlabelled;
                if tr != Truth::Sky {
                    t.surface += 1;
                }
                if labelled {
                    t.labelled += 1;
                    let truth_positive = tr == Truth::Correct;
                    if (label == Label::Positive) == truth_positive {
                        t.right += 1;
                    }
                }
                match (tr, label) {
                    (Truth::Correct, Label::Positive) => t.pos_right += 1,
                    (_, Label::Positive) => t.pos_wrong += 1,
                    _ => {}
                }
                match tr {
                    Truth::Wrong => {
                        t.wrong_px += 1;
                        t.wrong_neg += usize::from(label == Label::Negative);
                    }
                    Truth::HoleVisible => {
                        t.hole_px += 1;
                        t.hole_neg += usize::from(label == Label::Negative);
                    }
                    Truth::HoleInvisible => t.invisible_labelled += usize::from(labelled),
                    Truth::Sky => t.sky_labelled += usize::from(labelled),
                    Truth::Correct => {}
                }
            }
        }
    }
    let accuracy = t.right as f64 / t.labelled as f64;
    let share = t.labelled as f64 / t.surface as f64;
    let summary = LabelSummary::of(&labels);
    println!("{t:?}");
    println!(
        "label accuracy {:.2}% at {:.1}% of the surface pixels labelled; positives {}, negatives voted {}, missing {}",
        100.0 * accuracy,
        100.0 * share,
        summary.positive,
        summary.negative_voted,
        summary.negative_missing
    );
    assert!(accuracy >= 0.98, "accuracy {accuracy}");
    assert!(share >= 0.30, "labelled share {share}");
    assert!(t.pos_wrong as f64 <= 0.01 * t.pos_right as f64, "{t:?}");
    assert!(
        t.wrong_neg as f64 >= 0.5 * t.wrong_px as f64,
        "wrong-depth blobs: {t:?}"
    );
    assert!(
        t.hole_neg as f64 >= 0.3 * t.hole_px as f64,
        "visible holes: {t:?}"
    );
    assert_eq!(
        t.invisible_labelled, 0,
        "holes not visible in all three must stay unlabelled"
    );
    assert_eq!(t.sky_labelled, 0);
    assert_eq!(summary.negative_missing, t.hole_neg);
}
