//! `vpctl labelgen` end to end on files: a procedural site, its sparse
//! model, mesh and per-triplet depth maps written the way a user has them.

use std::path::{Path, PathBuf};
use std::process::Output;

use nalgebra::Point3;
use vp_labelgen::io::depth_map_path;
use vp_labelgen::synthetic::sparse_model;
use vp_labelgen::triplets::{write_triplet_list, Triplet};
use vp_scene::colmap::{write_depth_map, write_text, DepthMap};
use vp_scene::procedural::{box_mesh, heightfield};
use vp_scene::raster::{Label, LabelImage};
use vp_scene::raycast::RayCaster;
use vp_scene::{Camera, Intrinsics};

mod common;
use common::vpctl;

fn text(b: &[u8]) -> String {
    String::from_utf8_lossy(b).into_owned()
}

struct Fixture {
    _dir: tempfile::TempDir,
    root: PathBuf,
}

impl Fixture {
    fn p(&self, rel: &str) -> String {
        self.root.join(rel).to_str().unwrap().to_string()
    }
}

/// Four triplets over a terrain with a building, depth maps at levels 1 and 2.
fn fixture() -> Fixture {
    let dir = tempfile::tempdir().unwrap();
    let root = dir.path().to_path_buf();
    let mut mesh = heightfield(40, 40, 2.0, |x, y| {
        1.5 * (x / 12.0).sin() * (y / 10.0).cos()
    });
    mesh.append(&box_mesh(
        Point3::new(3.0, -10.0, -1.0),
        Point3::new(9.0, -4.0, 6.0),
    ));
    let caster = RayCaster::new(&mesh);
    let k = Intrinsics::from_hfov(96, 72, 60.0).unwrap();
    let mut cams = Vec::new();
    let mut triplets = Vec::new();
    for t in 0..4usize {
        let (cx, cy) = (-8.0 + 16.0 * (t % 2) as f64, -8.0 + 16.0 * (t / 2) as f64);
        let angle: f64 = [8.0, 15.0, 25.0, 35.0][t];
        let r = 2.0 * 32.0 * (0.5f64 * angle.to_radians()).tan() / 3f64.sqrt();
        let mut names = Vec::new();
        for i in 0..3 {
            let a = 0.4 * t as f64 + i as f64 * 2.0 * std::f64::consts::PI / 3.0;
            let c = Point3::new(cx + r * a.cos(), cy + r * a.sin(), 32.0);
            let name = format!("img{t}{i}.jpg");
            cams.push((
                name.clone(),
                Camera::look_at(k, c, Point3::new(cx, cy, 0.0)).unwrap(),
            ));
            names.push(name);
        }
        triplets.push(Triplet {
            bin: 0,
            angle_deg: angle,
            images: [names[0].clone(), names[1].clone(), names[2].clone()],
        });
    }
    let points: Vec<Point3<f64>> = mesh.vertices.iter().step_by(3).copied().collect();
    write_text(&root.join("model"), &sparse_model(&cams, &caster, &points)).unwrap();
    vp_scene::io::write_mesh(
        &root.join("mesh.ply"),
        &mesh,
        vp_scene::io::MeshFormat::PlyBinaryLittleEndian,
    )
    .unwrap();
    write_triplet_list(&root.join("triplets.txt"), &triplets).unwrap();
    for (t, tr) in triplets.iter().enumerate() {
        for level in 1..=2u32 {
            for name in &tr.images {
                let cam = cams.iter().find(|(n, _)| n == name).unwrap().1;
                let scaled = Camera::new(
                    cam.intrinsics.scaled(0.5f64.powi(level as i32 - 1)),
                    cam.world_from_cam,
                );
                let (depth, _) = caster.render_depth(&scaled);
                let k = scaled.intrinsics;
                let path = depth_map_path(&root.join("depth"), &format!("t{t:04}"), level, name);
                std::fs::create_dir_all(path.parent().unwrap()).unwrap();
                write_depth_map(
                    &path,
                    &DepthMap {
                        width: k.width,
                        height: k.height,
                        data: depth,
                    },
                )
                .unwrap();
            }
        }
    }
    Fixture { _dir: dir, root }
}

