//! A procedural world with known truth for the labelgen tests: a terrain with
//! a building, posed triplets, and depthmaps synthesised from the true
//! surface with injected errors (noise, blobs of wrong depth, holes).
#![allow(dead_code)]

use nalgebra::{Point2, Point3};
use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;
use vp_labelgen::{TripletReconstruction, View};
use vp_scene::colmap::DepthMap;
use vp_scene::procedural::{box_mesh, heightfield};
use vp_scene::raycast::RayCaster;
use vp_scene::triangulation::{point_covariance, sigma_along};
use vp_scene::{Camera, Intrinsics, Mesh};

/// What a pixel of a synthesised depthmap really is.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Truth {
    /// No surface along the ray.
    Sky,
    /// Correct depth (small noise).
    Correct,
    /// A blob of wrong depth.
    Wrong,
    /// A hole where the surface is visible in all three images.
    HoleVisible,
    /// A hole where the surface is not visible in all three images.
    HoleInvisible,
}

pub struct World {
    pub mesh: Mesh,
    pub caster: RayCaster,
}

pub fn world() -> World {
    let mut mesh = heightfield(50, 50, 2.0, |x, y| {
        2.0 * (x / 15.0).sin() * (y / 12.0).cos()
    });
    mesh.append(&box_mesh(
        Point3::new(4.0, -14.0, -1.0),
        Point3::new(12.0, -6.0, 7.0),
    ));
    let caster = RayCaster::new(&mesh);
    World { mesh, caster }
}

/// Cameras of an equilateral triplet centred above (cx, cy) at height `h`,
/// all looking at the ground point below the centre, with triangulation
/// angle about `angle_deg` there.
pub fn triplet_cameras(
    cx: f64,
    cy: f64,
    h: f64,
    angle_deg: f64,
    rot: f64,
    k: Intrinsics,
) -> [Camera; 3] {
    let r = 2.0 * h * (0.5 * angle_deg.to_radians()).tan() / 3f64.sqrt();
    let target = Point3::new(cx, cy, 0.0);
    std::array::from_fn(|i| {
        let a = rot + i as f64 * 2.0 * std::f64::consts::PI / 3.0;
        let c = Point3::new(cx + r * a.cos(), cy + r * a.sin(), h);
        Camera::look_at(k, c, target).unwrap()
    })
}

/// Whether `x` is visible (in frame, unoccluded) from `cam`.
pub fn visible(world: &World, cam: &Camera, x: &Point3<f64>) -> bool {
    let to_cam = cam.center() - x;
    let dist = to_cam.norm();
    let lifted = x + to_cam * (1e-3f64.max(1e-4 * dist) / dist);
    cam.project_in_frame(x).is_some() && !world.caster.occluded(&cam.center(), &lifted)
}

/// Error injection of the synthetic MVS.
#[derive(Debug, Clone, Copy)]
pub struct Errors {
    /// Blobs of wrong depth per image.
    pub blobs: usize,
    /// Holes per image.
    pub holes: usize,
    /// Blob and hole radius, share of the image width.
    pub radius: f64,
    /// Depth noise, in units of the triplet's sigma along the ray.
    pub noise_sigma: f64,
}

impl Default for Errors {
    fn default() -> Self {
        Errors {
            blobs: 2,
            holes: 2,
            radius: 0.07,
            noise_sigma: 0.3,
        }
    }
}

fn gauss(rng: &mut ChaCha8Rng) -> f64 {
    let u1: f64 = rng.random::<f64>().max(1e-12);
    let u2: f64 = rng.random();
    (-2.0 * u1.ln()).sqrt() * (2.0 * std::f64::consts::PI * u2).cos()
}

