//! Unit tests of the PLY reader on hand-made files covering the format's
//! corners: every scalar type, both byte orders, skipped lists, polygons,
//! materials, and located errors.

use std::path::Path;

use super::header::{Encoding, Scalar};
use super::parse;
use crate::error::SceneError;
use crate::mesh::{Material, Mesh};

const ALL: [Scalar; 8] = [
    Scalar::I8,
    Scalar::U8,
    Scalar::I16,
    Scalar::U16,
    Scalar::I32,
    Scalar::U32,
    Scalar::F32,
    Scalar::F64,
];

/// A PLY file under construction: header text, then body values encoded
/// as the declared types.
struct File {
    encoding: Encoding,
    bytes: Vec<u8>,
    /// Whether the current ascii line has a value yet.
    line_open: bool,
}

impl File {
    fn new(encoding: Encoding, header: &str) -> Self {
        let format = match encoding {
            Encoding::Ascii => "ascii",
            Encoding::BinaryLittleEndian => "binary_little_endian",
            Encoding::BinaryBigEndian => "binary_big_endian",
        };
        File {
            encoding,
            bytes: format!("ply\nformat {format} 1.0\n{header}end_header\n").into_bytes(),
            line_open: false,
        }
    }

    fn put(&mut self, t: Scalar, v: f64) -> &mut Self {
        let le = self.encoding == Encoding::BinaryLittleEndian;
        macro_rules! bin {
            ($ty:ty) => {{
                let x = v as $ty;
                self.bytes
                    .extend_from_slice(&if le { x.to_le_bytes() } else { x.to_be_bytes() });
            }};
        }
        if self.encoding == Encoding::Ascii {
            if self.line_open {
                self.bytes.push(b' ');
            }
            self.bytes.extend_from_slice(v.to_string().as_bytes());
            self.line_open = true;
            return self;
        }
        match t {
            Scalar::I8 => bin!(i8),
            Scalar::U8 => bin!(u8),
            Scalar::I16 => bin!(i16),
            Scalar::U16 => bin!(u16),
            Scalar::I32 => bin!(i32),
            Scalar::U32 => bin!(u32),
            Scalar::F32 => bin!(f32),
            Scalar::F64 => bin!(f64),
        }
        self
    }

    /// Ends an element instance (a line in ascii).
    fn end(&mut self) -> &mut Self {
        if self.encoding == Encoding::Ascii {
            self.bytes.push(b'\n');
            self.line_open = false;
        }
        self
    }

    fn parse(&self) -> crate::error::Result<Mesh> {
        Ok(self.parse_with_warnings()?.0)
    }

    fn parse_with_warnings(&self) -> crate::error::Result<(Mesh, Vec<super::ReadWarning>)> {
        parse(&self.bytes, Path::new("t.ply"))
    }
}

const ENCODINGS: [Encoding; 3] = [
    Encoding::Ascii,
    Encoding::BinaryLittleEndian,
    Encoding::BinaryBigEndian,
];

/// A unit square as two triangles, with coordinate type `coord`, list
/// types `count`/`index`, and skipped properties and elements around.
fn square(encoding: Encoding, coord: Scalar, count: Scalar, index: Scalar) -> File {
    let (c, n, i) = (coord.name(), count.name(), index.name());
    let mut f = File::new(
        encoding,
        &format!(
            "comment made by hand\nobj_info nothing\nelement vertex 4\n\
             property {c} x\nproperty int flags\nproperty {c} y\n\
             property list uchar float texcoord\nproperty {c} z\n\
             element edge 2\nproperty int a\nproperty int b\n\
             element face 2\nproperty uchar red\nproperty list {n} {i} vertex_indices\n\
             property list {n} {i} extra\n\
             element empty 0\nproperty float nothing\n"
        ),
    );
    for (x, y, z) in [
        (0.0, 0.0, 1.0),
        (1.0, 0.0, 1.0),
        (1.0, 1.0, 1.0),
        (0.0, 1.0, 2.0),
    ] {
        f.put(coord, x).put(Scalar::I32, -7.0).put(coord, y);
        f.put(Scalar::U8, 2.0)
            .put(Scalar::F32, 0.5)
            .put(Scalar::F32, 0.25);
        f.put(coord, z).end();
    }
    for e in [[0.0, 1.0], [1.0, 2.0]] {
        f.put(Scalar::I32, e[0]).put(Scalar::I32, e[1]).end();
    }
    for face in [[0.0, 1.0, 2.0], [0.0, 2.0, 3.0]] {
        f.put(Scalar::U8, 200.0).put(count, 3.0);
        for v in face {
            f.put(index, v);
        }
        f.put(count, 1.0).put(index, 9.0).end();
    }
    f
}