fn run_args(f: &Fixture, out: &str) -> Vec<String> {
    [
        "labelgen",
        "run",
        "--colmap",
        &f.p("model"),
        "--triplets",
        &f.p("triplets.txt"),
        "--depth-dir",
        &f.p("depth"),
        "--mesh",
        &f.p("mesh.ply"),
        "--out",
        &f.p(out),
        "--frame-unchecked",
    ]
    .map(String::from)
    .to_vec()
}

fn call(args: &[String]) -> Output {
    vpctl(&args.iter().map(String::as_str).collect::<Vec<_>>())
}

#[test]
fn triplets_command_writes_list_and_image_lists() {
    let f = fixture();
    let args = [
        "labelgen",
        "triplets",
        "--colmap",
        &f.p("model"),
        "--per-bin",
        "2",
        "--seed",
        "5",
        "--min-shared-points",
        "10",
        "--out",
        &f.p("sampled.txt"),
        "--image-lists",
        &f.p("lists"),
    ];
    let o = vpctl(&args);
    assert!(o.status.success(), "{}", text(&o.stderr));
    let list = std::fs::read_to_string(f.p("sampled.txt")).unwrap();
    let lines: Vec<&str> = list.lines().filter(|l| !l.starts_with('#')).collect();
    assert!(!lines.is_empty());
    assert!(text(&o.stdout).contains(&format!("triplets: {}", lines.len())));
    for l in &lines {
        assert_eq!(l.split('\t').count(), 5, "{l}");
    }
    assert!(Path::new(&f.p("lists/t0000.txt")).is_file());
    // Same seed, same list; existing output is not overwritten.
    let o = vpctl(&args);
    assert_eq!(o.status.code(), Some(2), "{}", text(&o.stderr));
    assert!(text(&o.stderr).contains("already exists"));
}

#[test]
fn run_command_writes_labels_and_summary() {
    let f = fixture();
    let o = call(&run_args(&f, "labels"));
    assert!(o.status.success(), "{}", text(&o.stderr));
    assert!(
        text(&o.stdout).contains("reconstructions: 8"),
        "{}",
        text(&o.stdout)
    );
    let summary: serde_json_value::Value = serde_json_value::parse(&f.p("labels/summary.json"));
    assert!(summary.positive > 0, "{summary:?}");
    let img = LabelImage::load(Path::new(&f.p("labels/t0000/level1/img00.jpg.vplabel"))).unwrap();
    assert_eq!((img.width(), img.height()), (96, 72));
    assert!(img.count(Label::Positive) > 0);
    // Exact depth maps: nothing voted negative.
    assert_eq!(summary.negative_voted, 0);
    // A second run refuses to overwrite.
    let o = call(&run_args(&f, "labels"));
    assert_eq!(o.status.code(), Some(2));
}

/// Reads the two numbers the tests check from summary.json without a JSON
/// dependency in the test (vpctl's own output format is what is checked).
mod serde_json_value {
    #[derive(Debug)]
    pub struct Value {
        pub positive: u64,
        pub negative_voted: u64,
    }
    fn field(s: &str, name: &str) -> u64 {
        let key = format!("\"{name}\":");
        let at = s.find(&key).unwrap() + key.len();
        s[at..]
            .trim_start()
            .split(|c: char| !c.is_ascii_digit())
            .next()
            .unwrap()
            .parse()
            .unwrap()
    }
    pub fn parse(path: &str) -> Value {
        let s = std::fs::read_to_string(path).unwrap();
        Value {
            positive: field(&s, "positive"),
            negative_voted: field(&s, "negative_voted"),
        }
    }
}

