//! M3: the triplet gain g(c3) keeps the M1 definition (visible = in frustum,
//! front-facing, unoccluded in all three cameras) however it is computed.

mod common;

use nalgebra::{Point3, Vector3};
use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;
use vp_planner::fulfillment::{sample_triangles, Fulfillment};
use vp_planner::quality::{CamTerm, Requirements};
use vp_planner::safety::Safety;
use vp_planner::surrogate::{link_valued, sample_positions, LazyLinks};
use vp_planner::triplet::{Potential, Search};
use vp_scene::mesh_ops::submesh;
use vp_scene::plan::AltitudeLimits;
use vp_scene::procedural::Site;
use vp_scene::raster::AngleBins;
use vp_scene::raycast::RayCaster;
use vp_scene::{Camera, Intrinsics, Mesh};

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

/// Every sampled triangle as T, with its mesh (the input of a gain test).
fn all_triangles(ful: &Fulfillment) -> (Vec<usize>, Mesh) {
    let selected: Vec<usize> = (0..ful.tris.len()).collect();
    let mesh = submesh(
        &ful.tri_mesh,
        &selected.iter().map(|&t| t as u32).collect::<Vec<_>>(),
    );
    (selected, mesh)
}

/// A search without surrogates, for testing the gain of given triplets.
fn gain_search<'a>(
    ful: &'a Fulfillment,
    selected: &'a [usize],
    selected_mesh: &'a Mesh,
    safety: &'a Safety,
    caster: &'a RayCaster,
    k: Intrinsics,
) -> Search<'a> {
    Search {
        ful,
        selected,
        selected_mesh,
        surrogates: &[],
        safety,
        caster,
        intrinsics: k,
        pitch_limits: (-90f64.to_radians(), 0.0),
        early_stop: true,
        deadline: None,
        banned: &[],
    }
}

