//! The GLB writer: container layout, the Y-up frame, per-material
//! primitives, determinism and the file checks. (The Khronos validator
//! checks the files end to end in the CLI's `views` tests.)
// Exact: the written f32 values are exact images of small integers.
#![allow(clippy::float_cmp)]

use gltf_json as json;
use nalgebra::{Point3, Vector3};

use super::*;
use crate::camera::Intrinsics;

fn two_material_mesh() -> Mesh {
    Mesh::new(
        vec![
            Point3::new(0.0, 0.0, 0.0),
            Point3::new(1.0, 0.0, 0.0),
            Point3::new(0.0, 1.0, 0.0),
            Point3::new(1.0, 1.0, 2.0),
        ],
        vec![[0, 1, 2], [1, 3, 2]],
        Some(vec![Material::Rock, Material::Grass]),
    )
    .unwrap()
}

fn u32_at(b: &[u8], at: usize) -> u32 {
    u32::from_le_bytes(b[at..at + 4].try_into().unwrap())
}

/// The JSON document and the BIN chunk of a GLB, checking the container.
fn split(glb: &[u8]) -> (json::Root, Vec<u8>) {
    assert_eq!(&glb[0..4], b"glTF");
    assert_eq!(u32_at(glb, 4), 2, "version");
    assert_eq!(u32_at(glb, 8) as usize, glb.len(), "total length");
    let json_len = u32_at(glb, 12) as usize;
    assert_eq!(&glb[16..20], b"JSON");
    assert_eq!(json_len % 4, 0);
    let root = json::Root::from_slice(&glb[20..20 + json_len]).unwrap();
    let at = 20 + json_len;
    if at == glb.len() {
        return (root, Vec::new());
    }
    let bin_len = u32_at(glb, at) as usize;
    assert_eq!(&glb[at + 4..at + 8], b"BIN\0");
    assert_eq!(bin_len % 4, 0);
    assert_eq!(at + 8 + bin_len, glb.len());
    (root, glb[at + 8..].to_vec())
}

/// The f32 triples of a VEC3 accessor.
fn vec3s(root: &json::Root, bin: &[u8], a: json::Index<json::Accessor>) -> Vec<[f32; 3]> {
    let acc = &root.accessors[a.value()];
    let view = &root.buffer_views[acc.buffer_view.unwrap().value()];
    let start = view.byte_offset.unwrap().0 as usize;
    (0..acc.count.0 as usize)
        .map(|i| {
            let f = |k: usize| {
                f32::from_le_bytes(bin[start + 12 * i + 4 * k..][..4].try_into().unwrap())
            };
            [f(0), f(1), f(2)]
        })
        .collect()
}

fn position_accessor(p: &json::mesh::Primitive) -> json::Index<json::Accessor> {
    p.attributes[&json::validation::Checked::Valid(json::mesh::Semantic::Positions)]
}

#[test]
fn enu_z_up_is_written_as_gltf_y_up_without_a_mirror() {
    let e = enu_to_gltf(&Point3::new(1.0, 0.0, 0.0));
    let n = enu_to_gltf(&Point3::new(0.0, 1.0, 0.0));
    let u = enu_to_gltf(&Point3::new(0.0, 0.0, 1.0));
    assert_eq!(u, [0.0, 1.0, 0.0], "up is +Y");
    assert_eq!(e, [1.0, 0.0, 0.0], "east is +X");
    assert_eq!(n, [0.0, 0.0, -1.0], "north is -Z");
    // A rotation keeps handedness: east x north = up in both frames.
    let v = |a: [f32; 3]| Vector3::new(a[0], a[1], a[2]);
    assert_eq!(v(e).cross(&v(n)), v(u));
}

#[test]
fn a_mesh_becomes_one_primitive_per_material_sharing_its_vertices() {
    let mut scene = GltfScene::new();
    scene.add_mesh("site", &two_material_mesh()).unwrap();
    let (root, bin) = split(&scene.to_glb().unwrap());
    assert_eq!(root.meshes.len(), 1);
    let prims = &root.meshes[0].primitives;
    assert_eq!(prims.len(), 2);
    assert_eq!(position_accessor(&prims[0]), position_accessor(&prims[1]));
    let colours: Vec<[f32; 4]> = prims
        .iter()
        .map(|p| {
            root.materials[p.material.unwrap().value()]
                .pbr_metallic_roughness
                .base_color_factor
                .0
        })
        .collect();
    assert_ne!(colours[0], colours[1], "rock and grass differ");
    let pos = vec3s(&root, &bin, position_accessor(&prims[0]));
    assert_eq!(pos[3], [1.0, 2.0, -1.0], "ENU (1, 1, 2) is glTF (1, 2, -1)");
    let acc = &root.accessors[position_accessor(&prims[0]).value()];
    assert_eq!(
        acc.min.as_ref().unwrap(),
        &serde_json::json!([0.0, 0.0, -1.0])
    );
    assert_eq!(
        acc.max.as_ref().unwrap(),
        &serde_json::json!([1.0, 2.0, 0.0])
    );
    assert_eq!(root.nodes[0].name.as_deref(), Some("site"));
    assert_eq!(root.scenes[0].nodes.len(), 1);
}

