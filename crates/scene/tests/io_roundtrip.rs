//! Writing then reading a mesh gives it back: every format, every precision,
//! with and without materials, in memory and through files.

use std::path::Path;

use nalgebra::Point3;
use proptest::prelude::*;
use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;
use vp_scene::io::{
    encode_mesh, parse_mesh, read_mesh, write_mesh, write_mesh_with, FileType, MeshFormat,
    Precision, WriteOptions,
};
use vp_scene::{Material, Mesh};

/// A valid random mesh: coordinates spread over a site-sized box, some
/// polygons' worth of shared vertices, optional materials.
fn random_mesh(seed: u64, n_vertices: usize, n_faces: usize, materials: bool) -> Mesh {
    let mut rng = ChaCha8Rng::seed_from_u64(seed);
    let vertices: Vec<Point3<f64>> = (0..n_vertices)
        .map(|_| {
            Point3::new(
                rng.random_range(-60.0..60.0),
                rng.random_range(-60.0..60.0),
                rng.random_range(-5.0..20.0),
            )
        })
        .collect();
    let n = n_vertices as u32;
    let faces: Vec<[u32; 3]> = (0..n_faces)
        .map(|_| {
            let a = rng.random_range(0..n);
            let b = (a + rng.random_range(1..n)) % n;
            let mut c = rng.random_range(0..n);
            while c == a || c == b {
                c = rng.random_range(0..n);
            }
            [a, b, c]
        })
        .collect();
    let materials = materials.then(|| {
        (0..n_faces)
            .map(|_| Material::ALL[rng.random_range(0..Material::ALL.len())])
            .collect()
    });
    Mesh::new(vertices, faces, materials).expect("random triangles are not degenerate")
}

fn round_trip(mesh: &Mesh, options: WriteOptions) -> (Mesh, Vec<u8>) {
    let mut bytes = Vec::new();
    encode_mesh(&mut bytes, mesh, options).unwrap();
    let origin = Path::new("memory");
    let back = parse_mesh(&bytes, options.format.file_type(), origin)
        .unwrap_or_else(|e| panic!("{options:?}: {e}"));
    (back, bytes)
}

fn rounded_to_f32(mesh: &Mesh) -> Mesh {
    let mut m = mesh.clone();
    for p in &mut m.vertices {
        p.coords.apply(|c| *c = f64::from(*c as f32));
    }
    m
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(16))]

    #[test]
    fn every_format_and_precision_round_trips(seed in 0u64..1_000_000, materials: bool) {
        let mesh = random_mesh(seed, 40, 70, materials);
        for format in MeshFormat::ALL {
            for precision in [Precision::Auto, Precision::Double] {
                let options = WriteOptions::new(format).precision(precision);
                prop_assert_eq!(&round_trip(&mesh, options).0, &mesh, "{:?}", options);
            }
            let options = WriteOptions::new(format).precision(Precision::Single);
            let (back, _) = round_trip(&mesh, options);
            if format == MeshFormat::Obj {
                // Text holds the f32 value's shortest decimal, which reads
                // back as a nearby f64, not the f32 itself.
                prop_assert_eq!(&back.faces, &mesh.faces);
                prop_assert_eq!(&back.materials, &mesh.materials);
                for (a, b) in back.vertices.iter().zip(&mesh.vertices) {
                    prop_assert!((a - b).amax() <= 60.0 * f64::from(f32::EPSILON));
                }
            } else {
                prop_assert_eq!(&back, &rounded_to_f32(&mesh), "{:?}", options);
            }
        }
    }
}

#[test]
fn auto_precision_writes_float_only_when_nothing_is_lost() {
    let exact = rounded_to_f32(&random_mesh(7, 30, 40, true));
    let inexact = random_mesh(7, 30, 40, true);
    for format in [
        MeshFormat::PlyAscii,
        MeshFormat::PlyBinaryLittleEndian,
        MeshFormat::PlyBinaryBigEndian,
    ] {
        let (back, bytes) = round_trip(&exact, WriteOptions::new(format));
        assert_eq!(back, exact);
        let text = String::from_utf8_lossy(&bytes);
        assert!(text.contains("property float x\n"), "{format}");
        let (back, bytes) = round_trip(&inexact, WriteOptions::new(format));
        assert_eq!(back, inexact);
        assert!(String::from_utf8_lossy(&bytes).contains("property double x\n"));
    }
}

