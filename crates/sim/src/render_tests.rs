//! Tests of the renderer: determinism, colours and texture per material,
//! exact depth, shadows.

use nalgebra::Point3;
use vp_scene::procedural::{box_mesh, with_material};
use vp_scene::raycast::RayCaster;
use vp_scene::{Camera, Material, Mesh};

use crate::render::{render, RenderParams, Rendered};
use crate::test_scenes::{intrinsics, tiled_plane};

fn nadir(height: f64, w: u32, h: u32) -> Camera {
    Camera::from_yaw_pitch(
        intrinsics(w, h),
        Point3::new(0.3, 0.2, height),
        0.2,
        -std::f64::consts::FRAC_PI_2,
    )
}

fn luminance(r: &Rendered, x: u32, y: u32) -> f64 {
    let p = r.rgb.get_pixel(x, y).0;
    0.3 * f64::from(p[0]) + 0.59 * f64::from(p[1]) + 0.11 * f64::from(p[2])
}

#[derive(Default, Clone, Copy)]
struct Stats {
    pixels: usize,
    rgb_sum: [f64; 3],
    /// Sum of |luminance difference| to the right and lower neighbour of the same material.
    gradient_sum: f64,
    gradient_pairs: usize,
    dark: usize,
    bright: usize,
}

/// Colour and local gradient energy per material, pixels split by face id.
fn stats_per_material(mesh: &Mesh, r: &Rendered) -> [Stats; 5] {
    let mut s = [Stats::default(); 5];
    let (w, h) = (r.rgb.width(), r.rgb.height());
    for y in 0..h {
        for x in 0..w {
            let Some(m) = r.material(mesh, x, y) else {
                continue;
            };
            let e = &mut s[m as usize];
            e.pixels += 1;
            let p = r.rgb.get_pixel(x, y).0;
            for (sum, v) in e.rgb_sum.iter_mut().zip(p) {
                *sum += f64::from(v);
            }
            let l = luminance(r, x, y);
            e.dark += usize::from(l < 40.0);
            e.bright += usize::from(l > 150.0);
            for (nx, ny) in [(x + 1, y), (x, y + 1)] {
                if nx < w && ny < h && r.material(mesh, nx, ny) == Some(m) {
                    e.gradient_sum += (luminance(r, nx, ny) - l).abs();
                    e.gradient_pairs += 1;
                }
            }
        }
    }
    s
}

#[test]
fn materials_have_their_colours_and_texture_energy() {
    let mesh = tiled_plane(40.0, 1.0);
    let caster = RayCaster::new(&mesh);
    // 1.3 cm per pixel: the scale at which grass texture is resolved.
    let cam = nadir(4.5, 400, 300);
    let params = RenderParams {
        shadows: false,
        ..RenderParams::default()
    };
    let r = render(&mesh, &caster, &cam, &params).unwrap();
    let s = stats_per_material(&mesh, &r);
    let mean = |m: Material| {
        s[m as usize]
            .rgb_sum
            .map(|v| v / s[m as usize].pixels as f64)
    };
    let grad = |m: Material| s[m as usize].gradient_sum / s[m as usize].gradient_pairs as f64;
    for m in Material::ALL {
        assert!(
            s[m as usize].pixels > 1000,
            "{m:?} covers {} pixels",
            s[m as usize].pixels
        );
    }
    let [gr, gg, gb] = mean(Material::Grass);
    assert!(gg > gr && gg > gb, "grass is green: {gr} {gg} {gb}");
    let [er, eg, eb] = mean(Material::Ground);
    assert!(er > eg && eg > eb, "ground is brown: {er} {eg} {eb}");
    let [rr, rg, rb] = mean(Material::Rock);
    assert!(
        (rr - rb).abs() < 0.2 * rr && rr > 80.0,
        "rock is light grey-beige: {rr} {rg} {rb}"
    );
    // Checker: both black and white cells, in about equal shares.
    let mk = s[Material::Marker as usize];
    let (dark, bright) = (
        mk.dark as f64 / mk.pixels as f64,
        mk.bright as f64 / mk.pixels as f64,
    );
    assert!(
        dark > 0.3 && bright > 0.3,
        "marker dark {dark} bright {bright}"
    );
    // Texture energy: rock and ground textured at pixel scale (the 1/f
    // spectrum of photos), foliage far rougher, the checker's edges strongest.
    let (rock, ground, grass, tree) = (
        grad(Material::Rock),
        grad(Material::Ground),
        grad(Material::Grass),
        grad(Material::Tree),
    );
    eprintln!("gradient energy: rock {rock:.2} ground {ground:.2} grass {grass:.2} tree {tree:.2} marker {:.2}", grad(Material::Marker));
    assert!(
        grass > 2.0 * rock && grass > 2.0 * ground && tree > 1.5 * rock,
        "rock {rock} ground {ground} grass {grass} tree {tree}"
    );
    assert!(rock > 0.5 * ground, "rock {rock} ground {ground}");
    assert!(grad(Material::Marker) > grass);
}