#[test]
fn frusta_and_paths_are_lines_and_the_bytes_repeat() {
    let k = Intrinsics::from_hfov(40, 30, 60.0).unwrap();
    let cam = Camera::from_yaw_pitch(
        k,
        Point3::new(0.0, 0.0, 10.0),
        0.0,
        -std::f64::consts::FRAC_PI_2,
    );
    let mut scene = GltfScene::new();
    scene
        .add_frusta("cameras", &[cam, cam], 2.0, [255, 150, 0])
        .unwrap();
    scene
        .add_line_strip(
            "path",
            vec![Point3::new(0.0, 0.0, 10.0), Point3::new(5.0, 0.0, 10.0)],
            [255, 255, 255],
        )
        .unwrap();
    // Nothing to draw adds no node (a glTF accessor needs a count >= 1).
    scene
        .add_line_strip("one point", vec![Point3::origin()], [0, 0, 0])
        .unwrap();
    scene.add_frusta("none", &[], 2.0, [0, 0, 0]).unwrap();
    assert_eq!(scene.n_nodes(), 2);
    let glb = scene.to_glb().unwrap();
    assert_eq!(glb, scene.to_glb().unwrap(), "same scene, same bytes");
    let (root, bin) = split(&glb);
    let mode = |m: usize| root.meshes[m].primitives[0].mode;
    assert_eq!(
        mode(0),
        json::validation::Checked::Valid(json::mesh::Mode::Lines)
    );
    assert_eq!(
        mode(1),
        json::validation::Checked::Valid(json::mesh::Mode::LineStrip)
    );
    // 10 segments per camera: 4 edges, 4 rectangle sides, 2 for the up mark.
    let lines = vec3s(
        &root,
        &bin,
        position_accessor(&root.meshes[0].primitives[0]),
    );
    assert_eq!(lines.len(), 2 * 2 * 10);
    // A nadir camera 10 m up: the apex at glTF y = 10, the image 2 m below.
    assert_eq!(lines[0], [0.0, 10.0, 0.0]);
    assert!((lines[1][1] - 8.0).abs() < 1e-5, "{:?}", lines[1]);
}

#[test]
fn an_empty_scene_is_a_valid_document_without_buffer() {
    let (root, bin) = split(&GltfScene::new().to_glb().unwrap());
    assert!(bin.is_empty() && root.buffers.is_empty() && root.scenes.is_empty());
    assert_eq!(root.asset.version, "2.0");
}

#[test]
fn bad_input_is_refused_naming_the_file_without_partial_output() {
    let dir = tempfile::tempdir().unwrap();
    let mut scene = GltfScene::new();
    scene.add_mesh("site", &two_material_mesh()).unwrap();
    for name in ["scene.gltf", "scene.ply", "scene"] {
        let p = dir.path().join(name);
        let e = write_glb(&p, &scene, false).unwrap_err().to_string();
        assert!(e.contains(name) && e.contains(".glb"), "{e}");
        assert!(!p.exists());
    }
    let p = dir.path().join("Scene.GLB");
    write_glb(&p, &scene, false).unwrap();
    let e = write_glb(&p, &scene, false).unwrap_err().to_string();
    assert!(e.contains("Scene.GLB"), "{e}");
    write_glb(&p, &scene, true).unwrap();
    let e = write_glb(&dir.path().join("missing/dir/s.glb"), &scene, false)
        .unwrap_err()
        .to_string();
    assert!(e.contains("s.glb"), "{e}");
    assert_eq!(
        std::fs::read_dir(dir.path()).unwrap().count(),
        1,
        "no temporary files left"
    );
    let nan = Mesh {
        vertices: vec![Point3::new(f64::NAN, 0.0, 0.0); 3],
        faces: vec![[0, 1, 2]],
        materials: None,
    };
    assert!(GltfScene::new().add_mesh("nan", &nan).is_err());
    let bad = Mesh {
        vertices: vec![Point3::origin(); 3],
        faces: vec![[0, 1, 7]],
        materials: None,
    };
    let e = GltfScene::new()
        .add_mesh("bad", &bad)
        .unwrap_err()
        .to_string();
    assert!(e.contains("face 0"), "{e}");
}
