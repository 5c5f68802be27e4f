//! Issue 6's acceptance on a procedural site where the truth is known:
//! vp-sim's virtual MVS reconstructs triplets, vp-labelgen labels them, and
//! the labels are checked against what the virtual MVS really did per pixel.

use nalgebra::Point3;
use vpctl_suite::labelgen::{
    generate_labels, LabelParams, MissingPartMeshes, TripletReconstruction, View,
};
use vpctl_suite::scene::camera::{Camera, Intrinsics};
use vpctl_suite::scene::procedural::{generate_site, SiteParams};
use vpctl_suite::scene::raster::Label;
use vpctl_suite::scene::raycast::RayCaster;
use vpctl_suite::scene::Material;
use vpctl_suite::sim::virtual_mvs::{level_camera, PixelStatus, PixelTruth};
use vpctl_suite::sim::{MvsProfile, VirtualMvs};

/// Reconstructions of ring triplets around the rock, with the per-pixel truth.
type Simulated = (Vec<TripletReconstruction>, Vec<[Vec<PixelTruth>; 3]>);

fn simulate(mesh_seed: u64) -> (vpctl_suite::scene::Mesh, Simulated) {
    let site = generate_site(&SiteParams {
        seed: mesh_seed,
        target_faces: 40_000,
        ..SiteParams::default()
    })
    .unwrap();
    let mesh = &site.mesh;
    let caster = RayCaster::new(mesh);
    let rb = site.rock_bounds;
    let focus = Point3::new(
        0.5 * (rb.min.x + rb.max.x),
        0.5 * (rb.min.y + rb.max.y),
        rb.max.z,
    );
    let k = Intrinsics::from_hfov(240, 180, 60.0).unwrap();
    // 36 cameras on a ring 22 m around the rock, 14 m above its top.
    let cams: Vec<Camera> = (0..36)
        .map(|i| {
            let a = f64::from(i) * 10f64.to_radians();
            let c = focus + nalgebra::Vector3::new(22.0 * a.cos(), 22.0 * a.sin(), 14.0);
            Camera::look_at(k, c, focus).unwrap()
        })
        .collect();
    let mvs = VirtualMvs::new(MvsProfile::sure_like()).unwrap();
    // Triplets (i, i+s, i+2s): s = 1 gives ~17 deg, s = 2 ~ 34 deg, s = 3 ~ 50 deg.
    let mut recs = Vec::new();
    let mut truths: Vec<[Vec<PixelTruth>; 3]> = Vec::new();
    for (t, (start, step)) in [0usize, 9, 18, 27]
        .iter()
        .flat_map(|&i| [(i, 1usize), (i + 3, 2), (i + 1, 3)])
        .enumerate()
    {
        let ids = [start % 36, (start + step) % 36, (start + 2 * step) % 36];
        for level in [1u8, 2] {
            let triplet = ids.map(|i| &cams[i]);
            let views = mvs
                .reconstruct_with_truth(
                    mesh,
                    &caster,
                    triplet,
                    level,
                    1000 + t as u64 * 10 + u64::from(level),
                )
                .unwrap();
            let [v0, v1, v2] = views;
            let view = |i: usize, v: &vpctl_suite::sim::virtual_mvs::MvsView| View {
                name: format!("img{:02}", ids[i]),
                camera: level_camera(&cams[ids[i]], level).unwrap(),
                depth: v.depth.clone(),
            };
            recs.push(TripletReconstruction {
                id: format!("t{t:02}/level{level}"),
                views: [view(0, &v0), view(1, &v1), view(2, &v2)],
            });
            truths.push([v0.truth, v1.truth, v2.truth]);
        }
    }
    (site.mesh, (recs, truths))
}

#[test]
fn labels_of_virtual_mvs_triplets_are_98_percent_right() {
    let (mesh, (recs, truths)) = simulate(21);
    let meshes = MissingPartMeshes::new(&mesh, 3);
    let labels = generate_labels(&recs, Some(&meshes), &LabelParams::default()).unwrap();

    let (mut right, mut labelled, mut surface) = (0usize, 0usize, 0usize);
    let (mut grass_holes, mut grass_holes_negative) = (0usize, 0usize);
    for rl in &labels {
        let r = recs.iter().position(|r| r.id == rl.id).unwrap();
        for (img, truth_v) in rl.labels.iter().zip(&truths[r]) {
            for y in 0..img.height() {
                for x in 0..img.width() {
                    let truth = truth_v[(y * img.width() + x) as usize];
                    if truth.status == PixelStatus::NoSurface {
                        continue;
                    }
                    surface += 1;
                    let mvs_right = truth.status == PixelStatus::Reconstructed;
                    let label = img.label(x, y);
                    if truth.status == PixelStatus::Failed
                        && truth.material == Some(Material::Grass)
                        && truth.angle_deg > 30.0
                    {
                        grass_holes += 1;
                        grass_holes_negative += usize::from(label == Label::Negative);
                    }
                    match label {
                        Label::Unlabelled => {}
                        Label::Positive => {
                            labelled += 1;
                            right += usize::from(mvs_right);
                        }
                        Label::Negative => {
                            labelled += 1;
                            right += usize::from(!mvs_right);
                        }
                    }
                }
            }
        }
    }
    let accuracy = right as f64 / labelled as f64;
    let share = labelled as f64 / surface as f64;
    let grass = grass_holes_negative as f64 / grass_holes.max(1) as f64;
    println!(
        "labels: {:.2}% correct, {:.1}% of surface pixels labelled ({labelled} of {surface}); \
         grass holes above 30 deg labelled negative: {grass_holes_negative} of {grass_holes} ({:.1}%)",
        100.0 * accuracy,
        100.0 * share,
        100.0 * grass
    );
    assert!(accuracy >= 0.98, "accuracy {accuracy}");
    assert!(share >= 0.30, "labelled share {share}");
    assert!(
        grass_holes > 200,
        "the scene must show grass holes at large angles"
    );
    assert!(
        grass > 0.2,
        "grass holes at large angles must become negatives: {grass}"
    );
}
