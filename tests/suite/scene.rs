//! vp-scene pieces together: file round trips, ray casting, clearance.

use nalgebra::{Point2, Point3};
use vpctl_suite::scene::camera::{Camera, Intrinsics};
use vpctl_suite::scene::clearance::Clearance;
use vpctl_suite::scene::io::{read_mesh, write_mesh, MeshFormat};
use vpctl_suite::scene::procedural::{generate_site, SiteParams};
use vpctl_suite::scene::raycast::RayCaster;
use vpctl_suite::scene::Material;

fn small_site(seed: u64) -> vpctl_suite::scene::procedural::Site {
    generate_site(&SiteParams {
        seed,
        target_faces: 30_000,
        ..SiteParams::default()
    })
    .expect("site")
}

/// A site survives a PLY round trip bit for bit, materials included, and the
/// BVH of the re-read mesh answers exactly as the original's.
#[test]
fn site_round_trips_through_ply_and_ray_casts_the_same() {
    let site = small_site(11);
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("site.ply");
    write_mesh(&path, &site.mesh, MeshFormat::PlyBinaryLittleEndian).unwrap();
    let back = read_mesh(&path).unwrap();
    assert_eq!(back, site.mesh);

    let (a, b) = (RayCaster::new(&site.mesh), RayCaster::new(&back));
    let k = Intrinsics::from_hfov(160, 120, 70.0).unwrap();
    let cam = Camera::look_at(
        k,
        Point3::new(-25.0, -20.0, 35.0),
        Point3::new(0.0, 0.0, 0.0),
    )
    .unwrap();
    assert_eq!(a.render_depth(&cam), b.render_depth(&cam));
}

/// Looking straight down on the rock from 30 m, the centre pixel sees rock at
/// the depth the site's own surface model gives.
#[test]
fn nadir_view_of_the_rock_sees_rock_at_the_right_depth() {
    let site = small_site(5);
    let caster = RayCaster::new(&site.mesh);
    let rb = site.rock_bounds;
    let centre = Point3::from((rb.min.coords + rb.max.coords) * 0.5);
    let k = Intrinsics::from_hfov(64, 48, 20.0).unwrap();
    let height = rb.max.z + 30.0;
    let cam = Camera::from_yaw_pitch(
        k,
        Point3::new(centre.x, centre.y, height),
        0.0,
        -std::f64::consts::FRAC_PI_2,
    );
    let (o, d) = cam.ray(&Point2::new(32.0, 24.0));
    let hit = caster
        .closest_hit(&o, &d, f64::INFINITY)
        .expect("the rock is below");
    assert_eq!(site.mesh.material(hit.face as usize), Some(Material::Rock));
    let expected = height - site.surface_height(o.x, o.y);
    assert!(
        (hit.t - expected).abs() < 0.05,
        "depth {} vs surface model {}",
        hit.t,
        expected
    );
    let rock_faces = caster
        .visible_faces(&cam, &site.mesh)
        .iter()
        .enumerate()
        .filter(|(f, &v)| v && site.mesh.material(*f) == Some(Material::Rock))
        .count();
    assert!(rock_faces > 100, "{rock_faces} rock faces visible");
}

/// The flight volume's floor keeps clear of ground and rock: every point of
/// a grid on it is at least 1.5 m from the mesh unless a tree is near.
#[test]
fn flight_volume_floor_clears_ground_and_rock() {
    let site = small_site(9);
    let clearance = Clearance::new(&site.mesh);
    let v = site.flight_volume;
    let tree_near = |p: &Point3<f64>| {
        site.trees.iter().any(|t| {
            (Point2::from(t.position) - Point2::new(p.x, p.y)).norm()
                < t.canopy_radii[0].max(t.canopy_radii[1]) + 3.0
        })
    };
    let mut checked = 0;
    for i in 0..=20 {
        for j in 0..=20 {
            let p = Point3::new(
                v.min.x + (v.max.x - v.min.x) * f64::from(i) / 20.0,
                v.min.y + (v.max.y - v.min.y) * f64::from(j) / 20.0,
                v.min.z,
            );
            if tree_near(&p) {
                continue;
            }
            checked += 1;
            assert!(
                clearance.point_is_clear(&p, 1.5),
                "{p} is {} m from the mesh",
                clearance.distance(&p)
            );
        }
    }
    assert!(checked > 200);
}
