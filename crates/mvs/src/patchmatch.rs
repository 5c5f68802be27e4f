//! PatchMatch stereo for one reference image against its sources: random
//! initialisation, red-black checkerboard propagation of planes from
//! neighbours, random refinement of depth and normal.

use rayon::prelude::*;

use crate::cost::{aggregate, homography, source_cost, RefPatch, MAX_COST};
use crate::error::{MvsError, Result};
use crate::params::MvsParams;
use crate::rng::PixelRng;
use crate::view::{k_of, pixel_ray, GreyImage, Relative, View};

/// Most sources scored per hypothesis (a stack array holds their costs).
pub const MAX_SOURCES: usize = 32;

/// Neighbours a pixel takes plane hypotheses from: all at an odd Manhattan
/// distance, so they have the other checkerboard colour and stay fixed
/// while this colour is updated (Gipuma's pattern).
const NEIGHBOURS: [(i32, i32); 8] = [
    (0, -1),
    (0, 1),
    (-1, 0),
    (1, 0),
    (0, -5),
    (0, 5),
    (-5, 0),
    (5, 0),
];

/// A depth and normal map in the reference camera frame: PatchMatch's
/// photometric result, or that result after the geometric filter.
#[derive(Debug, Clone, PartialEq)]
pub struct DepthNormalMap {
    /// Width in pixels.
    pub width: u32,
    /// Height in pixels.
    pub height: u32,
    /// Depth along the optical axis; 0 where a filter (photometric:
    /// `min_ncc`; geometric: consistency) rejected the pixel.
    pub depth: Vec<f32>,
    /// Unit normal (camera frame); zero where depth is 0.
    pub normal: Vec<[f32; 3]>,
    /// Aggregated matching cost (1 - NCC, in [0, 2]) of the winning
    /// hypothesis, kept for every pixel.
    pub cost: Vec<f32>,
}

#[derive(Debug, Clone, Copy, PartialEq)]
struct Hyp {
    d: f32,
    n: [f32; 3],
    cost: f32,
}

/// What one reference's PatchMatch needs, in f32.
struct Problem<'a> {
    image: &'a GreyImage,
    k: [f32; 4],
    sources: Vec<(Relative, &'a GreyImage)>,
    range: (f32, f32),
    /// Cosine of the largest normal-to-view angle.
    min_cos: f32,
    top_k: usize,
    offsets: Vec<i32>,
    params: &'a MvsParams,
    view_key: u64,
}

/// Runs PatchMatch for `views[reference]` against `views[s]` for `s` in
/// `sources`.
///
/// # Performance
/// Per iteration each pixel scores 8 propagated and 3 refined hypotheses,
/// each against every source over the window samples (36 by default): that
/// product is the work. Rows run in parallel (rayon); the output does not
/// depend on the thread count.
pub fn patch_match(views: &[View], reference: usize, sources: &[usize], params: &MvsParams) -> Result<DepthNormalMap> {
    params.validate()?;
    let view = views.get(reference).ok_or_else(|| {
        MvsError::InvalidArgument(format!("reference view {reference} does not exist"))
    })?;
    if sources.is_empty() || sources.len() > MAX_SOURCES {
        return Err(MvsError::InvalidArgument(format!(
            "image '{}': {} source images (need 1 to {MAX_SOURCES})",
            view.name,
            sources.len()
        )));
    }
    let mut rel = Vec::with_capacity(sources.len());
    for &s in sources {
        let src = views.get(s).filter(|_| s != reference).ok_or_else(|| {
            MvsError::InvalidArgument(format!(
                "image '{}': source view {s} does not exist or is the reference",
                view.name
            ))
        })?;
        rel.push((Relative::new(&view.camera, &src.camera), &src.grey));
    }
    let problem = Problem {
        image: &view.grey,
        k: k_of(&view.camera),
        sources: rel,
        range: (view.depth_range.0 as f32, view.depth_range.1 as f32),
        min_cos: params.max_normal_view_angle_deg.to_radians().cos(),
        top_k: params.top_k_sources,
        offsets: params.window_offsets(),
        params,
        view_key: reference as u64,
    };
    Ok(problem.run())
}