#[test]
fn depth_and_faces_equal_the_ray_caster() {
    let mut mesh = tiled_plane(30.0, 3.0);
    mesh.append(&with_material(
        box_mesh(Point3::new(-2.0, -1.0, 0.0), Point3::new(1.0, 2.0, 3.0)),
        Material::Rock,
    ));
    let caster = RayCaster::new(&mesh);
    let cam = Camera::look_at(
        intrinsics(160, 120),
        Point3::new(-12.0, -9.0, 10.0),
        Point3::new(0.0, 0.0, 1.0),
    )
    .unwrap();
    let r = render(&mesh, &caster, &cam, &RenderParams::default()).unwrap();
    let (depth, faces) = caster.render_depth(&cam);
    assert_eq!(r.depth.data, depth);
    assert_eq!(r.face_id, faces);
    assert_eq!((r.depth.width, r.depth.height), (160, 120));
    // Looking above the horizon at the far corner: sky where nothing is hit.
    let sky = RenderParams::default().sky;
    let misses = faces.iter().filter(|&&f| f == u32::MAX).count();
    assert!(misses > 0);
    for (i, &f) in faces.iter().enumerate() {
        if f == u32::MAX {
            assert_eq!(r.rgb.get_pixel(i as u32 % 160, i as u32 / 160).0, sky);
        }
    }
}

#[test]
fn rendering_is_deterministic_across_thread_counts() {
    let mesh = tiled_plane(30.0, 3.0);
    let caster = RayCaster::new(&mesh);
    let cam = nadir(12.0, 120, 90);
    let params = RenderParams::default();
    let a = render(&mesh, &caster, &cam, &params).unwrap();
    let one = rayon::ThreadPoolBuilder::new()
        .num_threads(1)
        .build()
        .unwrap();
    let b = one.install(|| render(&mesh, &caster, &cam, &params).unwrap());
    assert_eq!(a, b);
    let other = RenderParams {
        texture_seed: 1,
        ..params
    };
    assert_ne!(a.rgb, render(&mesh, &caster, &cam, &other).unwrap().rgb);
}

#[test]
fn a_box_casts_a_shadow_on_the_ground() {
    let mut mesh = tiled_plane(30.0, 30.0); // one tile: all rock-free ground material
    mesh.materials = Some(vec![Material::Ground; mesh.n_faces()]);
    mesh.append(&with_material(
        box_mesh(Point3::new(-1.0, -1.0, 0.0), Point3::new(1.0, 1.0, 4.0)),
        Material::Rock,
    ));
    let caster = RayCaster::new(&mesh);
    let cam = nadir(20.0, 160, 120);
    let lit = RenderParams {
        shadows: false,
        ..RenderParams::default()
    };
    let a = render(&mesh, &caster, &cam, &lit).unwrap();
    let b = render(&mesh, &caster, &cam, &RenderParams::default()).unwrap();
    // The sun is up at 50 deg towards the south-east: the shadow falls north-west of the box.
    let p = Point3::new(-2.5, 2.5, 0.0);
    let px = cam.project_in_frame(&p).unwrap();
    let (x, y) = (px.x as u32, px.y as u32);
    assert!(luminance(&b, x, y) < 0.6 * luminance(&a, x, y));
    let darker = (0..a.face_id.len())
        .filter(|&i| a.rgb.as_raw()[3 * i + 1] > b.rgb.as_raw()[3 * i + 1])
        .count();
    assert!(darker > 50, "only {darker} shadowed pixels");
}

#[test]
fn bad_parameters_are_named() {
    let mesh = tiled_plane(10.0, 2.0);
    let caster = RayCaster::new(&mesh);
    let cam = nadir(5.0, 8, 8);
    let bad = RenderParams {
        sun_elevation_deg: -3.0,
        ..RenderParams::default()
    };
    let msg = render(&mesh, &caster, &cam, &bad).unwrap_err().to_string();
    assert!(msg.contains("sun_elevation_deg"), "{msg}");
    let other = tiled_plane(12.0, 2.0);
    let msg = render(&other, &caster, &cam, &RenderParams::default())
        .unwrap_err()
        .to_string();
    assert!(msg.contains("faces"), "{msg}");
}
