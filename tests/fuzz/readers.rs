//! One test per reader: its seeds (real files from the test data where the
//! repository has them, else files our writers produce) and how it is
//! called, exactly as the command that reads such a file calls it.

use std::path::{Path, PathBuf};

use nalgebra::Point3;
use vp_scene::colmap;
use vp_scene::io::{encode_mesh, parse_mesh, FileType, MeshFormat, WriteOptions};
use vp_scene::plan::{GeodeticOrigin, Plan, PlannedView, Role};
use vp_scene::raster::{AngleBins, ConfidenceImage, Label, LabelImage};
use vp_scene::{Material, Mesh};

use crate::{chain, run, Reader};

fn root() -> PathBuf {
    PathBuf::from(env!("CARGO_MANIFEST_DIR"))
}

fn data(rel: &str) -> Vec<u8> {
    let p = root().join(rel);
    std::fs::read(&p).unwrap_or_else(|e| panic!("{}: {e}", p.display()))
}

/// A real text file cut after at most `max` bytes at a line end: the big
/// COLMAP models of the test data would make every case slow.
fn head(bytes: Vec<u8>, max: usize) -> Vec<u8> {
    if bytes.len() <= max {
        return bytes;
    }
    let cut = bytes[..max]
        .iter()
        .rposition(|&c| c == b'\n')
        .map_or(max, |i| i + 1);
    bytes[..cut].to_vec()
}

fn text(bytes: &[u8]) -> String {
    String::from_utf8_lossy(bytes).into_owned()
}

/// The bytes handed to a reader that takes a path (it reads the file itself).
fn via_file<T, E: std::error::Error + Send + Sync + 'static>(
    bytes: &[u8],
    path: &Path,
    read: impl Fn(&Path) -> Result<T, E>,
) -> Result<(), String> {
    std::fs::write(path, bytes).unwrap();
    read(path).map(drop).map_err(chain)
}

fn small_mesh() -> Mesh {
    Mesh::new(
        vec![
            Point3::new(0.0, 0.0, 0.0),
            Point3::new(1.5, 0.0, 0.25),
            Point3::new(1.0, 1.0, 0.0),
            Point3::new(0.0, 1.0, -0.5),
            Point3::new(0.5, 0.5, 2.0),
        ],
        vec![[0, 1, 2], [0, 2, 3], [0, 1, 4], [1, 2, 4]],
        Some(vec![
            Material::Ground,
            Material::Rock,
            Material::Tree,
            Material::Marker,
        ]),
    )
    .unwrap()
}

fn encoded(format: MeshFormat) -> Vec<u8> {
    let mut bytes = Vec::new();
    encode_mesh(&mut bytes, &small_mesh(), WriteOptions::new(format)).unwrap();
    bytes
}

const MESH_WHOLE: &[&str] = &["no vertices", "no faces", "empty"];

#[test]
fn fuzz_ply() {
    run(&Reader {
        name: "ply",
        file: "input.ply",
        seeds: vec![
            data("crates/scene/tests/data/meshes/bone.ply"),
            data("crates/scene/tests/data/meshes/colored_airplane.ply"),
            encoded(MeshFormat::PlyAscii),
            encoded(MeshFormat::PlyBinaryLittleEndian),
            encoded(MeshFormat::PlyBinaryBigEndian),
        ],
        text: true,
        reseal: false,
        whole_file: MESH_WHOLE,
        parse: Box::new(|b, p| parse_mesh(b, FileType::Ply, p).map(drop).map_err(chain)),
    });
}

#[test]
fn fuzz_obj() {
    run(&Reader {
        name: "obj",
        file: "input.obj",
        seeds: vec![
            head(data("crates/scene/tests/data/meshes/cow.obj"), 48 << 10),
            encoded(MeshFormat::Obj),
        ],
        text: true,
        reseal: false,
        whole_file: MESH_WHOLE,
        parse: Box::new(|b, p| parse_mesh(b, FileType::Obj, p).map(drop).map_err(chain)),
    });
}

const COLMAP: &str = "crates/scene/tests/data/colmap";
const REAL: &str = "tests/data/real-mvs/visp-cube/sparse";

