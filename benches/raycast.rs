//! Ray casting throughput on a ~200k-face procedural site: BVH build time,
//! closest-hit and occlusion rays per second (1M rays), on 1 and 2 threads.
//!
//! Run: `cargo bench --bench raycast`. Criterion prints the throughput as
//! `thrpt: ... Melem/s` (million rays per second).

use std::hint::black_box;
use std::time::Duration;

use criterion::{criterion_group, criterion_main, Criterion, Throughput};
use nalgebra::{Point3, Vector3};
use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;
use vpctl_suite::scene::procedural::{generate_site, SiteParams};
use vpctl_suite::scene::raycast::RayCaster;

const N_RAYS: usize = 1_000_000;

/// Rays as a UAV camera casts them: from 10-50 m above the site towards
/// random points of its footprint.
fn aerial_rays(
    site_min: Point3<f64>,
    site_max: Point3<f64>,
    seed: u64,
) -> Vec<(Point3<f64>, Vector3<f64>)> {
    let mut rng = ChaCha8Rng::seed_from_u64(seed);
    (0..N_RAYS)
        .map(|_| {
            let o = Point3::new(
                rng.random_range(site_min.x..site_max.x),
                rng.random_range(site_min.y..site_max.y),
                site_max.z + rng.random_range(10.0..50.0),
            );
            let t = Point3::new(
                rng.random_range(site_min.x..site_max.x),
                rng.random_range(site_min.y..site_max.y),
                site_min.z,
            );
            (o, (t - o).normalize())
        })
        .collect()
}

fn raycast(c: &mut Criterion) {
    let site = generate_site(&SiteParams {
        seed: 1,
        target_faces: 200_000,
        ..SiteParams::default()
    })
    .expect("site generation with default parameters");
    let mesh = &site.mesh;
    let bounds = mesh.bounds();
    eprintln!("site: {} faces", mesh.n_faces());

    let mut group = c.benchmark_group("bvh");
    group
        .sample_size(10)
        .measurement_time(Duration::from_secs(5));
    group.bench_function("build_200k", |b| b.iter(|| black_box(RayCaster::new(mesh))));
    group.finish();

    let caster = RayCaster::new(mesh);
    let rays = aerial_rays(bounds.min, bounds.max, 7);
    let segments: Vec<(Point3<f64>, Point3<f64>)> =
        rays.iter().map(|(o, d)| (*o, o + d * 40.0)).collect();

    for threads in [1, 2] {
        let pool = rayon::ThreadPoolBuilder::new()
            .num_threads(threads)
            .build()
            .expect("thread pool");
        let mut group = c.benchmark_group(format!("rays_{threads}_threads"));
        group
            .sample_size(10)
            .measurement_time(Duration::from_secs(8))
            .throughput(Throughput::Elements(N_RAYS as u64));
        group.bench_function("closest_hit_1M", |b| {
            b.iter(|| pool.install(|| black_box(caster.closest_hits(&rays, f64::INFINITY))));
        });
        group.bench_function("occlusion_1M", |b| {
            b.iter(|| pool.install(|| black_box(caster.occluded_batch(&segments))));
        });
        group.finish();
    }
}

criterion_group!(benches, raycast);
criterion_main!(benches);
