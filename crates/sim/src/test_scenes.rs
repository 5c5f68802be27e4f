//! Small scenes with known geometry for the tests of the renderer and the
//! virtual MVS.

use nalgebra::Point3;
use vp_scene::procedural::plane;
use vp_scene::{Camera, Intrinsics, Material, Mesh};

/// A flat `size` x `size` m plane at z = 0 in square tiles of `tile` m that
/// cycle through all five materials (faces are 1 m cells).
pub(crate) fn tiled_plane(size: f64, tile: f64) -> Mesh {
    let n = size.round() as usize;
    let mut mesh = plane(size, size, n, n);
    let materials = (0..mesh.n_faces())
        .map(|f| {
            let c = mesh.face_centroid(f);
            let (i, j) = ((c.x / tile).floor() as i64, (c.y / tile).floor() as i64);
            Material::ALL[(i + 2 * j).rem_euclid(5) as usize]
        })
        .collect();
    mesh.materials = Some(materials);
    mesh
}

/// A flat plane of one material.
pub(crate) fn uniform_plane(size: f64, material: Material) -> Mesh {
    let n = size.round() as usize;
    let mut mesh = plane(size, size, n, n);
    mesh.materials = Some(vec![material; mesh.n_faces()]);
    mesh
}

/// Intrinsics of the test cameras: `w` x `h` pixels, 60 deg horizontal field of view.
pub(crate) fn intrinsics(w: u32, h: u32) -> Intrinsics {
    Intrinsics::from_hfov(w, h, 60.0).unwrap()
}

/// Three cameras at height `height` above the origin, on a circle at
/// azimuths 90/210/330 deg, all looking at the origin, with triangulation
/// angle `angle_deg` at the origin.
pub(crate) fn triplet(k: Intrinsics, height: f64, angle_deg: f64) -> [Camera; 3] {
    let r = 2.0 * height * (0.5 * angle_deg.to_radians()).tan() / 3f64.sqrt();
    // A tiny offset keeps look_at away from the vertical at angle 0.
    let r = r.max(0.05);
    [90.0f64, 210.0, 330.0].map(|az| {
        let a = az.to_radians();
        Camera::look_at(
            k,
            Point3::new(r * a.cos(), r * a.sin(), height),
            Point3::origin(),
        )
        .unwrap()
    })
}
