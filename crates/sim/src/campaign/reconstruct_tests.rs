//! Tests of the matcher (`reconstruct.rs`).

use super::*;
use crate::campaign::MatchingGate;
use crate::sfm::SparseCandidates;
use vp_scene::raycast::RayCaster;
use vp_scene::Material;
use vp_scene::Mesh;

fn stats(matchable: f64, nonflat: f64, angle: f64) -> GateStats {
    GateStats {
        overlap_pixels: 1000,
        matchable_share: matchable,
        nonflat_share: nonflat,
        nonflat_median_angle_deg: angle,
    }
}

#[test]
fn gate_fails_wide_vegetation_triplets_and_keeps_flat_ones() {
    let g = MatchingGate::default();
    // Rock at a wide angle: mostly matchable, little vegetation.
    assert!(g.passes(&stats(0.9, 0.1, 40.0)));
    // Grass seen at 35 deg: median angle over the limit.
    assert!(!g.passes(&stats(0.6, 0.5, 35.0)));
    // The same grass at 10 deg passes.
    assert!(g.passes(&stats(0.6, 0.5, 10.0)));
    // Too little matchable overlap.
    assert!(!g.passes(&stats(0.3, 0.0, 0.0)));
    // No overlap: no output, gate or not.
    let off = MatchingGate {
        enabled: false,
        ..MatchingGate::default()
    };
    assert!(off.passes(&stats(0.0, 1.0, 80.0)));
    assert!(!off.passes(&GateStats::default()));
}

/// A nadir grid at 20 m over textured ground: every image against its
/// neighbours, most pixels within the 24 cm rule.
#[test]
fn nadir_grid_over_ground_reconstructs_most_pixels() {
    let mesh = crate::test_scenes::uniform_plane(60.0, Material::Ground);
    let caster = RayCaster::new(&mesh);
    let cfg = CampaignConfig::quick();
    let candidates = SparseCandidates::new(&mesh, cfg.sfm.points_per_m2, 11);
    let scene = Scene {
        mesh: &mesh,
        caster: &caster,
        texture_seed: 3,
        candidates: &candidates,
    };
    let k = cfg.planner.camera.intrinsics();
    for yaw in [0.0, std::f64::consts::FRAC_PI_2] {
        let mut cams = Vec::new();
        for j in 0..3 {
            for i in 0..3 {
                let c = nalgebra::Point3::new(
                    27.0 + 3.0 * f64::from(i),
                    28.0 + 2.0 * f64::from(j),
                    20.0,
                );
                cams.push(Camera::from_yaw_pitch(
                    k,
                    c,
                    yaw,
                    -std::f64::consts::FRAC_PI_2,
                ));
            }
        }
        let ids: Vec<u64> = (0..9).collect();
        let region = Aabb {
            min: nalgebra::Point3::new(-1.0, -1.0, -1.0),
            max: nalgebra::Point3::new(61.0, 61.0, 1.0),
        };
        let m = Matcher::new(&cfg).unwrap();
        let sfm = crate::sfm::sfm_cameras(&cams, &cfg, 7);
        let flown = m
            .image_set(
                &mut Renders::new(scene, &cfg),
                (&cams, &sfm),
                &ids,
                &region,
                5,
            )
            .unwrap();
        let (mut px, mut out, mut ok) = (0, 0, 0);
        for f in &flown {
            px += f.stats.pixels;
            out += f.stats.output;
            ok += f.stats.measured;
        }
        let (out, ok) = (out as f64 / px as f64, ok as f64 / px as f64);
        eprintln!(
            "yaw {yaw}: {} sets, output {out:.2}, measured {ok:.2}",
            flown.len()
        );
        assert!(ok > 0.5, "yaw {yaw}: measured {ok:.2}, output {out:.2}");
    }
}

/// A textured ground plane 60 m square, its caster and SfM candidates
/// (`points_per_m2`), and a triplet at 20 m looking at its centre with a
/// 15 deg triangulation angle.
fn ground_triplet(points_per_m2: f64) -> (Mesh, RayCaster, SparseCandidates, [Camera; 3]) {
    let mesh = crate::test_scenes::uniform_plane(60.0, Material::Ground);
    let caster = RayCaster::new(&mesh);
    let candidates = SparseCandidates::new(&mesh, points_per_m2, 11);
    let k = CampaignConfig::quick().planner.camera.intrinsics();
    let target = nalgebra::Point3::new(30.0, 30.0, 0.0);
    let cams = crate::test_scenes::triplet(k, 20.0, 15.0).map(|c| {
        let centre = c.center() + target.coords;
        Camera::look_at(k, centre, target).unwrap()
    });
    (mesh, caster, candidates, cams)
}

