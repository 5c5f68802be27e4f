//! Time per triplet at 1 Mpx (ignored by default: run with
//! `cargo test -p vp-labelgen --release --test timing -- --ignored --nocapture`;
//! `VP_TIMING_TRIPLETS=n` sets the number of triplets, default 6).

mod common;

use std::time::Instant;

use common::{scene, world, Errors};
use vp_labelgen::{generate_labels, LabelParams, LabelSummary, MissingPartMeshes};

#[test]
#[ignore = "measurement, not a check; takes a minute"]
fn time_per_triplet_at_one_megapixel() {
    let w = world();
    let n: usize = std::env::var("VP_TIMING_TRIPLETS")
        .ok()
        .and_then(|s| s.parse().ok())
        .unwrap_or(6);
    let (recs, _) = scene(&w, n, 3, 1152, Errors::default());
    let params = LabelParams::default();
    let meshes = MissingPartMeshes::new(&w.mesh, params.mesh_iterations);
    let start = Instant::now();
    let labels = generate_labels(&recs, Some(&meshes), &params).unwrap();
    let secs = start.elapsed().as_secs_f64();
    let s = LabelSummary::of(&labels);
    println!(
        "{n} triplets x 3 levels (1152x864 at level 1), {} threads: {secs:.2} s, {:.2} s per triplet; labelled share {:.3}",
        rayon::current_num_threads(),
        secs / n as f64,
        s.labelled_share
    );
}
