//! M3: the triplet gain g(c3) keeps the M1 definition (visible = in frustum,
//! front-facing, unoccluded in all three cameras) however it is computed.

mod common;

use nalgebra::{Point3, Vector3};
use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;
use vp_planner::fulfillment::{sample_triangles, Fulfillment};
use vp_planner::quality::{CamTerm, Requirements};
use vp_planner::safety::Safety;
use vp_planner::triplet::Search;
use vp_scene::mesh_ops::submesh;
use vp_scene::plan::AltitudeLimits;
use vp_scene::raster::AngleBins;
use vp_scene::raycast::RayCaster;
use vp_scene::{Camera, Intrinsics};

/// g(c3) straight from the definition: full visibility of every selected
/// triangle in each camera first, then the sum of positive gains.
fn gain_by_definition(search: &Search, cams: &[Camera; 3]) -> f64 {
    let vis: Vec<Vec<bool>> = cams
        .iter()
        .map(|c| search.caster.visible_faces(c, search.selected_mesh))
        .collect();
    let ful = search.ful;
    let mut g = 0.0;
    for (i, &t) in search.selected.iter().enumerate() {
        if !(vis[0][i] && vis[1][i] && vis[2][i]) {
            continue;
        }
        let tri = &ful.tris[t];
        let terms = cams.map(|c| CamTerm::new(&c, &tri.centroid, &tri.normal, ful.sigma_px));
        let (q, angle) = ful.req.score(&terms[0], &terms[1], &terms[2]);
        g += (q * ful.curve[t].at(&ful.req.bins, angle) - ful.f(t)).max(0.0);
    }
    g
}

#[test]
fn gain_equals_the_definition_on_a_site_with_trees() {
    let site = common::site(3, 30_000);
    let caster = RayCaster::new(&site.mesh);
    let mut rng = ChaCha8Rng::seed_from_u64(5);
    let roi: Vec<u32> = (0..site.mesh.n_faces() as u32).collect();
    let sampled = sample_triangles(&site.mesh, &roi, 400, &mut rng).unwrap();
    let acquired: Vec<Camera> = common::initial_views(&site)
        .iter()
        .map(|a| a.camera)
        .collect();
    let req = Requirements {
        r_desired: 1.0 / (0.02 * 0.02),
        accuracy: 0.02,
        alpha: 0.5,
        bins: AngleBins::paper(),
    };
    let ful = Fulfillment::new(
        req,
        1.0,
        3,
        sampled,
        &caster,
        &acquired,
        &vec![None; acquired.len()],
    );
    let selected: Vec<usize> = (0..ful.tris.len()).collect();
    let selected_mesh = submesh(
        &ful.tri_mesh,
        &selected.iter().map(|&t| t as u32).collect::<Vec<_>>(),
    );
    let v = site.flight_volume;
    let safety = Safety::new(
        &site.mesh,
        5.0,
        v,
        None,
        AltitudeLimits {
            min_m: v.min.z,
            max_m: v.max.z,
        },
    );
    let k = Intrinsics::from_hfov(640, 480, 70.0).unwrap();
    let search = Search {
        ful: &ful,
        selected: &selected,
        selected_mesh: &selected_mesh,
        surrogates: &[],
        links: &[],
        potential: &[],
        safety: &safety,
        caster: &caster,
        intrinsics: k,
        pitch_limits: (-90f64.to_radians(), 0.0),
        early_stop: true,
        deadline: None,
    };
    // Low oblique triplets around the rock: trees and the rock itself occlude.
    let c = nalgebra::center(&site.rock_bounds.min, &site.rock_bounds.max);
    let mut positive = 0;
    for _ in 0..40 {
        let (az, el, dist) = (
            rng.random_range(0.0..360f64).to_radians(),
            rng.random_range(15.0..70f64).to_radians(),
            rng.random_range(12.0..40.0),
        );
        let centre = c + Vector3::new(el.cos() * az.cos(), el.cos() * az.sin(), el.sin()) * dist;
        let cams: [Camera; 3] = [0.0, 2.1, 4.2].map(|a: f64| {
            let p = centre + Vector3::new(a.cos(), a.sin(), 0.0) * rng.random_range(1.0..8.0);
            Camera::look_at(k, p, Point3::from(c.coords)).unwrap()
        });
        let want = gain_by_definition(&search, &cams);
        assert_eq!(
            search.gain(&cams).to_bits(),
            want.to_bits(),
            "gain differs: {want}"
        );
        positive += usize::from(want > 0.0);
    }
    assert!(
        positive >= 10,
        "only {positive} of 40 triplets gain anything: the test checks little"
    );
}
