//! Ray-cast rendering of a textured, sun-lit mesh: the images a camera of
//! the simulated world takes, with the exact depth and face under each pixel.

use nalgebra::{Point2, Point3, Vector3};
use rayon::prelude::*;
use serde::{Deserialize, Serialize};
use vp_scene::colmap::DepthMap;
use vp_scene::raster::RgbImage;
use vp_scene::raycast::RayCaster;
use vp_scene::{Camera, Intrinsics, Material, Mesh};

use crate::error::{Result, SimError};
use crate::noise::gaussian;
use crate::texture::albedo;
use vp_scene::hash::mix64;

/// Offset of a shadow ray's origin from the surface, metres.
const SHADOW_EPSILON: f64 = 2e-3;

/// Lighting and texture settings of [`render`]. Serialisable with defaults
/// for missing fields.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct RenderParams {
    /// Sun azimuth, degrees counter-clockwise from east.
    pub sun_azimuth_deg: f64,
    /// Sun elevation above the horizon, degrees (0, 90].
    pub sun_elevation_deg: f64,
    /// Share of the light that is ambient (sky), in [0, 1]: lights surfaces
    /// facing away from the sun and surfaces in shadow.
    pub ambient: f64,
    /// Cast shadows (one occlusion ray towards the sun per pixel).
    pub shadows: bool,
    /// Seed of the procedural textures (the same point has the same texture
    /// in every image of one world).
    pub texture_seed: u64,
    /// Colour of pixels that hit no surface, 8-bit RGB.
    pub sky: [u8; 3],
    /// Standard deviation of the sensor noise, 8-bit grey levels, added to
    /// every channel of every pixel (a camera's read and shot noise; without
    /// it, two views of a flat texture match better than any photo would).
    /// Each image draws its own noise: the seed mixes `texture_seed` with
    /// the camera's pose.
    pub noise_sigma: f64,
}

impl Default for RenderParams {
    /// Late-morning sun from the south-east at 50 deg, 35 % ambient, shadows on.
    fn default() -> Self {
        RenderParams {
            sun_azimuth_deg: -45.0,
            sun_elevation_deg: 50.0,
            ambient: 0.35,
            shadows: true,
            texture_seed: 0,
            sky: [170, 200, 235],
            noise_sigma: 2.0,
        }
    }
}

impl RenderParams {
    /// Checks the ranges; the error names the parameter and its value.
    pub fn validate(&self) -> Result<()> {
        if !(self.sun_elevation_deg > 0.0 && self.sun_elevation_deg <= 90.0) {
            return Err(SimError::InvalidArgument(format!(
                "sun_elevation_deg = {} is outside (0, 90]",
                self.sun_elevation_deg
            )));
        }
        if !self.sun_azimuth_deg.is_finite() {
            return Err(SimError::InvalidArgument(format!(
                "sun_azimuth_deg = {} is not finite",
                self.sun_azimuth_deg
            )));
        }
        if !(self.noise_sigma >= 0.0 && self.noise_sigma <= 64.0) {
            return Err(SimError::InvalidArgument(format!(
                "noise_sigma = {} is outside [0, 64] grey levels",
                self.noise_sigma
            )));
        }
        if !(0.0..=1.0).contains(&self.ambient) {
            return Err(SimError::InvalidArgument(format!(
                "ambient = {} is outside [0, 1]",
                self.ambient
            )));
        }
        Ok(())
    }

    /// Unit vector towards the sun.
    pub fn sun_direction(&self) -> Vector3<f64> {
        let (az, el) = (
            self.sun_azimuth_deg.to_radians(),
            self.sun_elevation_deg.to_radians(),
        );
        Vector3::new(el.cos() * az.cos(), el.cos() * az.sin(), el.sin())
    }
}

/// A rendered view.
#[derive(Debug, Clone, PartialEq)]
pub struct Rendered {
    /// Shaded colour image.
    pub rgb: RgbImage,
    /// Exact depth along the optical axis (0 where the ray hits nothing),
    /// identical to [`RayCaster::render_depth`].
    pub depth: DepthMap,
    /// Face under each pixel centre, row-major; `u32::MAX` where none.
    pub face_id: Vec<u32>,
}

impl Rendered {
    /// Material under pixel (x, y), if a face is there. Faces of a mesh
    /// without materials read as ground.
    pub fn material(&self, mesh: &Mesh, x: u32, y: u32) -> Option<Material> {
        let f = *self
            .face_id
            .get(y as usize * self.depth.width as usize + x as usize)?;
        (f != u32::MAX).then(|| mesh.material(f as usize).unwrap_or(Material::Ground))
    }
}