#[test]
fn binary_files_have_the_size_the_layout_implies() {
    let mesh = random_mesh(3, 50, 90, true);
    let size = |format, precision| {
        let (_, bytes) = round_trip(&mesh, WriteOptions::new(format).precision(precision));
        bytes.len()
    };
    // uchar count + 3 int indices + uchar material per face.
    let faces = 90 * 14;
    let le_single = size(MeshFormat::PlyBinaryLittleEndian, Precision::Single);
    let be_double = size(MeshFormat::PlyBinaryBigEndian, Precision::Double);
    let le_double = size(MeshFormat::PlyBinaryLittleEndian, Precision::Double);
    assert_eq!(
        le_double - le_single,
        50 * 12 + 3,
        "float -> double: 3 header bytes"
    );
    assert_eq!(
        be_double + 3,
        le_double,
        "'big' is 3 letters shorter than 'little'"
    );
    assert!(le_single > 50 * 12 + faces);
}

#[test]
fn files_round_trip_through_disk_and_obj_groups_materials() {
    let dir = tempfile::tempdir().unwrap();
    let mesh = random_mesh(11, 25, 30, true);
    for format in MeshFormat::ALL {
        let ext = format.file_type().extension().to_uppercase();
        let path = dir.path().join(format!("{format}.{ext}"));
        write_mesh(&path, &mesh, format).unwrap();
        assert_eq!(read_mesh(&path).unwrap(), mesh, "{format}");
    }
    let mut sorted = mesh.clone();
    let mut order: Vec<usize> = (0..sorted.n_faces()).collect();
    order.sort_by_key(|&f| mesh.materials.as_ref().unwrap()[f]);
    sorted.faces = order.iter().map(|&f| mesh.faces[f]).collect();
    sorted.materials = Some(order.iter().map(|&f| mesh.material(f).unwrap()).collect());
    let path = dir.path().join("sorted.obj");
    write_mesh(&path, &sorted, MeshFormat::Obj).unwrap();
    let text = std::fs::read_to_string(&path).unwrap();
    let groups = text.lines().filter(|l| l.starts_with("usemtl ")).count();
    let distinct = sorted
        .material_counts()
        .unwrap()
        .iter()
        .filter(|&&c| c > 0)
        .count();
    assert_eq!(groups, distinct);
    assert_eq!(read_mesh(&path).unwrap(), sorted);
}

#[test]
fn a_mesh_without_materials_writes_no_material_property() {
    let mesh = random_mesh(5, 10, 8, false);
    for format in MeshFormat::ALL {
        let (back, bytes) = round_trip(&mesh, WriteOptions::new(format));
        assert_eq!(back.materials, None);
        let text = String::from_utf8_lossy(&bytes);
        assert!(
            !text.contains("material") && !text.contains("usemtl"),
            "{format}"
        );
    }
}

#[test]
fn writing_refuses_a_mismatched_extension_and_leaves_no_file() {
    let dir = tempfile::tempdir().unwrap();
    let mesh = random_mesh(1, 5, 3, false);
    let path = dir.path().join("mesh.obj");
    let e = write_mesh(&path, &mesh, MeshFormat::PlyAscii)
        .unwrap_err()
        .to_string();
    assert!(
        e.contains("mesh.obj: a ply-ascii file needs the extension .ply"),
        "{e}"
    );
    let mut bad = mesh.clone();
    bad.materials = Some(vec![Material::Rock]);
    let path = dir.path().join("mesh.ply");
    let options = WriteOptions::new(MeshFormat::PlyBinaryLittleEndian);
    let e = write_mesh_with(&path, &bad, options)
        .unwrap_err()
        .to_string();
    assert!(e.contains("1 materials for 3 faces"), "{e}");
    assert_eq!(std::fs::read_dir(dir.path()).unwrap().count(), 0);
}

#[test]
fn format_names_parse_back() {
    for format in MeshFormat::ALL {
        assert_eq!(format.name().parse::<MeshFormat>().unwrap(), format);
    }
    let e = "stl".parse::<MeshFormat>().unwrap_err().to_string();
    assert!(
        e.contains("unknown mesh format 'stl'") && e.contains("ply-binary-le"),
        "{e}"
    );
    assert_eq!(
        FileType::from_path(Path::new("a/B.Ply")).unwrap(),
        FileType::Ply
    );
}
