//! vp-mvs on one triplet of rendered, textured views of a procedural site:
//! the full pipeline (PatchMatch on each view against the other two, the
//! geometric filter, fusion). Prints seconds per triplet and megapixel-
//! hypotheses per second.
//!
//! Tiers: `fast` (256x256, 2 iterations) and `paper` (1024x1024, default
//! parameters, coarse-to-fine), with `paper_single_scale` beside it (the
//! same without the half-resolution level; the printed ratio is what
//! coarse-to-fine buys). `cargo bench --bench mvs -- --test` runs only the
//! fast tier once (set VPCTL_BENCH_FULL=1 to include the paper tiers); a
//! plain `cargo bench --bench mvs` runs all.
//!
//! `VPCTL_BENCH_MVS_CONFIG=<file.toml>` times the paper tiers with the
//! parameters of that file (what `vpctl mvs run --config`
//! reads, e.g. `fine_iterations = 1`) instead of the defaults, so that
//! a schedule can be timed in turn with the default on one binary.
//!
//! Lives in the workspace's benches (not `crates/mvs/benches`) because the
//! textured images come from vp-sim's renderer, which vp-mvs must not
//! depend on.

use std::hint::black_box;
use std::time::{Duration, Instant};

use criterion::{criterion_group, criterion_main, Criterion};
use nalgebra::{Point3, Vector3};
use vpctl_suite::mvs::{reconstruct, MvsParams, Output, View};
use vpctl_suite::scene::procedural::{generate_site, Site, SiteParams};
use vpctl_suite::scene::raycast::RayCaster;
use vpctl_suite::scene::{Camera, Intrinsics};
use vpctl_suite::sim::{render, RenderParams};

/// Three views of the rock, 26 m away at 55 deg elevation, about 12 deg
/// apart (triangulation angle at the rock top).
fn triplet(site: &Site, caster: &RayCaster, size: u32) -> Vec<View> {
    let k = Intrinsics::from_hfov(size, size, 60.0).expect("valid intrinsics");
    let rb = site.rock_bounds;
    let focus = Point3::new(
        0.5 * (rb.min.x + rb.max.x),
        0.5 * (rb.min.y + rb.max.y),
        rb.max.z,
    );
    let el = 55f64.to_radians();
    let v = Vector3::new(el.cos(), 0.0, el.sin());
    let u1 = v.cross(&Vector3::z()).normalize();
    let u2 = v.cross(&u1);
    let beta = (12.0f64 / 3f64.sqrt()).to_radians();
    [90.0f64, 210.0, 330.0]
        .iter()
        .enumerate()
        .map(|(i, phi)| {
            let p = phi.to_radians();
            let dir = (v + beta.tan() * (p.cos() * u1 + p.sin() * u2)).normalize();
            let cam = Camera::look_at(k, focus + 26.0 * dir, focus).expect("valid camera");
            let r = render(&site.mesh, caster, &cam, &RenderParams::default()).expect("render");
            View::new(&format!("v{i}"), cam, r.rgb, (12.0, 45.0)).expect("valid view")
        })
        .collect()
}

/// CPU seconds of this process so far (user + system, Linux only): on a
/// shared machine CPU time says more than wall time about the code.
fn cpu_seconds() -> Option<f64> {
    let stat = std::fs::read_to_string("/proc/self/stat").ok()?;
    // Fields after the command name, which is in parentheses: utime and
    // stime are the 12th and 13th, in clock ticks (100 per second).
    let rest = stat.rsplit_once(')')?.1;
    let mut f = rest.split_whitespace().skip(11);
    let utime: f64 = f.next()?.parse().ok()?;
    let stime: f64 = f.next()?.parse().ok()?;
    Some((utime + stime) / 100.0)
}

/// FNV-1a over the bits of every map (depth, normal, cost) and fused
/// point: equal checksums before and after a speed-up show that it kept
/// the results bit for bit.
fn checksum(out: &Output) -> u64 {
    let mut hash = 0xcbf2_9ce4_8422_2325u64;
    let mut eat = |bits: u64| {
        hash ^= bits;
        hash = hash.wrapping_mul(0x0100_0000_01b3);
    };
    for map in out.photometric.iter().chain(&out.geometric).flatten() {
        for ((d, n), c) in map.depth.iter().zip(&map.normal).zip(&map.cost) {
            for v in [*d, n[0], n[1], n[2], *c] {
                eat(u64::from(v.to_bits()));
            }
        }
    }
    for p in &out.fused {
        for v in p.position.iter().chain(p.normal.iter()) {
            eat(v.to_bits());
        }
        eat(p.n_pixels as u64);
    }
    hash
}

fn sources() -> Vec<Vec<usize>> {
    vec![vec![1, 2], vec![0, 2], vec![0, 1]]
}

