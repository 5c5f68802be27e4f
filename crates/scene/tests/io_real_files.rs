//! The readers on files written by other tools (MeshLab/VCGLIB), not by us.

use std::path::{Path, PathBuf};

use vp_scene::io::{encode_mesh, load_mesh_raw, parse_mesh, read_mesh, MeshFormat, WriteOptions};
use vp_scene::Mesh;

fn data(name: &str) -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("tests/data/meshes")
        .join(name)
}

/// Checks counts and bounds against the values trimesh measured
/// (tests/data/meshes/README.md).
fn check(mesh: &Mesh, vertices: usize, faces: usize, min: [f64; 3], max: [f64; 3]) {
    assert_eq!(mesh.n_vertices(), vertices);
    assert_eq!(mesh.n_faces(), faces);
    let b = mesh.bounds();
    for k in 0..3 {
        assert!((b.min[k] - min[k]).abs() < 1e-3, "min[{k}] = {}", b.min[k]);
        assert!((b.max[k] - max[k]).abs() < 1e-3, "max[{k}] = {}", b.max[k]);
    }
    assert_eq!(mesh.materials, None);
}

#[test]
fn meshlab_binary_ply_with_double_coordinates_and_colours() {
    let mesh = load_mesh_raw(&data("colored_airplane.ply")).unwrap();
    check(
        &mesh,
        7017,
        10796,
        [-0.9897, -0.212, -0.602],
        [0.9752, 0.1192, 0.4747],
    );
    // Values decoded by hand from the file (struct.unpack in Python).
    assert_eq!(
        mesh.vertices[0].coords.as_slice(),
        &[-0.002_913, 0.117_016, -0.583_723]
    );
    assert_eq!(
        mesh.vertices[7016].coords.as_slice(),
        &[0.093_722, -0.095_115, -0.353_93]
    );
    assert_eq!(mesh.faces[0], [3313, 3329, 3314]);
    assert_eq!(mesh.faces[10795], [4258, 4499, 4518]);
}

#[test]
fn meshlab_binary_ply_with_int_flags_between_coordinates_and_colours() {
    let mesh = load_mesh_raw(&data("bone.ply")).unwrap();
    check(
        &mesh,
        1872,
        3022,
        [0.0279, 0.4041, 0.283],
        [0.9772, 0.5965, 0.7175],
    );
    assert_eq!(
        mesh.vertices[0].coords.as_slice(),
        &[
            f64::from(0.771_295_f32),
            f64::from(0.555_536_f32),
            f64::from(0.624_994_f32)
        ]
    );
    assert_eq!(mesh.faces[0], [345, 924, 83]);
    assert_eq!(mesh.faces[3021], [873, 875, 878]);
}

#[test]
fn meshlab_obj() {
    let mesh = load_mesh_raw(&data("cow.obj")).unwrap();
    check(
        &mesh,
        2904,
        5804,
        [-0.2815, -0.6171, -0.8776],
        [0.2904, 0.458, 0.8776],
    );
    assert_eq!(mesh.faces[0], [251, 210, 250]);
}

#[test]
fn real_files_are_valid_meshes() {
    for name in ["colored_airplane.ply", "bone.ply", "cow.obj"] {
        let path = data(name);
        assert_eq!(
            read_mesh(&path).unwrap(),
            load_mesh_raw(&path).unwrap(),
            "{name}"
        );
    }
}

#[test]
fn real_meshes_round_trip_through_every_format() {
    for name in ["colored_airplane.ply", "bone.ply", "cow.obj"] {
        let mesh = read_mesh(&data(name)).unwrap();
        for format in MeshFormat::ALL {
            let mut bytes = Vec::new();
            encode_mesh(&mut bytes, &mesh, WriteOptions::new(format)).unwrap();
            let back = parse_mesh(&bytes, format.file_type(), Path::new("memory")).unwrap();
            assert_eq!(back, mesh, "{name} as {format}");
        }
    }
}

#[test]
fn face_section_is_byte_identical_to_meshlab() {
    // MeshLab writes faces as uchar count + int indices, little endian; so
    // do we, so the face bytes of bone.ply come out the same.
    let original = std::fs::read(data("bone.ply")).unwrap();
    let mesh = read_mesh(&data("bone.ply")).unwrap();
    let mut ours = Vec::new();
    let options = WriteOptions::new(MeshFormat::PlyBinaryLittleEndian);
    encode_mesh(&mut ours, &mesh, options).unwrap();
    let faces = 3022 * 13;
    assert_eq!(
        ours[ours.len() - faces..],
        original[original.len() - faces..]
    );
    // Float coordinates stay float: Auto precision loses nothing here.
    assert!(String::from_utf8_lossy(&ours[..300]).contains("property float x"));
}