#[test]
fn every_scalar_type_and_encoding_reads_the_same_square() {
    let ints = ALL.iter().copied().filter(|t| t.is_integer());
    for encoding in ENCODINGS {
        for coord in ALL {
            for count in ints.clone() {
                for index in ints.clone() {
                    let mesh = square(encoding, coord, count, index)
                        .parse()
                        .unwrap_or_else(|e| {
                            panic!("{encoding:?} {coord:?} {count:?} {index:?}: {e}")
                        });
                    assert_eq!(mesh.faces, vec![[0, 1, 2], [0, 2, 3]]);
                    assert_eq!(mesh.vertices[3].coords.as_slice(), &[0.0, 1.0, 2.0]);
                    assert_eq!(mesh.materials, None);
                }
            }
        }
    }
}

#[test]
fn polygons_become_fans_and_vertex_index_is_accepted() {
    for encoding in ENCODINGS {
        let mut f = File::new(
            encoding,
            "element vertex 5\nproperty float x\nproperty float y\nproperty float z\n\
             element face 1\nproperty list uchar uint vertex_index\n",
        );
        for k in 0..5 {
            let a = f64::from(k) * 1.2566;
            f.put(Scalar::F32, a.cos())
                .put(Scalar::F32, a.sin())
                .put(Scalar::F32, 0.0)
                .end();
        }
        f.put(Scalar::U8, 5.0);
        for k in [0.0, 1.0, 2.0, 3.0, 4.0] {
            f.put(Scalar::U32, k);
        }
        f.end();
        let mesh = f.parse().unwrap();
        assert_eq!(mesh.faces, vec![[0, 1, 2], [0, 2, 3], [0, 3, 4]]);
    }
}

#[test]
fn face_material_applies_to_all_triangles_of_its_polygon() {
    for encoding in ENCODINGS {
        // Material declared before the list: it must still reach the
        // triangles the list makes afterwards.
        let mut f = File::new(
            encoding,
            "element vertex 4\nproperty double x\nproperty double y\nproperty double z\n\
             element face 2\nproperty uchar material\nproperty list uchar int vertex_indices\n",
        );
        for (x, y) in [(0.0, 0.0), (1.0, 0.0), (1.0, 1.0), (0.0, 1.0)] {
            f.put(Scalar::F64, x)
                .put(Scalar::F64, y)
                .put(Scalar::F64, 0.0)
                .end();
        }
        f.put(Scalar::U8, 4.0).put(Scalar::U8, 4.0);
        for v in [0.0, 1.0, 2.0, 3.0] {
            f.put(Scalar::I32, v);
        }
        f.end();
        f.put(Scalar::U8, 1.0).put(Scalar::U8, 3.0);
        for v in [0.0, 2.0, 3.0] {
            f.put(Scalar::I32, v);
        }
        f.end();
        let mesh = f.parse().unwrap();
        assert_eq!(
            mesh.materials,
            Some(vec![Material::Marker, Material::Marker, Material::Rock])
        );
    }
}

fn message(e: &SceneError) -> String {
    e.to_string()
}

