//! Closest-hit or occlusion throughput of vp-scene's ray caster on a mesh
//! file and a ray file, for the peer comparison in
//! `benches/peer/raycast_vs_embree.py`.
//!
//! Usage: `raycast_peer MESH RAYS THREADS REPEATS OUT [occluded LEN]`
//! - RAYS: little-endian f32, 6 per ray (origin xyz, unit direction xyz);
//! - OUT: closest hit: one little-endian f32 per ray, the hit distance or
//!   infinity for a miss; with `occluded LEN`: one byte per ray, 1 if the
//!   segment from the origin to LEN metres along the ray is occluded (to
//!   check that both engines agree).
//!
//! Prints one line per repeat: `rays_per_s=<value>`.

use std::time::Instant;

use anyhow::{ensure, Context, Result};
use nalgebra::{Point3, Vector3};
use vpctl_suite::scene::io::read_mesh;
use vpctl_suite::scene::raycast::RayCaster;

fn main() -> Result<()> {
    let args: Vec<String> = std::env::args().collect();
    ensure!(
        args.len() == 6 || (args.len() == 8 && args[6] == "occluded"),
        "usage: raycast_peer MESH RAYS THREADS REPEATS OUT [occluded LEN]"
    );
    let segment_len: Option<f64> = match args.get(7) {
        Some(s) => Some(s.parse().context("LEN")?),
        None => None,
    };
    let mesh = read_mesh(args[1].as_ref())?;
    let bytes = std::fs::read(&args[2]).with_context(|| format!("reading {}", args[2]))?;
    ensure!(
        bytes.len() % 24 == 0,
        "{}: size is not a multiple of 24 bytes",
        args[2]
    );
    let threads: usize = args[3].parse().context("THREADS")?;
    let repeats: usize = args[4].parse().context("REPEATS")?;
    let f = |i: usize| {
        f64::from(f32::from_le_bytes([
            bytes[i],
            bytes[i + 1],
            bytes[i + 2],
            bytes[i + 3],
        ]))
    };
    let rays: Vec<(Point3<f64>, Vector3<f64>)> = (0..bytes.len() / 24)
        .map(|r| {
            let b = r * 24;
            (
                Point3::new(f(b), f(b + 4), f(b + 8)),
                Vector3::new(f(b + 12), f(b + 16), f(b + 20)),
            )
        })
        .collect();
    let caster = RayCaster::new(&mesh);
    let pool = rayon::ThreadPoolBuilder::new()
        .num_threads(threads)
        .build()?;
    let mut out = Vec::new();
    if let Some(len) = segment_len {
        let segments: Vec<(Point3<f64>, Point3<f64>)> =
            rays.iter().map(|(o, d)| (*o, o + d * len)).collect();
        for _ in 0..repeats {
            let t0 = Instant::now();
            let occluded = pool.install(|| caster.occluded_batch(&segments));
            let dt = t0.elapsed().as_secs_f64();
            println!("rays_per_s={:.0}", rays.len() as f64 / dt);
            out = occluded.iter().map(|&o| u8::from(o)).collect();
        }
    } else {
        for _ in 0..repeats {
            let t0 = Instant::now();
            let hits = pool.install(|| caster.closest_hits(&rays, f64::INFINITY));
            let dt = t0.elapsed().as_secs_f64();
            println!("rays_per_s={:.0}", rays.len() as f64 / dt);
            out = hits
                .iter()
                .flat_map(|h| h.map_or(f32::INFINITY, |h| h.t as f32).to_le_bytes())
                .collect();
        }
    }
    std::fs::write(&args[5], out).with_context(|| format!("writing {}", args[5]))?;
    Ok(())
}
