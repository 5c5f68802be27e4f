//! Label generation split into independent tasks (stage 1 per chunk of
//! queries, then stages 2-3 per chunk, as on separate Dask workers) gives
//! the labels and summary of one `generate_labels` call.

mod common;

use common::{scene, world, Errors};
use vp_labelgen::{
    generate_labels, labels_for, references_of, support_for, LabelParams, LabelSummary,
    MissingPartMeshes, ReconLabels,
};

/// (x, y, label, angle bits) of every labelled pixel of one view.
type Pixels = Vec<(u32, u32, u8, u32)>;

fn flat(labels: &[ReconLabels]) -> Vec<(String, Pixels)> {
    labels
        .iter()
        .flat_map(|rl| {
            rl.labels.iter().zip(&rl.names).map(move |(img, name)| {
                let px = img
                    .labelled()
                    .map(|(x, y, l, a)| (x, y, l as u8, a.to_bits()))
                    .collect();
                (format!("{}/{name}", rl.id), px)
            })
        })
        .collect()
}

#[test]
fn labels_generated_in_chunks_equal_one_call() {
    let w = world();
    let (recs, _) = scene(&w, 6, 2, 64, Errors::default());
    let params = LabelParams::default();
    let meshes = MissingPartMeshes::new(&w.mesh, params.mesh_iterations);
    let whole = generate_labels(&recs, Some(&meshes), &params).unwrap();

    let mut ids: Vec<String> = recs.iter().map(|r| r.id.clone()).collect();
    ids.reverse();
    let chunks: Vec<&[String]> = ids.chunks(5).collect();
    let supports: Vec<_> = chunks
        .iter()
        .flat_map(|c| support_for(&recs, c, &params).unwrap())
        .collect();
    let mut parts: Vec<ReconLabels> = Vec::new();
    let mut summaries = Vec::new();
    for c in &chunks {
        let l = labels_for(&recs, &supports, c, Some(&meshes), &params).unwrap();
        summaries.push(LabelSummary::of(&l));
        parts.extend(l);
    }
    parts.sort_by(|a, b| a.id.cmp(&b.id));
    assert!(whole.iter().zip(&parts).all(|(a, b)| a.counts == b.counts));
    assert_eq!(flat(&whole), flat(&parts));
    assert_eq!(LabelSummary::combine(&summaries), LabelSummary::of(&whole));
    assert!(LabelSummary::of(&whole).positive > 0);

    // Each query needs exactly its references' support.
    let refs = references_of(&recs, &params).unwrap();
    assert_eq!(refs.len(), recs.len());
    for (id, r) in &refs {
        let needed: Vec<_> = supports
            .iter()
            .filter(|(s, _)| r.contains(s))
            .cloned()
            .collect();
        let one = labels_for(&recs, &needed, std::slice::from_ref(id), None, &params).unwrap();
        assert_eq!(one.len(), 1);
    }
    // A chunk without the support of its references is refused, by name.
    let e = labels_for(&recs, &supports[..1], &ids[..1], None, &params)
        .unwrap_err()
        .to_string();
    assert!(
        e.contains("needs the stage-1 support of its reference"),
        "{e}"
    );
    let e = support_for(&recs, &["t9999/level1".to_string()], &params)
        .unwrap_err()
        .to_string();
    assert!(e.contains("t9999/level1"), "{e}");
}