#[test]
fn unknown_material_id_names_the_face() {
    for encoding in ENCODINGS {
        let mut f = File::new(
            encoding,
            "element vertex 3\nproperty float x\nproperty float y\nproperty float z\n\
             element face 2\nproperty list uchar int vertex_indices\nproperty uchar material\n",
        );
        for (x, y) in [(0.0, 0.0), (1.0, 0.0), (1.0, 1.0)] {
            f.put(Scalar::F32, x)
                .put(Scalar::F32, y)
                .put(Scalar::F32, 0.0)
                .end();
        }
        for id in [0.0, 9.0] {
            f.put(Scalar::U8, 3.0)
                .put(Scalar::I32, 0.0)
                .put(Scalar::I32, 1.0);
            f.put(Scalar::I32, 2.0).put(Scalar::U8, id).end();
        }
        let e = message(&f.parse().unwrap_err());
        let place = if encoding == Encoding::Ascii {
            "t.ply: line 15: face 1: ".to_string()
        } else {
            format!("t.ply: face 1 (byte {}): ", f.bytes.len() - 14)
        };
        assert!(e.starts_with(&place), "{e}");
        assert!(e.contains("unknown material id 9"), "{e}");
    }
}

/// One triangle.
fn triangle(encoding: Encoding) -> File {
    let mut f = File::new(
        encoding,
        "element vertex 3\nproperty float x\nproperty float y\nproperty float z\n\
         element face 1\nproperty list uchar int vertex_indices\n",
    );
    for (x, y) in [(0.0, 0.0), (1.0, 0.0), (1.0, 1.0)] {
        f.put(Scalar::F32, x)
            .put(Scalar::F32, y)
            .put(Scalar::F32, 0.0)
            .end();
    }
    f.put(Scalar::U8, 3.0);
    for v in [0.0, 1.0, 2.0] {
        f.put(Scalar::I32, v);
    }
    f.end();
    f
}

#[test]
fn binary_errors_give_element_and_byte_offset() {
    let good = triangle(Encoding::BinaryLittleEndian);
    let body = good.bytes.len() - 3 * 12 - 13;
    assert_eq!(good.parse().unwrap().faces, vec![[0, 1, 2]]);

    let cut = &good.bytes[..body + 30];
    let e = message(&parse(cut, Path::new("t.ply")).unwrap_err());
    assert!(
        e.contains(&format!(
            "vertex 2 (byte {}): file truncated: it ends at byte {}",
            body + 24,
            body + 30
        )),
        "{e}"
    );

    let mut big = good.bytes.clone();
    big[body + 36] = 200; // list count
    let e = message(&parse(&big, Path::new("t.ply")).unwrap_err());
    assert!(e.contains(&format!("face 0 (byte {})", body + 36)), "{e}");
    assert!(
        e.contains("declares 200 items of 4 bytes, but only 12 bytes remain"),
        "{e}"
    );

    let mut neg = good.bytes.clone();
    neg[body + 41..body + 45].copy_from_slice(&(-1i32).to_le_bytes());
    let e = message(&parse(&neg, Path::new("t.ply")).unwrap_err());
    assert!(
        e.contains("face 0") && e.contains("vertex index -1 is not a valid index"),
        "{e}"
    );

    let mut two = good.bytes[..good.bytes.len() - 4].to_vec();
    two[body + 36] = 2;
    let e = message(&parse(&two, Path::new("t.ply")).unwrap_err());
    assert!(
        e.contains("the list has 2 vertex indices; a face needs at least 3"),
        "{e}"
    );

    let mut extra = good.bytes.clone();
    extra.extend_from_slice(&[1, 2, 3]);
    let e = message(&parse(&extra, Path::new("t.ply")).unwrap_err());
    assert!(
        e.contains(&format!(
            "byte {}: 3 bytes follow the last element",
            body + 49
        )),
        "{e}"
    );
    // A trailing newline is harmless.
    let mut newline = good.bytes.clone();
    newline.push(b'\n');
    assert!(parse(&newline, Path::new("t.ply")).is_ok());
}

#[test]
fn skipped_fixed_size_element_reports_truncation() {
    let mut f = File::new(
        Encoding::BinaryBigEndian,
        "element junk 1000\nproperty double a\nelement vertex 0\nproperty float x\n\
         property float y\nproperty float z\n",
    );
    f.put(Scalar::F64, 1.0)
        .put(Scalar::F64, 2.0)
        .put(Scalar::U8, 0.0);
    let body = f.bytes.len() - 17;
    let e = message(&f.parse().unwrap_err());
    assert!(
        e.contains(&format!("junk 2 (byte {}): file truncated", body + 16)),
        "{e}"
    );
}

