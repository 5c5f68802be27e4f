//! Rendering and virtual MVS on the default ~200k-face procedural site.
//!
//! - `render/1mpx_depth_only`: `RayCaster::render_depth` of the same view,
//!   the ray-casting floor the renderer's cost is measured against.
//! - `render/1mpx_shadows` and `render/1mpx_no_shadows`: one 1024x1024 image
//!   of an oblique camera 40 m from the rock (the budget: well under a
//!   second on 2 cores).
//! - `mvs/triplet_level{1,2,3}`: one virtual MVS reconstruction of a triplet of
//!   1024x1024 cameras (three depth maps) at each pyramid level.
//!
//! Run: `cargo bench -p vp-sim --bench render`.

use std::hint::black_box;
use std::time::Duration;

use criterion::{criterion_group, criterion_main, Criterion};
use nalgebra::Point3;
use vp_scene::procedural::{generate_site, SiteParams};
use vp_scene::raycast::RayCaster;
use vp_scene::{Camera, Intrinsics};
use vp_sim::{render, MvsProfile, RenderParams, VirtualMvs};

fn camera(at: Point3<f64>) -> Camera {
    let k = Intrinsics::from_hfov(1024, 1024, 60.0).expect("valid intrinsics");
    Camera::look_at(k, at, Point3::new(0.0, 0.0, 1.0)).expect("camera not vertical")
}

fn benches(c: &mut Criterion) {
    let site = generate_site(&SiteParams::default()).expect("default site");
    let caster = RayCaster::new(&site.mesh);
    let cam = camera(Point3::new(-25.0, -20.0, 25.0));
    let mut g = c.benchmark_group("render");
    g.sample_size(10).measurement_time(Duration::from_secs(8));
    // Baseline in the same run: the bare ray casting (depth and face ids).
    g.bench_function("1mpx_depth_only", |b| {
        b.iter(|| caster.render_depth(black_box(&cam)));
    });
    for (name, shadows) in [("1mpx_shadows", true), ("1mpx_no_shadows", false)] {
        let params = RenderParams {
            shadows,
            ..RenderParams::default()
        };
        g.bench_function(name, |b| {
            b.iter(|| render(&site.mesh, &caster, black_box(&cam), &params).expect("render"));
        });
    }
    g.finish();

    let mvs = VirtualMvs::new(MvsProfile::sure_like()).expect("valid profile");
    let triplet = [
        camera(Point3::new(-25.0, -20.0, 25.0)),
        camera(Point3::new(-21.0, -20.0, 25.0)),
        camera(Point3::new(-23.0, -16.5, 25.0)),
    ];
    let mut g = c.benchmark_group("mvs");
    g.sample_size(10).measurement_time(Duration::from_secs(8));
    for level in 1..=3u8 {
        g.bench_function(format!("triplet_level{level}"), |b| {
            b.iter(|| {
                mvs.reconstruct(
                    &site.mesh,
                    &caster,
                    [&triplet[0], &triplet[1], &triplet[2]],
                    level,
                    7,
                )
                .expect("reconstruct")
            });
        });
    }
    g.finish();
}

criterion_group!(render_benches, benches);
criterion_main!(render_benches);