/// Renders `mesh` (with `caster` built from it) as seen by `camera`: one ray
/// through each pixel centre, the material texture at the hit point, Lambert
/// shading with the face normal turned towards the camera (thin grass blades
/// and leaves are two-sided), optional sun shadows. Deterministic: the same
/// inputs give the same bytes for any thread count.
///
/// # Performance
/// Parallel over rows (rayon). One closest-hit ray per pixel plus one
/// occlusion ray when shadows are on; see `benches/render.rs` for figures.
pub fn render(
    mesh: &Mesh,
    caster: &RayCaster,
    camera: &Camera,
    params: &RenderParams,
) -> Result<Rendered> {
    params.validate()?;
    if caster.n_faces() != mesh.n_faces() {
        return Err(SimError::InvalidArgument(format!(
            "ray caster has {} faces but the mesh has {}: build the caster from this mesh",
            caster.n_faces(),
            mesh.n_faces()
        )));
    }
    let k = camera.intrinsics;
    let (w, h) = (k.width as usize, k.height as usize);
    let axis = camera.axis();
    let sun = params.sun_direction();
    // One normal and material per face up front: the per-pixel lookups then
    // touch one array each instead of the face and its three vertices.
    let normals = mesh.face_normals();
    let materials: Vec<Material> = (0..mesh.n_faces())
        .map(|f| mesh.material(f).unwrap_or(Material::Ground))
        .collect();
    let surface = Surface {
        caster,
        normals: &normals,
        materials: &materials,
        sun,
        params,
    };
    let noise_seed = image_noise_seed(camera, params.texture_seed);
    let mut rgb = vec![0u8; w * h * 3];
    let mut depth = vec![0f32; w * h];
    let mut face_id = vec![u32::MAX; w * h];
    rgb.par_chunks_mut(w * 3)
        .zip(depth.par_chunks_mut(w))
        .zip(face_id.par_chunks_mut(w))
        .enumerate()
        .for_each(|(y, ((crow, drow), frow))| {
            for x in 0..w {
                let (o, d) = camera.ray(&Point2::new(x as f64 + 0.5, y as f64 + 0.5));
                let Some(hit) = caster.closest_hit(&o, &d, f64::INFINITY) else {
                    crow[3 * x..3 * x + 3].copy_from_slice(&params.sky);
                    continue;
                };
                drow[x] = (hit.t * d.dot(&axis)) as f32;
                frow[x] = hit.face;
                let light = surface.light(hit.face, &hit.point, &d);
                for (c, (out, a)) in crow[3 * x..3 * x + 3].iter_mut().zip(light).enumerate() {
                    let noise = if params.noise_sigma > 0.0 {
                        params.noise_sigma * gaussian(noise_seed, x as i64, y as i64, c as i64)
                    } else {
                        0.0
                    };
                    *out = (a * 255.0 + noise).round().clamp(0.0, 255.0) as u8;
                }
            }
        });
    let rgb =
        RgbImage::from_raw(k.width, k.height, rgb).expect("buffer has width * height * 3 bytes");
    Ok(Rendered {
        rgb,
        depth: DepthMap {
            width: k.width,
            height: k.height,
            data: depth,
        },
        face_id,
    })
}

/// What shading needs of the scene, prepared once per image.
struct Surface<'a> {
    caster: &'a RayCaster,
    normals: &'a [Vector3<f64>],
    materials: &'a [Material],
    sun: Vector3<f64>,
    params: &'a RenderParams,
}

impl Surface<'_> {
    /// Linear colour in [0, 1] of face `face` at `p`, seen along `dir`.
    fn light(&self, face: u32, p: &Point3<f64>, dir: &Vector3<f64>) -> [f64; 3] {
        let f = face as usize;
        let mut n = self.normals[f];
        if n.dot(dir) > 0.0 {
            n = -n;
        }
        let mut direct = n.dot(&self.sun).max(0.0);
        if direct > 0.0
            && self.params.shadows
            && self
                .caster
                .occluded(&(p + n * SHADOW_EPSILON), &(p + self.sun * 1e4))
        {
            direct = 0.0;
        }
        let ambient = self.params.ambient;
        let light = ambient + (1.0 - ambient) * direct;
        albedo(self.materials[f], p, self.params.texture_seed).map(|a| f64::from(a) * light)
    }
}

/// Seed of one image's sensor noise: the world's seed and the camera's pose.
fn image_noise_seed(camera: &Camera, seed: u64) -> u64 {
    let pose = camera.world_from_cam;
    let t = pose.translation.vector;
    let q = pose.rotation.coords;
    [t.x, t.y, t.z, q.x, q.y, q.z, q.w]
        .iter()
        .fold(mix64(seed ^ 0x006e_6f69_7365), |h, v| {
            mix64(h ^ v.to_bits())
        })
}

/// A camera at `from` looking at `at` (`vpctl sim render --from --at`);
/// straight down or up it uses heading east (roll is undefined there).
pub fn look_at_camera(k: Intrinsics, from: Point3<f64>, at: Point3<f64>) -> Result<Camera> {
    let d = at - from;
    if !(d.norm() > 0.0) {
        return Err(SimError::InvalidArgument(
            "--from and --at are the same point".into(),
        ));
    }
    let horizontal = d.x.hypot(d.y);
    if horizontal < 1e-6 * d.norm() {
        let pitch = std::f64::consts::FRAC_PI_2.copysign(d.z);
        return Ok(Camera::from_yaw_pitch(k, from, 0.0, pitch));
    }
    Ok(Camera::look_at(k, from, at)?)
}

/// The share of a rendering's pixels on each material of `mesh`, in
/// [`Material::ALL`] order (`face_id` as [`Rendered::face_id`]; a face
/// without a material counts as ground). Their sum is the share of pixels
/// that see the surface.
pub fn material_shares(mesh: &Mesh, face_id: &[u32]) -> [f64; Material::ALL.len()] {
    let total = face_id.len().max(1) as f64;
    let mut counts = [0usize; Material::ALL.len()];
    for &f in face_id.iter().filter(|&&f| f != u32::MAX) {
        counts[mesh.material(f as usize).unwrap_or(Material::Ground) as usize] += 1;
    }
    counts.map(|n| n as f64 / total)
}