#[test]
fn ascii_errors_name_the_line() {
    let good = triangle(Encoding::Ascii);
    let text = String::from_utf8(good.bytes.clone()).unwrap();
    let parse_text = |s: &str| message(&parse(s.as_bytes(), Path::new("t.ply")).unwrap_err());

    let e = parse_text(&text.replace("1 1 0\n", "1 x 0\n"));
    assert!(
        e.contains("t.ply: line 12: vertex 2: 'x' is not a valid float for property 'y'"),
        "{e}"
    );

    let e = parse_text(&text.replace("3 0 1 2\n", ""));
    assert!(
        e.contains("line 13: file ends before face 0: the header declares 1 of them"),
        "{e}"
    );

    let e = parse_text(&text.replace("3 0 1 2\n", "3 0 1\n"));
    assert!(
        e.contains("line 13: face 0: the line ends before item 2 of list 'vertex_indices'"),
        "{e}"
    );

    let e = parse_text(&text.replace("element vertex 3", "element vertex 4"));
    assert!(
        e.contains("line 13: vertex 3: unexpected extra value '2'"),
        "{e}"
    );

    let e = parse_text(&text.replace("element vertex 3", "element vertex 2"));
    assert!(
        e.contains("line 12: face 0: the list has 1 vertex indices"),
        "{e}"
    );

    let e = parse_text(&format!("{text}3 0 1 2\n"));
    assert!(e.contains("line 14: data after the last element"), "{e}");

    let e = parse_text(&text.replace("3 0 1 2\n", "300 0 1 2\n"));
    assert!(
        e.contains("line 13: face 0: '300' is not a valid uchar"),
        "{e}"
    );

    let e = parse_text(&text.replace("3 0 1 2\n", "3 0 1 2.5\n"));
    assert!(
        e.contains("line 13: face 0: '2.5' is not a valid int"),
        "{e}"
    );
}

#[test]
fn ascii_float_properties_read_as_f32_like_binary() {
    // A `float` property holds an f32 whatever the encoding, so the same
    // file in ascii and binary gives the same mesh.
    let text = "ply\nformat ascii 1.0\nelement vertex 1\nproperty float x\n\
                property float y\nproperty double z\nend_header\n0.1 0.2 0.3\n";
    let (mesh, _) = parse(text.as_bytes(), Path::new("t.ply")).unwrap();
    assert_eq!(mesh.vertices[0].x.to_bits(), f64::from(0.1f32).to_bits());
    assert_eq!(mesh.vertices[0].z.to_bits(), 0.3f64.to_bits());
}

#[test]
fn structural_header_errors() {
    let cases = [
        (
            "element face 0\nproperty list uchar int vertex_indices\n",
            "no 'vertex' element",
        ),
        (
            "element vertex 0\nproperty float x\nproperty float y\n",
            "no 'z' property",
        ),
        (
            "element vertex 0\nproperty float x\nproperty float y\nproperty list uchar float z\n",
            "vertex property 'z' is a list",
        ),
        (
            "element vertex 0\nproperty float x\nproperty float y\nproperty float z\n\
             element face 0\nproperty list uchar int indices\n",
            "no 'vertex_indices'",
        ),
        (
            "element vertex 0\nproperty float x\nproperty float y\nproperty float z\n\
             element face 0\nproperty list uchar float vertex_indices\n",
            "must be a list of integers",
        ),
        (
            "element vertex 0\nproperty float x\nproperty float y\nproperty float z\n\
             element face 0\nproperty list uchar int vertex_indices\nproperty float material\n",
            "'material' must be an integer",
        ),
    ];
    for (header, expected) in cases {
        let e = message(&File::new(Encoding::Ascii, header).parse().unwrap_err());
        assert!(e.contains("t.ply: header: ") && e.contains(expected), "{e}");
    }
}

