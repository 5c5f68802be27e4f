//! Planning at the paper's parameters (N_t 2000, N_p 5000, N_v 200, b 9,
//! phi 120 deg, k 4) on a ~200k-face procedural site with 18 initial
//! cameras (a 50 m nadir grid, as the paper's 19). Prints the time per
//! module and per triplet of three calls, then lets criterion time whole calls.
//!
//! `cargo bench -p vp-planner -- --quick`

use std::hint::black_box;
use std::time::Duration;

use criterion::{criterion_group, criterion_main, Criterion};
use vp_planner::{plan, AcquiredView, PlanInputs, PlannerConfig, RoiSpec};
use vp_scene::procedural::{generate_site, SiteParams};
use vp_scene::roi::Roi;
use vp_test_support::rock::initial_views;

fn bench(c: &mut Criterion) {
    let site = generate_site(&SiteParams {
        seed: 1,
        target_faces: 200_000,
        ..SiteParams::default()
    })
    .expect("site");
    let acquired: Vec<AcquiredView> = initial_views(&site);
    let v = site.flight_volume;
    let cfg = PlannerConfig {
        flight_volume: Some([v.min.into(), v.max.into()]),
        ..PlannerConfig::default()
    };
    let inputs = PlanInputs {
        mesh: &site.mesh,
        acquired: &acquired,
        roi: RoiSpec::Region(Roi::from_aabb(&site.rock_bounds)),
        config: &cfg,
        origin: None,
        observations: None,
        home: None,
    };
    let r = plan(&inputs).expect("plan");
    eprintln!(
        "paper parameters: {} faces, {} initial cameras, {} triplets, visited {:?}",
        site.mesh.n_faces(),
        acquired.len(),
        r.triplet_gains.len(),
        r.visited
    );
    eprintln!("  gains: {:?}", r.triplet_gains);
    // Three calls: the machine is shared, the smallest figures are the
    // least disturbed. "per triplet" is M1-M4 over k (the figure);
    // the call also builds the BVH and the free-space map.
    for _ in 0..3 {
        let r = plan(&inputs).expect("plan");
        let k = r.triplet_gains.len().max(1) as f64;
        let t = |m: &str| r.module_time_s.get(m).copied().unwrap_or(0.0);
        let modules = t("m1") + t("m2") + t("m3") + t("m4");
        eprintln!(
            "  {:.4} s per triplet (M1-M4 / k; target 0.05): m1 {:.4} m2 {:.4} m3 {:.4} m4 {:.4}, \
             free space {:.4}, whole call {:.4} s",
            modules / k,
            t("m1"),
            t("m2"),
            t("m3"),
            t("m4"),
            t("free_space"),
            r.plan.statistics.total_time_s.unwrap_or(0.0)
        );
    }
    let mut g = c.benchmark_group("paper");
    g.sample_size(10).measurement_time(Duration::from_secs(20));
    g.bench_function("plan_k4_200k_faces", |bch| {
        bch.iter(|| black_box(plan(&inputs).expect("plan")));
    });
    g.finish();
}

criterion_group!(benches, bench);
criterion_main!(benches);