fn colmap_seeds(file: &str, kind: &str) -> Vec<Vec<u8>> {
    let mut seeds = vec![data(&format!("{COLMAP}/hand/colmap_{kind}/{file}"))];
    let sfm = data(&format!("{COLMAP}/sfm/{kind}/{file}"));
    seeds.push(if kind == "txt" {
        head(sfm, 32 << 10)
    } else {
        sfm
    });
    if kind == "txt" {
        seeds.push(data(&format!("{COLMAP}/hand/vpctl_txt/{file}")));
        seeds.push(head(data(&format!("{REAL}/{file}")), 32 << 10));
    }
    seeds
}

#[test]
fn fuzz_colmap_cameras_txt() {
    run(&Reader {
        name: "colmap-cameras-txt",
        file: "cameras.txt",
        seeds: colmap_seeds("cameras.txt", "txt"),
        text: true,
        reseal: false,
        whole_file: &[],
        parse: Box::new(|b, p| colmap::parse_cameras(p, &text(b)).map(drop).map_err(chain)),
    });
}

#[test]
fn fuzz_colmap_images_txt() {
    run(&Reader {
        name: "colmap-images-txt",
        file: "images.txt",
        seeds: colmap_seeds("images.txt", "txt"),
        text: true,
        reseal: false,
        whole_file: &[],
        parse: Box::new(|b, p| colmap::parse_images(p, &text(b)).map(drop).map_err(chain)),
    });
}

#[test]
fn fuzz_colmap_points3d_txt() {
    run(&Reader {
        name: "colmap-points3d-txt",
        file: "points3D.txt",
        seeds: colmap_seeds("points3D.txt", "txt"),
        text: true,
        reseal: false,
        whole_file: &[],
        parse: Box::new(|b, p| colmap::parse_points3d(p, &text(b)).map(drop).map_err(chain)),
    });
}

#[test]
fn fuzz_colmap_cameras_bin() {
    run(&Reader {
        name: "colmap-cameras-bin",
        file: "cameras.bin",
        seeds: colmap_seeds("cameras.bin", "bin"),
        text: false,
        reseal: false,
        whole_file: &[],
        parse: Box::new(|b, p| colmap::parse_cameras_binary(p, b).map(drop).map_err(chain)),
    });
}

#[test]
fn fuzz_colmap_images_bin() {
    run(&Reader {
        name: "colmap-images-bin",
        file: "images.bin",
        seeds: colmap_seeds("images.bin", "bin"),
        text: false,
        reseal: false,
        whole_file: &[],
        parse: Box::new(|b, p| colmap::parse_images_binary(p, b).map(drop).map_err(chain)),
    });
}

#[test]
fn fuzz_colmap_points3d_bin() {
    run(&Reader {
        name: "colmap-points3d-bin",
        file: "points3D.bin",
        seeds: colmap_seeds("points3D.bin", "bin"),
        text: false,
        reseal: false,
        whole_file: &[],
        parse: Box::new(|b, p| colmap::parse_points3d_binary(p, b).map(drop).map_err(chain)),
    });
}

/// A COLMAP dense map written by our writer: `channels` planes of w x h.
fn dense_map(w: u32, h: u32, channels: usize) -> Vec<u8> {
    let mut out = format!("{w}&{h}&{channels}&").into_bytes();
    for i in 0..(w * h) as usize * channels {
        out.extend_from_slice(&(1.0 + (i % 7) as f32 * 0.25).to_le_bytes());
    }
    out
}

#[test]
fn fuzz_depth_map() {
    run(&Reader {
        name: "depth-map",
        file: "img.geometric.bin",
        seeds: vec![
            data(&format!("{COLMAP}/depth/ramp_5x3.geometric.bin")),
            dense_map(6, 4, 1),
        ],
        text: false,
        reseal: false,
        whole_file: &[],
        parse: Box::new(|b, p| colmap::parse_depth_map(p, b).map(drop).map_err(chain)),
    });
}

#[test]
fn fuzz_normal_map() {
    run(&Reader {
        name: "normal-map",
        file: "img.normal.bin",
        seeds: vec![dense_map(5, 3, 3), dense_map(2, 7, 3)],
        text: false,
        reseal: false,
        whole_file: &[],
        parse: Box::new(|b, p| colmap::parse_normal_map(p, b).map(drop).map_err(chain)),
    });
}

