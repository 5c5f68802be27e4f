//! What the CLI test binaries share: running `vpctl` and the test data.
#![allow(dead_code)]

use std::path::{Path, PathBuf};
use std::process::{Command, Output};

use vp_planner::grid::{grid_views, GridParams};
use vp_scene::colmap::{self, CameraModel, ColmapCamera, ColmapImage, Reconstruction};
use vp_scene::io::{write_mesh, MeshFormat};
use vp_scene::plan::Role;
use vp_scene::procedural::{generate_site, Site, SiteParams};
use vp_scene::{Aabb, Intrinsics};

/// Runs the `vpctl` binary with `args`.
pub fn vpctl(args: &[&str]) -> Output {
    Command::new(env!("CARGO_BIN_EXE_vpctl"))
        .args(args)
        .output()
        .expect("vpctl runs")
}

/// Standard output as text.
pub fn stdout(o: &Output) -> String {
    String::from_utf8_lossy(&o.stdout).into_owned()
}

/// Standard error as text.
pub fn stderr(o: &Output) -> String {
    String::from_utf8_lossy(&o.stderr).into_owned()
}

/// Test data of vp-scene: real files written by MeshLab and COLMAP.
pub fn scene_data(rel: &str) -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("../scene/tests/data")
        .join(rel)
}

/// A site mesh, a COLMAP model of an initial grid flight over it, and a small config.
pub fn plan_fixture(dir: &Path) -> Site {
    let site = generate_site(&SiteParams {
        seed: 2,
        target_faces: 20_000,
        ..SiteParams::default()
    })
    .unwrap();
    write_mesh(
        &dir.join("site.ply"),
        &site.mesh,
        MeshFormat::PlyBinaryLittleEndian,
    )
    .unwrap();
    let k = Intrinsics {
        width: 1200,
        height: 800,
        fx: 1800.0,
        fy: 1800.0,
        cx: 600.0,
        cy: 400.0,
    };
    let b = site.rock_bounds;
    let c = nalgebra::center(&b.min, &b.max);
    let fp = Aabb {
        min: nalgebra::Point3::new(c.x - 22.0, c.y - 22.0, b.min.z),
        max: nalgebra::Point3::new(c.x + 22.0, c.y + 22.0, b.max.z),
    };
    let params = GridParams {
        height_m: 50.0,
        role: Role::Initial,
        ..GridParams::default()
    };
    let mut rec = Reconstruction::default();
    rec.cameras.insert(
        1,
        ColmapCamera {
            id: 1,
            model: CameraModel::Pinhole,
            width: 1200,
            height: 800,
            params: vec![1800.0, 1800.0, 600.0, 400.0],
        },
    );
    for (i, v) in grid_views(&fp, &params, k).unwrap().iter().enumerate() {
        let id = i as u32 + 1;
        rec.images.insert(
            id,
            ColmapImage {
                id,
                camera_id: 1,
                name: format!("img_{id:03}.jpg"),
                cam_from_world: v.to_camera(k).cam_from_world(),
                points2d: Vec::new(),
            },
        );
    }
    std::fs::create_dir_all(dir.join("model")).unwrap();
    colmap::write_text(&dir.join("model"), &rec).unwrap();
    // The model is already metric ENU: its frame is the identity.
    colmap::ModelFrame {
        origin: vp_scene::plan::GeodeticOrigin::default(),
        sim3: colmap::Sim3 {
            scale: 1.0,
            rotation_wxyz: [1.0, 0.0, 0.0, 0.0],
            translation: [0.0; 3],
        },
        rms_m: 0.0,
        residuals: Vec::new(),
    }
    .save(&dir.join("model"))
    .unwrap();
    let v = site.flight_volume;
    std::fs::write(
        dir.join("plan.toml"),
        format!(
            "n_triangles = 300\nn_surrogates = 600\nn_selected = 60\nn_triplets = 2\nflight_volume = [[{}, {}, {}], [{}, {}, {}]]\n",
            v.min.x, v.min.y, v.min.z, v.max.x, v.max.y, v.max.z
        ),
    )
    .unwrap();
    site
}