fn tier(
    c: &mut Criterion,
    site: &Site,
    caster: &RayCaster,
    name: &str,
    size: u32,
    params: &MvsParams,
) -> f64 {
    let views = triplet(site, caster, size);
    // One timed run first, for the figures criterion does not print.
    let (start, cpu_start) = (Instant::now(), cpu_seconds());
    let out = reconstruct(&views, &sources(), params, &mut |_| {}).expect("reconstruct");
    let secs = start.elapsed().as_secs_f64();
    let cpu = cpu_seconds().zip(cpu_start).map(|(b, a)| b - a);
    let px = 3.0 * f64::from(size) * f64::from(size);
    // Hypotheses considered per pixel and pass: 1 initial + (4 propagated +
    // 3 refined) per iteration, 1 refined in a pass that starts from solved
    // planes unless `seeded_random_candidates` (an upper bound: repeated
    // planes and hypotheses that provably lose are not scored); a level
    // counts a quarter of the finer one; the geometric pass runs
    // `geom_iterations` at full resolution from the photometric result.
    let per_pass = |it: u32, seeded: bool| {
        let refined = if seeded && !params.seeded_random_candidates {
            1.0
        } else {
            3.0
        };
        1.0 + (4.0 + refined) * f64::from(it)
    };
    // Halvings that keep `coarse_min_size` (as `Problem::solve` decides).
    let levels = (1..=params.coarse_levels)
        .take_while(|&l| size >> l >= params.coarse_min_size)
        .count() as i32;
    let photometric = 0.25f64.powi(levels) * per_pass(params.iterations, false)
        + (0..levels)
            .map(|l| 0.25f64.powi(l) * per_pass(params.fine_iterations, true))
            .sum::<f64>();
    let geometric = if params.geom_consistency {
        per_pass(params.geom_iterations, true)
    } else {
        0.0
    };
    let hyps = px * (photometric + geometric);
    let samples = params.window_sample_count() as f64 * 2.0;
    eprintln!(
        "mvs/{name}: {size}x{size} triplet: {secs:.2} s per triplet ({:.2} s per Mpx triplet; \
         CPU {}), {:.2} Mpx-hypotheses/s, {:.0} M window samples/s (x2 sources), {} fused points, \
         {} threads, output checksum {:016x}",
        secs * 1e6 / (f64::from(size) * f64::from(size)),
        cpu.map_or("unknown".to_string(), |c| format!("{c:.2} s")),
        hyps / secs / 1e6,
        hyps * samples / secs / 1e6,
        out.fused.len(),
        rayon::current_num_threads(),
        checksum(&out)
    );
    let mut group = c.benchmark_group("mvs");
    group.sample_size(10);
    group.measurement_time(Duration::from_secs(if size > 512 { 60 } else { 10 }));
    group.bench_function(name, |b| {
        b.iter(|| {
            black_box(reconstruct(&views, &sources(), params, &mut |_| {}).expect("reconstruct"))
        });
    });
    group.finish();
    secs
}

fn mvs(c: &mut Criterion) {
    let site = generate_site(&SiteParams {
        seed: 1,
        target_faces: 200_000,
        ..SiteParams::default()
    })
    .expect("site generation with default parameters");
    let caster = RayCaster::new(&site.mesh);
    let fast = MvsParams {
        iterations: 2,
        ..MvsParams::default()
    };
    tier(c, &site, &caster, "fast_256", 256, &fast);
    let test_mode = std::env::args().any(|a| a == "--test");
    if !test_mode || std::env::var_os("VPCTL_BENCH_FULL").is_some() {
        let params = paper_params();
        let multi = tier(c, &site, &caster, "paper_1024", 1024, &params);
        let single = MvsParams {
            coarse_levels: 0,
            ..params
        };
        let one = tier(c, &site, &caster, "paper_single_scale_1024", 1024, &single);
        eprintln!(
            "mvs: coarse-to-fine is {:.2}x the speed of single scale",
            one / multi
        );
    }
}

/// The paper tiers' parameters: the defaults, or those of the file named
/// by `VPCTL_BENCH_MVS_CONFIG` (see the module docs).
fn paper_params() -> MvsParams {
    let Some(path) = std::env::var_os("VPCTL_BENCH_MVS_CONFIG") else {
        return MvsParams::default();
    };
    let path = std::path::Path::new(&path);
    let text = std::fs::read_to_string(path).unwrap_or_else(|e| {
        panic!(
            "VPCTL_BENCH_MVS_CONFIG: cannot read {}: {e}",
            path.display()
        )
    });
    let params =
        MvsParams::from_toml(&text, path).unwrap_or_else(|e| panic!("VPCTL_BENCH_MVS_CONFIG: {e}"));
    eprintln!("mvs: paper tiers with the parameters of {}", path.display());
    params
}

criterion_group!(benches, mvs);
criterion_main!(benches);