fn label_seed(w: u32, h: u32) -> Vec<u8> {
    let mut img = LabelImage::new(w, h);
    for y in 0..h {
        for x in 0..w {
            let l = match (x + 2 * y) % 3 {
                0 => Label::Unlabelled,
                1 => Label::Positive,
                _ => Label::Negative,
            };
            img.set(x, y, l, (x * 3) as f32).unwrap();
        }
    }
    img.to_bytes()
}

#[test]
fn fuzz_label_image() {
    run(&Reader {
        name: "label-image",
        file: "img.vplabel",
        seeds: vec![label_seed(7, 5), label_seed(1, 1)],
        text: false,
        reseal: true,
        whole_file: &[],
        parse: Box::new(|b, p| LabelImage::from_bytes(b, p).map(drop).map_err(chain)),
    });
}

fn confidence_seed(w: u32, h: u32, step: u32) -> Vec<u8> {
    let mut img = ConfidenceImage::zeros(w, h, step, AngleBins::paper()).unwrap();
    for (i, v) in img.values_mut().iter_mut().enumerate() {
        *v = (i % 11) as f32 / 10.0;
    }
    img.to_bytes()
}

#[test]
fn fuzz_confidence_image() {
    run(&Reader {
        name: "confidence-image",
        file: "img.vpconf",
        seeds: vec![confidence_seed(9, 6, 2), confidence_seed(4, 4, 1)],
        text: false,
        reseal: true,
        whole_file: &[],
        parse: Box::new(|b, p| ConfidenceImage::from_bytes(b, p).map(drop).map_err(chain)),
    });
}

fn forest_seed() -> Vec<u8> {
    use vp_forest::synthetic::{label_image, texture_image};
    use vp_forest::{train, TrainParams, TrainingSet};
    let img = texture_image(40, 40, 10, 4);
    let labels = label_image(&img, 2, 50.0, 4, |noisy, _| {
        if noisy {
            Label::Negative
        } else {
            Label::Positive
        }
    });
    let mut set = TrainingSet::new();
    set.add_image(&img.image, &[labels]).unwrap();
    let params = TrainParams {
        n_trees: 2,
        max_depth: 4,
        min_samples_split: 10,
        n_tests: 20,
        n_thresholds: 8,
        n_node_samples: 80,
        ..TrainParams::default()
    };
    train(&set, &params, 1).unwrap().to_bytes()
}

#[test]
fn fuzz_forest_model() {
    run(&Reader {
        name: "forest-model",
        file: "model.vpforest",
        seeds: vec![forest_seed()],
        text: false,
        reseal: true,
        whole_file: &[],
        parse: Box::new(|b, p| vp_forest::Forest::from_bytes(b, p).map(drop).map_err(chain)),
    });
}

fn plan_seed() -> Vec<u8> {
    let mut plan = Plan::new(Some(GeodeticOrigin::new(46.0, 10.3, 400.0).unwrap()));
    plan.home = plan.origin.map(vp_scene::plan::Home::origin_on_ground);
    for i in 0..3 {
        plan.waypoints.push(PlannedView {
            position: [10.0 * f64::from(i), -5.0, 40.0],
            yaw_deg: 90.0,
            pitch_deg: -45.0,
            roll_deg: 0.0,
            role: Role::TripletMember,
            triplet_id: Some(2),
            expected_gain: Some(0.25),
            angle_bin_deg: Some(12.5),
        });
    }
    plan.geofence = Some(vec![[-50.0, -50.0], [50.0, -50.0], [50.0, 50.0]]);
    serde_json::to_vec_pretty(&plan).unwrap()
}

#[test]
fn fuzz_plan_json() {
    run(&Reader {
        name: "plan-json",
        file: "plan.json",
        seeds: vec![plan_seed()],
        text: true,
        reseal: false,
        whole_file: &[],
        parse: Box::new(|b, p| Plan::from_json(&text(b), p).map(drop).map_err(chain)),
    });
}

#[test]
fn fuzz_roi_json() {
    let seeds = [
        vp_scene::roi::Roi::from_box([0.0, 1.0, 2.0, 3.0, 4.0, 5.0]).unwrap(),
        vp_scene::roi::Roi::Polygon {
            polygon: vec![[0.0, 0.0], [10.0, 0.0], [5.0, 8.0]],
            holes: vec![vec![[4.0, 1.0], [6.0, 1.0], [5.0, 3.0]]],
            z_min: -1.0,
            z_max: 30.0,
        },
    ];
    run(&Reader {
        name: "roi-json",
        file: "roi.json",
        seeds: seeds
            .iter()
            .map(|r| serde_json::to_vec_pretty(r).unwrap())
            .collect(),
        text: true,
        reseal: false,
        whole_file: &[],
        parse: Box::new(|b, p| via_file(b, p, vp_scene::roi::Roi::load)),
    });
}

