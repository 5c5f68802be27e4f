//! Random bytes, truncations and corruptions of valid files never panic the
//! readers, and a cut binary file is always an error.

use std::path::Path;

use nalgebra::Point3;
use proptest::prelude::*;
use vp_scene::io::{encode_mesh, parse_mesh, parse_mesh_raw, FileType, MeshFormat, WriteOptions};
use vp_scene::{Material, Mesh};

/// A small valid mesh with a quad's worth of faces and materials.
fn sample() -> Mesh {
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
    encode_mesh(&mut bytes, &sample(), WriteOptions::new(format)).unwrap();
    bytes
}

/// Runs both the raw and the validating parser; only errors may come out.
fn parse_both(bytes: &[u8], file_type: FileType) -> bool {
    let origin = Path::new("fuzz");
    let raw = parse_mesh_raw(bytes, file_type, origin);
    let full = parse_mesh(bytes, file_type, origin);
    if let Err(e) = &full {
        assert!(e.to_string().starts_with("fuzz: "), "{e}");
    }
    raw.is_ok()
}

fn format() -> impl Strategy<Value = MeshFormat> {
    prop::sample::select(MeshFormat::ALL.to_vec())
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(64))]

    #[test]
    fn random_bytes_never_panic(bytes in prop::collection::vec(any::<u8>(), 0..400)) {
        parse_both(&bytes, FileType::Ply);
        parse_both(&bytes, FileType::Obj);
    }

    #[test]
    fn random_body_after_a_plausible_header_never_panics(
        format in prop::sample::select(vec!["ascii", "binary_little_endian", "binary_big_endian"]),
        count in prop::sample::select(vec!["char", "uchar", "short", "int", "uint"]),
        body in prop::collection::vec(any::<u8>(), 0..300),
    ) {
        let mut bytes = format!(
            "ply\nformat {format} 1.0\nelement vertex 4\nproperty double x\nproperty float y\n\
             property short z\nproperty list uchar float extra\nelement face 3\n\
             property list {count} int vertex_indices\nproperty uchar material\nend_header\n"
        )
        .into_bytes();
        bytes.extend_from_slice(&body);
        parse_both(&bytes, FileType::Ply);
    }

    #[test]
    fn truncations_never_panic_and_cut_binary_files_fail(format in format(), cut in 0.0f64..1.0) {
        let bytes = encoded(format);
        let len = (bytes.len() as f64 * cut) as usize;
        let ok = parse_both(&bytes[..len], format.file_type());
        let binary = matches!(
            format,
            MeshFormat::PlyBinaryLittleEndian | MeshFormat::PlyBinaryBigEndian
        );
        prop_assert!(!(binary && ok), "a binary file cut at {} of {} bytes parsed", len, bytes.len());
    }

    #[test]
    fn corrupted_bytes_never_panic(
        format in format(),
        edits in prop::collection::vec((0.0f64..1.0, any::<u8>()), 1..6),
    ) {
        let mut bytes = encoded(format);
        for (at, value) in edits {
            let i = ((bytes.len() - 1) as f64 * at) as usize;
            bytes[i] = value;
        }
        parse_both(&bytes, format.file_type());
    }
}

#[test]
fn untouched_encodings_parse() {
    for format in MeshFormat::ALL {
        assert_eq!(
            parse_mesh(&encoded(format), format.file_type(), Path::new("x")).unwrap(),
            sample()
        );
    }
}