#[test]
fn point_cloud_without_faces_reads() {
    let f = File::new(
        Encoding::BinaryLittleEndian,
        "element vertex 0\nproperty float x\nproperty float y\nproperty float z\n",
    );
    let mesh = f.parse().unwrap();
    assert!(mesh.vertices.is_empty() && mesh.faces.is_empty());
}

#[test]
fn huge_declared_counts_fail_without_allocating_them() {
    let f = File::new(
        Encoding::BinaryLittleEndian,
        "element vertex 18446744073709551615\nproperty float x\nproperty float y\nproperty float z\n\
         element nothing 18446744073709551615\n",
    );
    let e = message(&f.parse().unwrap_err());
    assert!(
        e.contains("vertex 0 (byte") && e.contains("file truncated"),
        "{e}"
    );
}

#[test]
fn blender_free_text_header_line_reads_as_a_comment() {
    // Regression: old Blender exporters write `Created by Blender3D ...`
    // without `comment`; vpctl refused such files (as MeshLab does) while
    // trimesh and assimp read them.
    for encoding in ENCODINGS {
        let mut f = File::new(
            encoding,
            "Created by Blender3D 2.49 - www.blender.org, source file: 'rock.blend'\n\
             element vertex 3\nproperty float x\nproperty float y\nproperty float z\n\
             element face 1\nproperty list uchar uint vertex_indices\n",
        );
        for (x, y) in [(0.0, 0.0), (1.0, 0.0), (0.0, 1.0)] {
            f.put(Scalar::F32, x)
                .put(Scalar::F32, y)
                .put(Scalar::F32, 0.0)
                .end();
        }
        f.put(Scalar::U8, 3.0);
        for k in [0.0, 1.0, 2.0] {
            f.put(Scalar::U32, k);
        }
        f.end();
        let (mesh, warnings) = f.parse_with_warnings().unwrap();
        assert_eq!(mesh.faces, vec![[0, 1, 2]]);
        // Returned to the caller (not printed by the reader), naming the
        // file and the line.
        let told: Vec<String> = warnings.iter().map(ToString::to_string).collect();
        assert_eq!(told.len(), 1, "{told:?}");
        assert!(
            told[0].starts_with("t.ply: line 3: header line without a PLY keyword read as a comment: 'Created by Blender3D"),
            "{told:?}"
        );
    }
}

#[test]
fn vertex_normals_are_read_from_ascii_and_binary() {
    use nalgebra::Vector3;
    let ascii = b"ply\nformat ascii 1.0\nelement vertex 2\nproperty float x\nproperty float y\n\
property float z\nproperty float nx\nproperty float ny\nproperty float nz\nproperty uchar red\n\
end_header\n0 0 0 0 0 1 255\n1 2 3 0.5 0.5 0 7\n";
    let cloud = super::parse_with_normals(ascii, Path::new("a.ply")).unwrap();
    assert_eq!(cloud.points.len(), 2);
    assert_eq!(
        cloud.normals.unwrap(),
        vec![Vector3::new(0.0, 0.0, 1.0), Vector3::new(0.5, 0.5, 0.0)]
    );
    let mut bin = b"ply\nformat binary_little_endian 1.0\nelement vertex 1\nproperty float x\n\
property float y\nproperty float z\nproperty float nx\nproperty float ny\nproperty float nz\n\
end_header\n"
        .to_vec();
    for v in [1.0f32, 2.0, 3.0, 0.0, -1.0, 0.0] {
        bin.extend_from_slice(&v.to_le_bytes());
    }
    let cloud = super::parse_with_normals(&bin, Path::new("b.ply")).unwrap();
    assert_eq!(cloud.normals.unwrap(), vec![Vector3::new(0.0, -1.0, 0.0)]);
    let plain = b"ply\nformat ascii 1.0\nelement vertex 1\nproperty float x\nproperty float y\n\
property float z\nend_header\n1 2 3\n";
    assert!(super::parse_with_normals(plain, Path::new("c.ply"))
        .unwrap()
        .normals
        .is_none());
}