#[test]
fn fuzz_planner_config_toml() {
    run(&Reader {
        name: "planner-toml",
        file: "planner.toml",
        seeds: vec![vp_planner::PlannerConfig::default_toml()
            .as_bytes()
            .to_vec()],
        text: true,
        reseal: false,
        whole_file: &[],
        parse: Box::new(|b, p| {
            vp_planner::PlannerConfig::from_toml(&text(b), p)
                .map(drop)
                .map_err(chain)
        }),
    });
}

#[test]
fn fuzz_campaign_config_toml() {
    run(&Reader {
        name: "campaign-toml",
        file: "campaign.toml",
        seeds: vec![
            vp_sim::campaign::CampaignConfig::demo()
                .to_toml()
                .unwrap()
                .into_bytes(),
            data("examples/paper-site.toml"),
        ],
        text: true,
        reseal: false,
        // The value itself, quoted: `strategy 'F0x4'`, `curve 'rock'`.
        whole_file: &["strategy '", "curve '"],
        parse: Box::new(|b, p| {
            vp_sim::campaign::CampaignConfig::from_toml(&text(b), p)
                .map(drop)
                .map_err(chain)
        }),
    });
}

#[test]
fn fuzz_label_params_toml() {
    run(&Reader {
        name: "labelgen-toml",
        file: "labels.toml",
        seeds: vec![toml::to_string(&vp_labelgen::LabelParams::default())
            .unwrap()
            .into_bytes()],
        text: true,
        reseal: false,
        whole_file: &[],
        parse: Box::new(|b, p| via_file(b, p, vp_labelgen::LabelParams::load)),
    });
}

#[test]
fn fuzz_train_params_toml() {
    run(&Reader {
        name: "forest-toml",
        file: "train.toml",
        seeds: vec![toml::to_string(&vp_forest::TrainParams::default())
            .unwrap()
            .into_bytes()],
        text: true,
        reseal: false,
        whole_file: &[],
        parse: Box::new(|b, p| {
            via_file(b, p, |p| {
                vp_scene::config_file::load_toml::<vp_forest::TrainParams>(p)
            })
        }),
    });
}

#[test]
fn fuzz_triplet_list() {
    let seed = "# vpctl labelgen triplets v1\n# bin\tangle_deg\timage1\timage2\timage3\n\
                0\t5.0000\ta.jpg\tb.jpg\tc.jpg\n1\t15.2500\tb.jpg\tc.jpg\td.jpg\n\
                3\t33.0000\tsub/e.png\ta.jpg\td.jpg\n";
    run(&Reader {
        name: "triplet-list",
        file: "triplets.txt",
        seeds: vec![seed.as_bytes().to_vec()],
        text: true,
        reseal: false,
        whole_file: &[],
        parse: Box::new(|b, p| via_file(b, p, vp_labelgen::triplets::read_triplet_list)),
    });
}

#[test]
fn fuzz_wpl() {
    let seed = "QGC WPL 110\n\
        0\t1\t0\t16\t0\t0\t0\t0\t46.00000000\t10.30000000\t400.000000\t1\n\
        1\t0\t3\t22\t0\t0\t0\t0\t0.00000000\t0.00000000\t20.000000\t1\n\
        2\t0\t3\t16\t2.000000\t1.000000\t0\t90.000000\t46.00010000\t10.30020000\t40.000000\t1\n\
        3\t0\t2\t205\t-45.000000\t0\t90.000000\t0\t0\t0\t2.000000\t1\n\
        4\t0\t2\t203\t0\t0\t0\t0\t1\t0\t0.000000\t1\n\
        5\t0\t2\t20\t0\t0\t0\t0\t0\t0\t0.000000\t1\n";
    run(&Reader {
        name: "wpl",
        file: "mission.waypoints",
        seeds: vec![seed.as_bytes().to_vec()],
        text: true,
        reseal: false,
        whole_file: &[],
        parse: Box::new(|b, p| vp_mission::parse_wpl(&text(b), p).map(drop).map_err(chain)),
    });
}