fn whole_plane() -> Aabb {
    Aabb {
        min: nalgebra::Point3::new(-1.0, -1.0, -1.0),
        max: nalgebra::Point3::new(61.0, 61.0, 1.0),
    }
}

/// Issue 34: the matcher got the renderer's true poses while labelgen and
/// the planner got SfM's. Shift SfM's estimates of all three cameras 1 m
/// up (a georeferencing error): the images are the same, and what vp-mvs
/// reconstructs must sit where those poses put it, 1 m above the truth.
#[test]
fn the_matcher_matches_with_the_sfm_poses() {
    let (mesh, caster, candidates, cams) = ground_triplet(0.5);
    let scene = Scene {
        mesh: &mesh,
        caster: &caster,
        texture_seed: 3,
        candidates: &candidates,
    };
    let cfg = CampaignConfig::quick();
    let up = nalgebra::Vector3::new(0.0, 0.0, 1.0);
    let sfm = cams.map(|c| {
        Camera::new(
            c.intrinsics,
            nalgebra::Translation3::from(up) * c.world_from_cam,
        )
    });
    let m = Matcher::new(&cfg).unwrap();
    let mut curves = CurveAccumulator::new(cfg.training.forest.bins.clone());
    let fl = m
        .fly_triplet(
            &mut Renders::new(scene, &cfg),
            (cams, sfm),
            [0, 1, 2],
            &whole_plane(),
            5,
            &mut curves,
        )
        .unwrap();
    assert_eq!(fl.sfm, sfm.to_vec(), "the flown set keeps its SfM poses");
    assert!(fl.fused.len() > 100, "{} fused points", fl.fused.len());
    let mean_z = fl.fused.iter().map(|p| p.position.z).sum::<f64>() / fl.fused.len() as f64;
    assert!(
        (mean_z - 1.0).abs() < 0.2,
        "fused points at z = {mean_z:.2} m: not matched with the SfM poses (1 m up)"
    );
    // The depths are the SfM cameras' (1 m farther along the nadir-ish
    // axis than the truth), so the truth finds them 1 m off: nothing
    // within 24 cm.
    assert!(fl.stats.measured * 100 < fl.stats.pixels, "{:?}", fl.stats);
}

/// Issue 34: the depth range was cut from the renderer's dense true depth.
/// Now it comes from SfM's sparse points only: with no sparse point in the
/// views (no candidates), COLMAP has no depth range and nothing is matched;
/// with them, the same triplet reconstructs.
#[test]
fn the_depth_range_comes_from_sparse_points_not_the_renderer() {
    let cfg = CampaignConfig::quick();
    let m = Matcher::new(&cfg).unwrap();
    let mut curves = CurveAccumulator::new(cfg.training.forest.bins.clone());
    let mut output = Vec::new();
    for density in [0.0, 0.5] {
        let (mesh, caster, candidates, cams) = ground_triplet(density);
        let scene = Scene {
            mesh: &mesh,
            caster: &caster,
            texture_seed: 3,
            candidates: &candidates,
        };
        let run = m
            .triplet(
                &mut Renders::new(scene, &cfg),
                (
                    [&cams[0], &cams[1], &cams[2]],
                    [&cams[0], &cams[1], &cams[2]],
                ),
                1,
                None,
                5,
                &mut curves,
            )
            .unwrap();
        output.push((run.sparse.len(), run.stats.output, run.stats.measured));
    }
    assert_eq!(output[0], (0, 0, 0), "{output:?}");
    assert!(output[1].0 > 0 && output[1].2 > 1000, "{output:?}");
}

#[test]
fn mvs_sgm_in_a_campaign_config_reconstructs_with_the_semi_global_matcher() {
    let path = std::path::Path::new("campaign.toml");
    let c = CampaignConfig::from_toml("mvs = \"sgm\"\n", path).unwrap();
    assert_eq!(c.mvs, MvsKind::Sgm);
    let m = Matcher::new(&c).unwrap();
    assert!(m.virtual_mvs.is_none());
    assert_eq!(m.params(7).algorithm, vp_mvs::Algorithm::Sgm);
    assert_eq!(m.params(7).seed, 7);
    // PatchMatch stays the default, whatever [patchmatch] says otherwise.
    let c = CampaignConfig::from_toml("", path).unwrap();
    assert_eq!(
        Matcher::new(&c).unwrap().params(7).algorithm,
        vp_mvs::Algorithm::PatchMatch
    );
    let e = CampaignConfig::from_toml("mvs = \"sgbm\"\n", path)
        .unwrap_err()
        .to_string();
    assert!(e.contains("sgm"), "{e}");
}
