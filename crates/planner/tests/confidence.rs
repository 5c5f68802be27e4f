//! The paper's supplementary observation: with confidence images saying
//! "grass fails above 20 deg", triplets aimed at grass use small angles and
//! triplets aimed at the rock large ones; without prediction angles go up.

mod common;

use common::{initial_views, site, test_config};
use nalgebra::Point2;
use vp_planner::{AcquiredView, PlanInputs, PlannerConfig, RoiSpec};
use vp_scene::raster::{AngleBins, ConfidenceImage};
use vp_scene::raycast::RayCaster;
use vp_scene::Material;

/// Confidence image of one acquired view: 1 everywhere, except on grass
/// pixels where bins above 20 deg say 0.05.
fn grass_fails_above_20(
    view: &AcquiredView,
    caster: &RayCaster,
    mesh: &vp_scene::Mesh,
) -> ConfidenceImage {
    let k = view.camera.intrinsics;
    let mut img = ConfidenceImage::zeros(k.width, k.height, 16, AngleBins::paper()).unwrap();
    let (gw, gh) = img.grid_size();
    let bins = AngleBins::paper();
    let mut values = Vec::with_capacity(gw * gh * 9);
    for j in 0..gh {
        for i in 0..gw {
            // Grass if any of 4 x 4 rays through the node's cell hits grass
            // (blades are thinner than a cell).
            let (x0, y0) = (i as f64 * 16.0, j as f64 * 16.0);
            let grass = (0..16).any(|s| {
                let px = Point2::new(
                    x0 + 2.0 + 4.0 * f64::from(s % 4),
                    y0 + 2.0 + 4.0 * f64::from(s / 4),
                );
                let (o, d) = view.camera.ray(&px);
                caster
                    .closest_hit(&o, &d, f64::INFINITY)
                    .is_some_and(|h| mesh.material(h.face as usize) == Some(Material::Grass))
            });
            values.extend((0..9).map(|b| {
                if grass && bins.centre(b) > 20.0 {
                    0.05
                } else {
                    1.0
                }
            }));
        }
    }
    img.values_mut().copy_from_slice(&values);
    img
}

fn angles(
    faces: Vec<u32>,
    acquired: &[AcquiredView],
    s: &vp_scene::procedural::Site,
    cfg: &PlannerConfig,
) -> Vec<f64> {
    let r = vp_planner::plan(&PlanInputs {
        mesh: &s.mesh,
        acquired,
        roi: RoiSpec::Faces(faces),
        config: cfg,
        origin: None,
        observations: None,
        home: None,
    })
    .unwrap();
    r.plan
        .waypoints
        .iter()
        .filter_map(|w| w.angle_bin_deg)
        .collect()
}

#[test]
fn predicted_failure_on_grass_keeps_grass_triplets_narrow() {
    let s = site(21, 30_000);
    let cfg = PlannerConfig {
        n_triplets: 3,
        ..test_config(&s)
    };
    let caster = RayCaster::new(&s.mesh);
    let np = initial_views(&s);
    let mut predicted = np.clone();
    for v in &mut predicted {
        v.confidence = Some(grass_fails_above_20(v, &caster, &s.mesh));
    }
    let of = |m: Material| -> Vec<u32> {
        // Only where the initial flight has images (and so predictions).
        let c = nalgebra::center(&s.rock_bounds.min, &s.rock_bounds.max);
        (0..s.mesh.n_faces() as u32)
            .filter(|&f| {
                let p = s.mesh.face_centroid(f as usize);
                s.mesh.material(f as usize) == Some(m)
                    && (p.x - c.x).abs() < 15.0
                    && (p.y - c.y).abs() < 15.0
            })
            .collect()
    };
    let grass = angles(of(Material::Grass), &predicted, &s, &cfg);
    let rock = angles(of(Material::Rock), &predicted, &s, &cfg);
    let rock_np = angles(of(Material::Rock), &np, &s, &cfg);
    let grass_np = angles(of(Material::Grass), &np, &s, &cfg);
    println!("grass {grass:?}\nrock {rock:?}\nrock NP {rock_np:?}\ngrass NP {grass_np:?}");
    assert!(
        !grass.is_empty() && grass.iter().all(|&a| a <= 20.0),
        "grass {grass:?}"
    );
    let mean = |v: &[f64]| v.iter().sum::<f64>() / v.len() as f64;
    assert!(mean(&rock) > 20.0, "rock {rock:?}");
    assert!(
        mean(&grass_np) > mean(&grass),
        "NP grass {grass_np:?} vs {grass:?}"
    );
}