#[test]
fn bad_depth_maps_are_named_and_leave_no_output() {
    let f = fixture();
    let target = depth_map_path(&f.root.join("depth"), "t0001", 2, "img11.jpg");
    // Wrong size.
    write_depth_map(
        &target,
        &DepthMap {
            width: 10,
            height: 30,
            data: vec![1.0; 300],
        },
    )
    .unwrap();
    let o = call(&run_args(&f, "out1"));
    assert_eq!(o.status.code(), Some(2));
    let err = text(&o.stderr);
    assert!(
        err.contains("img11.jpg.geometric.bin") && err.contains("depth map is 10x30"),
        "{err}"
    );
    assert!(!Path::new(&f.p("out1")).exists());
    // NaN depth.
    let mut data = vec![20.0f32; 48 * 36];
    data[48 * 2 + 5] = f32::NAN;
    write_depth_map(
        &target,
        &DepthMap {
            width: 48,
            height: 36,
            data,
        },
    )
    .unwrap();
    let o = call(&run_args(&f, "out2"));
    assert_eq!(o.status.code(), Some(2));
    let err = text(&o.stderr);
    assert!(err.contains("pixel (5, 2)") && err.contains("NaN"), "{err}");
    // Missing map.
    std::fs::remove_file(&target).unwrap();
    let o = call(&run_args(&f, "out3"));
    assert_eq!(o.status.code(), Some(2));
    assert!(
        text(&o.stderr).contains("no depth map for image \"img11.jpg\""),
        "{}",
        text(&o.stderr)
    );
    // Triplet naming an image the model does not have.
    std::fs::write(
        f.p("triplets.txt"),
        "0\t5.0\timg00.jpg\timg01.jpg\tnope.jpg\n",
    )
    .unwrap();
    let o = call(&run_args(&f, "out4"));
    assert_eq!(o.status.code(), Some(2));
    assert!(text(&o.stderr).contains("nope.jpg"), "{}", text(&o.stderr));
}

/// Regression (issue 39): `labelgen run --out <folder> --force` wrote into
/// any folder, the current one or its own depth maps' folder included.
#[test]
fn labelgen_run_never_deletes_what_it_did_not_write() {
    let f = fixture();
    let args = [
        "labelgen",
        "run",
        "--colmap",
        "model",
        "--triplets",
        "triplets.txt",
        "--depth-dir",
        "depth",
        "--mesh",
        "mesh.ply",
        "--frame-unchecked",
    ];
    common::assert_output_guards(&f.root, &args, "depth");
}

/// Every `.vplabel` file under `dir`, by its path relative to `dir`.
fn label_files(dir: &Path) -> std::collections::BTreeMap<PathBuf, Vec<u8>> {
    common::snapshot(dir)
        .into_iter()
        .filter(|(p, _)| p.extension().is_some_and(|e| e == "vplabel"))
        .collect()
}

/// An OpenDroneMap project's reconstruction (`--opensfm`, georeferenced by
/// its own `reference_lla`, so with the frame checked) samples the same
/// triplets and gives the same labels as its COLMAP twin.
#[test]
fn an_odm_project_labels_as_its_colmap_twin() {
    let f = fixture();
    common::opensfm::as_opensfm(&f.root.join("model"), &f.root.join("odm"));
    for (flag, model, out) in [
        ("--colmap", "model", "colmap.txt"),
        ("--opensfm", "odm", "odm.txt"),
    ] {
        let o = call(
            &[
                "labelgen",
                "triplets",
                flag,
                &f.p(model),
                "--per-bin",
                "3",
                "--min-shared-points",
                "5",
                "--out",
                &f.p(out),
            ]
            .map(String::from),
        );
        assert!(o.status.success(), "{flag}: {}", text(&o.stderr));
    }
    let colmap_list = std::fs::read(f.p("colmap.txt")).unwrap();
    assert!(!colmap_list.is_empty());
    assert_eq!(colmap_list, std::fs::read(f.p("odm.txt")).unwrap());

    let o = call(&run_args(&f, "labels-colmap"));
    assert!(o.status.success(), "{}", text(&o.stderr));
    let mut args = run_args(&f, "labels-odm");
    let at = args.iter().position(|a| a == "--colmap").unwrap();
    args[at] = "--opensfm".into();
    args[at + 1] = f.p("odm");
    args.retain(|a| a != "--frame-unchecked");
    let o = call(&args);
    assert!(o.status.success(), "{}", text(&o.stderr));
    let colmap_labels = label_files(Path::new(&f.p("labels-colmap")));
    assert_eq!(colmap_labels.len(), 24, "{:?}", colmap_labels.keys());
    assert!(colmap_labels == label_files(Path::new(&f.p("labels-odm"))));
}