impl Problem<'_> {
    fn run(&self) -> DepthNormalMap {
        let (w, h) = (self.image.width as usize, self.image.height as usize);
        let mut state: Vec<Hyp> = vec![
            Hyp {
                d: 0.0,
                n: [0.0, 0.0, -1.0],
                cost: MAX_COST,
            };
            w * h
        ];
        state.par_chunks_mut(w).enumerate().for_each(|(y, row)| {
            let mut patch = RefPatch::default();
            for (x, hyp) in row.iter_mut().enumerate() {
                let mut rng = PixelRng::new(self.params.seed, self.view_key, (y * w + x) as u64, 0);
                let ray = pixel_ray(&self.k, x, y);
                let d = self.random_depth(&mut rng);
                let n = random_normal(&mut rng, &ray);
                patch.build(self.image, x, y, &self.offsets, self.params);
                *hyp = Hyp {
                    d,
                    n,
                    cost: self.cost(&patch, x, y, &ray, d, &n),
                };
            }
        });
        for it in 0..self.params.iterations {
            for colour in 0..2 {
                let prev = state.clone();
                let step = 1 + 2 * u64::from(it) + colour as u64;
                state.par_chunks_mut(w).enumerate().for_each(|(y, row)| {
                    let mut patch = RefPatch::default();
                    let mut x = (y + colour) % 2;
                    while x < w {
                        row[x] = self.update(&prev, &mut patch, x, y, it, step);
                        x += 2;
                    }
                });
            }
        }
        let max_cost = 1.0 - self.params.min_ncc;
        let mut out = DepthNormalMap {
            width: w as u32,
            height: h as u32,
            depth: vec![0.0; w * h],
            normal: vec![[0.0; 3]; w * h],
            cost: vec![MAX_COST; w * h],
        };
        for (i, hyp) in state.iter().enumerate() {
            out.cost[i] = hyp.cost;
            if hyp.cost <= max_cost {
                out.depth[i] = hyp.d;
                out.normal[i] = hyp.n;
            }
        }
        out
    }

    fn random_depth(&self, rng: &mut PixelRng) -> f32 {
        // Uniform in inverse depth: uniform in disparity, as a stereo search.
        let (lo, hi) = (1.0 / self.range.1, 1.0 / self.range.0);
        1.0 / (lo + (hi - lo) * rng.next_f32())
    }

    /// Aggregated cost of plane (d, n) at pixel (x, y).
    fn cost(&self, patch: &RefPatch, x: usize, y: usize, ray: &[f32; 3], d: f32, n: &[f32; 3]) -> f32 {
        if !(d >= self.range.0 && d <= self.range.1) || !patch.textured() {
            return MAX_COST;
        }
        // The normal must face the camera within the allowed angle.
        let ray_len = (ray[0] * ray[0] + ray[1] * ray[1] + 1.0).sqrt();
        let facing = -(n[0] * ray[0] + n[1] * ray[1] + n[2] * ray[2]) / ray_len;
        if facing < self.min_cos {
            return MAX_COST;
        }
        let mut costs = [MAX_COST; MAX_SOURCES];
        let m = self.sources.len();
        let (u, v) = (x as f32 + 0.5, y as f32 + 0.5);
        for (c, (rel, src)) in costs.iter_mut().zip(&self.sources) {
            if let Some(h) = homography(rel, &self.k, d, n, ray) {
                *c = source_cost(patch, u, v, &h, src);
            }
        }
        aggregate(&mut costs[..m], self.top_k)
    }

    fn update(&self, prev: &[Hyp], patch: &mut RefPatch, x: usize, y: usize, it: u32, step: u64) -> Hyp {
        let w = self.image.width as usize;
        let h = self.image.height as usize;
        let idx = y * w + x;
        let ray = pixel_ray(&self.k, x, y);
        patch.build(self.image, x, y, &self.offsets, self.params);
        let mut best = prev[idx];
        if !patch.textured() {
            return best;
        }
        // Propagation: the neighbour's plane, intersected with this pixel's ray.
        for (ox, oy) in NEIGHBOURS {
            let (nx, ny) = (x as i32 + ox, y as i32 + oy);
            if nx < 0 || ny < 0 || nx as usize >= w || ny as usize >= h {
                continue;
            }
            let nb = prev[ny as usize * w + nx as usize];
            let nray = pixel_ray(&self.k, nx as usize, ny as usize);
            let n = nb.n;
            let num = nb.d * (n[0] * nray[0] + n[1] * nray[1] + n[2] * nray[2]);
            let den = n[0] * ray[0] + n[1] * ray[1] + n[2] * ray[2];
            if den.abs() < 1e-6 {
                continue;
            }
            let d = num / den;
            if d == best.d && n == best.n {
                continue;
            }
            let c = self.cost(patch, x, y, &ray, d, &n);
            if c < best.cost {
                best = Hyp { d, n, cost: c };
            }
        }
        // Refinement: a random depth, a random normal, and a perturbation of
        // both whose size halves every iteration.
        let mut rng = PixelRng::new(self.params.seed, self.view_key, idx as u64, step);
        let scale = 0.5f32.powi(it as i32);
        let random_d = self.random_depth(&mut rng);
        let random_n = random_normal(&mut rng, &ray);
        let pert_d = best.d * (1.0 + 0.05 * scale * rng.symmetric());
        let pert_n = normalize([
            best.n[0] + 0.3 * scale * rng.symmetric(),
            best.n[1] + 0.3 * scale * rng.symmetric(),
            best.n[2] + 0.3 * scale * rng.symmetric(),
        ]);
        let candidates = [(random_d, best.n), (best.d, random_n), (pert_d, pert_n)];
        for (d, n) in candidates {
            let c = self.cost(patch, x, y, &ray, d, &n);
            if c < best.cost {
                best = Hyp { d, n, cost: c };
            }
        }
        best
    }
}

/// A random unit normal facing the camera along `ray` (the reversed ray
/// plus a random vector of the unit cube), so that fronto-parallel planes
/// are the most likely and grazing ones rare.
fn random_normal(rng: &mut PixelRng, ray: &[f32; 3]) -> [f32; 3] {
    let r = normalize(*ray);
    normalize([
        -r[0] + rng.symmetric(),
        -r[1] + rng.symmetric(),
        -r[2] + rng.symmetric(),
    ])
}

#[inline]
fn normalize(v: [f32; 3]) -> [f32; 3] {
    let l = (v[0] * v[0] + v[1] * v[1] + v[2] * v[2]).sqrt();
    if l > 0.0 {
        [v[0] / l, v[1] / l, v[2] / l]
    } else {
        [0.0, 0.0, -1.0]
    }
}
