//! Time of the semi-global matcher alone (census, costs, aggregation,
//! winner-take-all, left-right check, speckle filter) on a rectified pair:
//! no process start, file reading, rectification or depth maps.
//!
//! - `sgm/synthetic_640x480x64/{4,8}paths`: a textured pair made here.
//! - With `VP_SGM_PAIR=LEFT.png,RIGHT.png,MIN_DISPARITY,NUM_DISPARITIES[,RUNS]`
//!   it times that pair instead, RUNS times (default 1) after one
//!   unmeasured run, and prints one line `sgm_match_seconds S` per run, for
//!   `benches/peer/sgm_vs_sgbm.py`, which alternates it with StereoSGBM's
//!   `compute()` on the same pair. `VP_SGM_PATHS=4` takes 4 paths; with
//!   `VP_SGM_OUT=FILE` the disparities go to FILE (raw little-endian f32,
//!   row-major, NaN where none).
//!
//! Run: `cargo bench --workspace --locked --bench sgm -- --quick`

use std::hint::black_box;
use std::time::Instant;

use criterion::{criterion_group, Criterion};
use vp_mvs::sgm::rectified_disparity;
use vp_mvs::{GreyImage, SgmParams};

/// The grey image vp-mvs matches (Rec. 601 luma, as `View` makes it).
fn grey(path: &str) -> GreyImage {
    let img = image::open(path)
        .unwrap_or_else(|e| panic!("{path}: {e}"))
        .to_rgb8();
    GreyImage::from_rgb(&img)
}

/// Hashed value noise, smooth over ~`cell` pixels.
fn texture(x: f64, y: f64, cell: f64) -> f32 {
    let (qx, qy) = (x / cell, y / cell);
    let (fx, fy) = (qx.floor(), qy.floor());
    let h = |i: f64, j: f64| {
        let v =
            ((i as i64).wrapping_mul(0x9E37_79B9) ^ (j as i64).wrapping_mul(0x85EB_CA6B)) as u64;
        (v.wrapping_mul(0x2545_F491_4F6C_DD1D) >> 40) as f64 / f64::from(1u32 << 24)
    };
    let (ax, ay) = (qx - fx, qy - fy);
    let top = h(fx, fy) * (1.0 - ax) + h(fx + 1.0, fy) * ax;
    let bottom = h(fx, fy + 1.0) * (1.0 - ax) + h(fx + 1.0, fy + 1.0) * ax;
    (top * (1.0 - ay) + bottom * ay) as f32
}

/// A 640x480 pair whose disparity ramps from 10 to 50 px down the image.
fn synthetic() -> (GreyImage, GreyImage) {
    let (w, h) = (640u32, 480u32);
    let make = |shift: bool| GreyImage {
        width: w,
        height: h,
        data: (0..w * h)
            .map(|i| {
                let (x, y) = (f64::from(i % w), f64::from(i / w));
                let d = if shift {
                    10.0 + 40.0 * y / f64::from(h)
                } else {
                    0.0
                };
                texture(x + d, y, 2.5)
            })
            .collect(),
    };
    (make(false), make(true))
}

fn bench(c: &mut Criterion) {
    let (left, right) = synthetic();
    let mut g = c.benchmark_group("sgm/synthetic_640x480x64");
    g.sample_size(10);
    for paths in [4, 8] {
        let params = SgmParams {
            paths,
            ..SgmParams::default()
        };
        g.bench_function(format!("{paths}paths"), |b| {
            b.iter(|| black_box(rectified_disparity(&left, &right, 4, 64, &params).unwrap()));
        });
    }
    g.finish();
}

criterion_group!(benches, bench);

/// The `VP_SGM_PAIR` mode (see the module doc).
fn time_pair(spec: &str) {
    let parts: Vec<&str> = spec.split(',').collect();
    assert!(
        parts.len() == 4 || parts.len() == 5,
        "VP_SGM_PAIR=LEFT,RIGHT,MIN_DISPARITY,NUM_DISPARITIES[,RUNS], not {spec}"
    );
    let (left, right) = (grey(parts[0]), grey(parts[1]));
    let min_d: i32 = parts[2].parse().expect("MIN_DISPARITY: an integer");
    let n: usize = parts[3].parse().expect("NUM_DISPARITIES: an integer");
    let runs: usize = parts
        .get(4)
        .map_or(1, |r| r.parse().expect("RUNS: an integer"));
    let params = SgmParams {
        paths: std::env::var("VP_SGM_PATHS")
            .map_or(8, |p| p.parse().expect("VP_SGM_PATHS: 4 or 8")),
        max_disparities: 4096,
        ..SgmParams::default()
    };
    let mut disp = rectified_disparity(&left, &right, min_d, n, &params).expect("a matchable pair");
    for _ in 0..runs {
        let t0 = Instant::now();
        disp = rectified_disparity(&left, &right, min_d, n, &params).expect("a matchable pair");
        println!("sgm_match_seconds {:.6}", t0.elapsed().as_secs_f64());
    }
    if let Ok(out) = std::env::var("VP_SGM_OUT") {
        let bytes: Vec<u8> = disp.iter().flat_map(|d| d.to_le_bytes()).collect();
        std::fs::write(&out, bytes).unwrap_or_else(|e| panic!("{out}: {e}"));
    }
}

fn main() {
    if let Ok(spec) = std::env::var("VP_SGM_PAIR") {
        time_pair(&spec);
        return;
    }
    benches();
    Criterion::default().configure_from_args().final_summary();
}