/// Site 3 (30k faces) with its ray caster, f(t) of 400 sampled triangles
/// seen by its initial views (requirements for `accuracy` metres), the
/// safety rules of its flight volume, and the rng that sampled them.
fn fixture(seed: u64, accuracy: f64) -> (Site, RayCaster, Fulfillment, Safety, ChaCha8Rng) {
    let site = common::site(3, 30_000);
    let caster = RayCaster::new(&site.mesh);
    let mut rng = ChaCha8Rng::seed_from_u64(seed);
    let roi: Vec<u32> = (0..site.mesh.n_faces() as u32).collect();
    let sampled = sample_triangles(&site.mesh, &roi, 400, &mut rng).unwrap();
    let acquired: Vec<Camera> = common::initial_views(&site)
        .iter()
        .map(|a| a.camera)
        .collect();
    let req = Requirements {
        r_desired: 1.0 / (accuracy * accuracy),
        accuracy,
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
    (site, caster, ful, safety, rng)
}

#[test]
fn gain_equals_the_definition_on_a_site_with_trees() {
    let (site, caster, ful, safety, mut rng) = fixture(5, 0.02);
    let (selected, selected_mesh) = all_triangles(&ful);
    let k = Intrinsics::from_hfov(640, 480, 70.0).unwrap();
    let search = gain_search(&ful, &selected, &selected_mesh, &safety, &caster, k);
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

/// The lazy search (segments tested on demand) visits the same surrogates
/// in the same order and finds the same triplet as the search over links
/// tested up front, over iterations in which f(t) grows.
#[test]
fn lazy_search_equals_the_search_over_tested_links() {
    let (site, caster, mut ful, safety, mut rng) = fixture(9, 0.008);
    let selected: Vec<usize> = (0..ful.tris.len()).step_by(3).collect();
    let selected_mesh = submesh(
        &ful.tri_mesh,
        &selected.iter().map(|&t| t as u32).collect::<Vec<_>>(),
    );
    let surrogates = sample_positions(&safety, &caster, &site.mesh, 800, &mut rng).unwrap();
    let t_geo: Vec<_> = selected
        .iter()
        .map(|&t| (ful.tris[t].centroid, ful.tris[t].normal))
        .collect();
    let k = Intrinsics::from_hfov(1200, 800, 73.7).unwrap();
    let (links, potential, mut lazy) = {
        let pot = Potential::new(&ful, k.fx);
        let value = |s: usize, i: usize| {
            let t = selected[i];
            let v = pot.value(&surrogates[s], t);
            (v > ful.f(t)).then_some(v)
        };
        let (links, potential) = link_valued(&surrogates, &t_geo, 120.0, &caster, value);
        let lazy = LazyLinks::new(&surrogates, &t_geo, 120.0, value);
        (links, potential, lazy)
    };
    let mut visits = 0;
    for it in 0..4 {
        let mut best = None;
        for early_stop in [false, true] {
            let search = Search {
                ful: &ful,
                selected: &selected,
                selected_mesh: &selected_mesh,
                surrogates: &surrogates,
                safety: &safety,
                caster: &caster,
                intrinsics: k,
                pitch_limits: (-90f64.to_radians(), 0.0),
                early_stop,
                deadline: None,
                banned: &[],
            };
            let want = search.run(&links, &potential);
            let got = search.run_lazy(&mut lazy);
            assert_eq!(got.visited, want.visited, "iteration {it}");
            assert_eq!(got.best, want.best, "iteration {it}");
            assert_eq!(
                got.best.as_ref().map(|b| b.gain.to_bits()),
                want.best.as_ref().map(|b| b.gain.to_bits())
            );
            visits += want.visited;
            best = want.best;
        }
        let Some(best) = best else { break };
        for cam in &best.cameras {
            ful.add_planned(cam, &caster);
        }
    }
    assert!(visits > 20, "only {visits} visits: the test checks little");
}

/// The bounds that skip triangles (f(t, c3) cannot beat f(t)) and
/// triplets (g(c3) cannot beat the best so far) change no gain: after
/// planned cameras raised f(t), `gain` still equals the definition bit for
/// bit, and `gain_above` says `None` only for gains at most its floor.
#[test]
fn pruned_gain_equals_the_definition_once_f_has_grown() {
    let (site, caster, mut ful, safety, mut rng) = fixture(7, 0.02);
    let k = Intrinsics::from_hfov(640, 480, 70.0).unwrap();
    let c = nalgebra::center(&site.rock_bounds.min, &site.rock_bounds.max);
    let triplet = |rng: &mut ChaCha8Rng| -> [Camera; 3] {
        let (az, el, dist) = (
            rng.random_range(0.0..360f64).to_radians(),
            rng.random_range(15.0..80f64).to_radians(),
            rng.random_range(12.0..40.0),
        );
        let centre = c + Vector3::new(el.cos() * az.cos(), el.cos() * az.sin(), el.sin()) * dist;
        [0.0, 2.1, 4.2].map(|a: f64| {
            let p = centre + Vector3::new(a.cos(), a.sin(), 0.0) * rng.random_range(1.0..8.0);
            Camera::look_at(k, p, Point3::from(c.coords)).unwrap()
        })
    };
    for _ in 0..6 {
        for cam in &triplet(&mut rng) {
            ful.add_planned(cam, &caster);
        }
    }
    let (selected, selected_mesh) = all_triangles(&ful);
    let search = gain_search(&ful, &selected, &selected_mesh, &safety, &caster, k);
    let (mut positive, mut none) = (0, 0);
    for _ in 0..40 {
        let cams = triplet(&mut rng);
        let want = gain_by_definition(&search, &cams);
        assert_eq!(
            search.gain(&cams).to_bits(),
            want.to_bits(),
            "gain differs: {want}"
        );
        // 400 triangles gain at most 1 each: the last floor prunes always.
        for floor in [0.0, 0.5 * want, want, 1.2 * want + 0.01, 400.0] {
            if let Some(g) = search.gain_above(&cams, floor) {
                assert_eq!(g.to_bits(), want.to_bits(), "floor {floor}");
            } else {
                assert!(want <= floor, "{want} > floor {floor}");
                none += 1;
            }
        }
        positive += usize::from(want > 0.0);
    }
    assert!(
        positive >= 10 && none >= 40,
        "{positive} positive gains, {none} pruned: the test checks little"
    );
}