/// A reconstruction of `cams` (named `names`) at `scale` of their resolution,
/// with the truth of each pixel.
pub fn reconstruct(
    world: &World,
    id: &str,
    names: [&str; 3],
    cams: &[Camera; 3],
    scale: f64,
    errors: Errors,
    seed: u64,
) -> (TripletReconstruction, [Vec<Truth>; 3]) {
    let mut rng = ChaCha8Rng::seed_from_u64(seed);
    let scaled: [Camera; 3] =
        cams.map(|c| Camera::new(c.intrinsics.scaled(scale), c.world_from_cam));
    let mut truths = Vec::new();
    let mut views = Vec::new();
    for (v, cam) in scaled.iter().enumerate() {
        let (depth, _) = world.caster.render_depth(cam);
        let (w, h) = (
            cam.intrinsics.width as usize,
            cam.intrinsics.height as usize,
        );
        let rad = errors.radius * w as f64;
        let disk = |rng: &mut ChaCha8Rng| {
            (
                rng.random::<f64>() * w as f64,
                rng.random::<f64>() * h as f64,
            )
        };
        let blobs: Vec<((f64, f64), f64)> = (0..errors.blobs)
            .map(|_| (disk(&mut rng), if rng.random::<bool>() { 0.7 } else { 1.3 }))
            .collect();
        let holes: Vec<(f64, f64)> = (0..errors.holes).map(|_| disk(&mut rng)).collect();
        let inside = |c: &(f64, f64), x: usize, y: usize| {
            let (dx, dy) = (x as f64 + 0.5 - c.0, y as f64 + 0.5 - c.1);
            dx * dx + dy * dy <= rad * rad
        };
        let mut out = vec![0f32; w * h];
        let mut truth = vec![Truth::Sky; w * h];
        for y in 0..h {
            for x in 0..w {
                let i = y * w + x;
                let d = f64::from(depth[i]);
                if d <= 0.0 {
                    continue;
                }
                let px = Point2::new(x as f64 + 0.5, y as f64 + 0.5);
                let p = cam.unproject(&px, d);
                let all = scaled
                    .iter()
                    .enumerate()
                    .all(|(j, c)| j == v || visible(world, c, &p));
                if !all {
                    truth[i] = Truth::HoleInvisible;
                    continue;
                }
                if holes.iter().any(|c| inside(c, x, y)) {
                    truth[i] = Truth::HoleVisible;
                    continue;
                }
                let (_, dir) = cam.ray(&px);
                let sigma =
                    point_covariance(&scaled, &p, 1.0).map_or(0.0, |cov| sigma_along(&cov, &dir));
                let ray_len = d / dir.dot(&cam.axis());
                if let Some((_, f)) = blobs.iter().find(|(c, _)| inside(c, x, y)) {
                    // Wrong means wrong beyond what the triplet's geometry can
                    // resolve: 6 sigma along the ray plus 10% of the distance.
                    truth[i] = Truth::Wrong;
                    let offset = (6.0 * sigma + 0.1 * ray_len).min(0.8 * ray_len);
                    let wrong = if *f > 1.0 {
                        ray_len + offset
                    } else {
                        ray_len - offset
                    };
                    out[i] = (wrong * dir.dot(&cam.axis())) as f32;
                    continue;
                }
                let noisy = ray_len + gauss(&mut rng) * errors.noise_sigma * sigma;
                out[i] = (noisy * dir.dot(&cam.axis())) as f32;
                truth[i] = Truth::Correct;
            }
        }
        truths.push(truth);
        views.push(View {
            name: names[v].to_string(),
            camera: *cam,
            depth: DepthMap {
                width: w as u32,
                height: h as u32,
                data: out,
            },
        });
    }
    let views: [View; 3] = views.try_into().unwrap();
    let truths: [Vec<Truth>; 3] = truths.try_into().unwrap();
    (
        TripletReconstruction {
            id: id.to_string(),
            views,
        },
        truths,
    )
}

/// The standard test set: `n` triplets over the site at levels 1..=levels,
/// with triangulation angles cycling through 6..40 deg.
pub fn scene(
    world: &World,
    n: usize,
    levels: u32,
    width: u32,
    errors: Errors,
) -> (Vec<TripletReconstruction>, Vec<[Vec<Truth>; 3]>) {
    let k = Intrinsics::from_hfov(width, width * 3 / 4, 60.0).unwrap();
    let angles = [6.0, 12.0, 20.0, 30.0, 40.0];
    let mut recs = Vec::new();
    let mut truths = Vec::new();
    for t in 0..n {
        let cx = -12.0 + 12.0 * (t % 3) as f64;
        let cy = -12.0 + 12.0 * ((t / 3) % 3) as f64;
        let h = 35.0 + 5.0 * (t % 2) as f64;
        let cams = triplet_cameras(cx, cy, h, angles[t % angles.len()], 0.3 * t as f64, k);
        let names = [0, 1, 2].map(|i| format!("img_{t:02}_{i}.jpg"));
        for level in 1..=levels {
            let scale = 0.5f64.powi(level as i32 - 1);
            let (rec, truth) = reconstruct(
                world,
                &format!("t{t:04}/level{level}"),
                [&names[0], &names[1], &names[2]],
                &cams,
                scale,
                errors,
                1000 * t as u64 + u64::from(level),
            );
            recs.push(rec);
            truths.push(truth);
        }
    }
    (recs, truths)
}
