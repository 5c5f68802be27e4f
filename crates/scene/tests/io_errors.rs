//! Every bad input gives an error that names the file, the place (line,
//! element, byte offset) and the problem; none panics.

use std::path::{Path, PathBuf};

use tempfile::TempDir;
use vp_scene::io::{load_mesh_raw, read_mesh};
use vp_scene::SceneError;

/// Header of a PLY file with float x/y/z and a uchar/int face list.
fn ply_header(format: &str, vertices: usize, faces: usize) -> String {
    format!(
        "ply\nformat {format} 1.0\nelement vertex {vertices}\nproperty float x\n\
         property float y\nproperty float z\nelement face {faces}\n\
         property list uchar int vertex_indices\nend_header\n"
    )
}

/// Binary little-endian PLY of the given vertices and triangles.
fn binary_ply(vertices: &[[f32; 3]], faces: &[[i32; 3]]) -> Vec<u8> {
    let mut b = ply_header("binary_little_endian", vertices.len(), faces.len()).into_bytes();
    for v in vertices {
        for c in v {
            b.extend_from_slice(&c.to_le_bytes());
        }
    }
    for f in faces {
        b.push(3);
        for i in f {
            b.extend_from_slice(&i.to_le_bytes());
        }
    }
    b
}

const TRIANGLE: [[f32; 3]; 3] = [[0.0, 0.0, 0.0], [1.0, 0.0, 0.0], [0.0, 1.0, 0.0]];
/// Bytes of the header of a 3-vertex, 1-face binary file.
fn header_len() -> usize {
    ply_header("binary_little_endian", 3, 1).len()
}

fn ascii_triangle() -> String {
    format!(
        "{}0 0 0\n1 0 0\n0 1 0\n3 0 1 2\n",
        ply_header("ascii", 3, 1)
    )
}

struct Dir(TempDir);

impl Dir {
    fn new() -> Self {
        Dir(tempfile::tempdir().unwrap())
    }

    fn file(&self, name: &str, bytes: impl AsRef<[u8]>) -> PathBuf {
        let path = self.0.path().join(name);
        std::fs::write(&path, bytes).unwrap();
        path
    }
}

/// The error of reading `path`, checked to start with the file's name.
fn read_error(path: &Path) -> String {
    let e = read_mesh(path).unwrap_err().to_string();
    assert!(
        e.starts_with(&path.display().to_string()),
        "error does not name the file: {e}"
    );
    e
}

fn assert_has(e: &str, expected: &str) {
    assert!(
        e.contains(expected),
        "{e}\n  expected to contain: {expected}"
    );
}

#[test]
fn missing_file() {
    let dir = Dir::new();
    let path = dir.0.path().join("absent.ply");
    let e = read_mesh(&path).unwrap_err();
    assert!(matches!(e, SceneError::Io { .. }));
    assert_has(&e.to_string(), "absent.ply: No such file");
}

#[test]
fn unknown_extension() {
    let dir = Dir::new();
    let path = dir.file("mesh.stl", ascii_triangle());
    assert_has(
        &read_mesh(&path).unwrap_err().to_string(),
        "mesh.stl: unknown mesh file extension 'stl' (expected .ply or .obj)",
    );
    // The extension's case does not matter.
    let path = dir.file("MESH.PLY", ascii_triangle());
    assert_eq!(read_mesh(&path).unwrap().n_faces(), 1);
}

#[test]
fn wrong_magic_and_unknown_format() {
    let dir = Dir::new();
    let e = read_error(&dir.file("a.ply", b"PK\x03\x04 not a mesh"));
    assert_has(&e, "a.ply: line 1: not a PLY file");
    let e = read_error(&dir.file("b.ply", ascii_triangle().replace("ascii", "utf8")));
    assert_has(&e, "b.ply: line 2: unknown format line 'format utf8 1.0'");
}

#[test]
fn truncated_binary_body_gives_the_byte_offset() {
    let dir = Dir::new();
    let full = binary_ply(&TRIANGLE, &[[0, 1, 2]]);
    let h = header_len();
    let e = read_error(&dir.file("t.ply", &full[..h + 20]));
    assert_has(
        &e,
        &format!(
            "t.ply: vertex 1 (byte {}): file truncated: it ends at byte {}",
            h + 12,
            h + 20
        ),
    );
    let e = read_error(&dir.file("u.ply", &full[..full.len() - 1]));
    assert_has(&e, &format!("face 0 (byte {})", h + 36));
}

#[test]
fn truncated_ascii_gives_the_line() {
    let dir = Dir::new();
    let text = ascii_triangle();
    let cut = &text[..text.find("0 1 0\n").unwrap()];
    let e = read_error(&dir.file("t.ply", cut));
    assert_has(
        &e,
        "t.ply: line 12: file ends before vertex 2: the header declares 3 of them",
    );
}

#[test]
fn fewer_vertices_than_declared() {
    let dir = Dir::new();
    // ascii: the face line is read as the missing vertex and has one value
    // too many.
    let text = ascii_triangle().replace("0 1 0\n", "");
    let e = read_error(&dir.file("a.ply", text));
    assert_has(&e, "a.ply: line 12: vertex 2: unexpected extra value '2'");
    // binary: twelve of the face's thirteen bytes are taken for the missing
    // vertex; its last byte (0) is read as the face's list count.
    let mut bytes = binary_ply(&TRIANGLE[..2], &[[0, 1, 2]]);
    let patched = String::from_utf8_lossy(&bytes[..header_len()]).replace("vertex 2", "vertex 3");
    bytes.splice(..header_len(), patched.into_bytes());
    let e = read_error(&dir.file("b.ply", bytes));
    assert_has(
        &e,
        &format!(
            "b.ply: face 0 (byte {}): the list has 0 vertex indices",
            header_len() + 36
        ),
    );
}

#[test]
fn face_index_out_of_range_is_named_by_read_but_loaded_raw() {
    let dir = Dir::new();
    let path = dir.file("t.ply", binary_ply(&TRIANGLE, &[[0, 1, 2], [0, 2, 7]]));
    let e = read_error(&path);
    assert_has(
        &e,
        &format!(
            "t.ply: face 1 (byte {}): refers to vertex 7, but the file has only 3 vertices",
            header_len() + 36 + 13
        ),
    );
    // The raw loader keeps the face, so a tool can report and clean it.
    let raw = load_mesh_raw(&path).unwrap();
    let (clean, report) = raw.cleaned();
    assert_eq!((clean.n_faces(), report.bad_index_faces), (1, 1));

    let text = ascii_triangle().replace("3 0 1 2", "3 0 1 5");
    let e = read_error(&dir.file("a.ply", text));
    assert_has(
        &e,
        "a.ply: line 13: face 0: refers to vertex 5, but the file has only 3 vertices",
    );
}

#[test]
fn nan_coordinate_is_rejected_naming_the_vertex() {
    let dir = Dir::new();
    let mut vertices = TRIANGLE;
    vertices[1][2] = f32::NAN;
    let e = read_error(&dir.file("t.ply", binary_ply(&vertices, &[[0, 1, 2]])));
    assert_has(
        &e,
        &format!(
            "t.ply: vertex 1 (byte {}): non-finite coordinate (1, 0, NaN)",
            header_len() + 12
        ),
    );
    let text = ascii_triangle().replace("1 0 0\n", "1 nan 0\n");
    let e = read_error(&dir.file("a.ply", text));
    assert_has(
        &e,
        "a.ply: line 11: vertex 1: non-finite coordinate (1, NaN, 0)",
    );
    let e = read_error(&dir.file("o.obj", "v 0 0 0\nv inf 0 0\nv 0 1 0\nf 1 2 3\n"));
    assert_has(
        &e,
        "o.obj: line 2: vertex 2: non-finite coordinate (inf, 0, 0)",
    );
}

#[test]
fn degenerate_polygon_names_the_file_face_not_the_triangle() {
    let dir = Dir::new();
    // Face 0 is a quad (two triangles); face 1 repeats a vertex, so the
    // third triangle is bad but the file's face number is 1.
    let text = format!(
        "{}0 0 0\n1 0 0\n1 1 0\n0 1 0\n4 0 1 2 3\n3 0 2 2\n",
        ply_header("ascii", 4, 2)
    );
    let e = read_error(&dir.file("t.ply", text));
    assert_has(&e, "t.ply: line 15: face 1: uses vertex 2 twice");
    let e = read_error(&dir.file(
        "t.obj",
        "v 0 0 0\nv 1 0 0\nv 2 0 0\nv 0 1 0\nf 1 2 4\nf 1 2 3\n",
    ));
    assert_has(
        &e,
        "t.obj: line 6: face 2: triangle (1, 2, 3) has zero area",
    );
}

#[test]
fn list_count_too_large() {
    let dir = Dir::new();
    let mut bytes = binary_ply(&TRIANGLE, &[[0, 1, 2]]);
    let count = header_len() + 36;
    bytes[count] = 250;
    let e = read_error(&dir.file("t.ply", bytes));
    assert_has(
        &e,
        &format!("t.ply: face 0 (byte {count}): list 'vertex_indices' declares 250 items of 4 bytes, but only 12 bytes remain"),
    );
}

#[test]
fn bad_number_on_a_line() {
    let dir = Dir::new();
    let text = ascii_triangle().replace("1 0 0\n", "1 0 0,5\n");
    let e = read_error(&dir.file("t.ply", text));
    assert_has(
        &e,
        "t.ply: line 11: vertex 1: '0,5' is not a valid float for property 'z'",
    );
    let e = read_error(&dir.file("t.obj", "v 0 0 0\nv 1 O 0\n"));
    assert_has(&e, "t.obj: line 2: vertex 2: 'O' is not a number");
}

#[test]
fn obj_bad_and_zero_index() {
    let dir = Dir::new();
    let square = "v 0 0 0\nv 1 0 0\nv 1 1 0\nv 0 1 0\n";
    let e = read_error(&dir.file("z.obj", format!("{square}f 1 2 3\nf 0 1 2\n")));
    assert_has(
        &e,
        "z.obj: line 6: face 2: vertex index 0 is invalid (OBJ indices start at 1)",
    );
    let e = read_error(&dir.file("b.obj", format!("{square}f 1 2 3\nf 1 3 9\n")));
    assert_has(
        &e,
        "b.obj: line 6: face 2: refers to vertex 9, but the file has only 4 vertices",
    );
    let e = read_error(&dir.file("r.obj", format!("{square}f -1 -2 -7\n")));
    assert_has(
        &e,
        "r.obj: line 5: face 1: relative vertex index -7 points before the first vertex",
    );
    let e = read_error(&dir.file("s.obj", format!("{square}f 1/2/3/4 2 3\n")));
    assert_has(&e, "s.obj: line 5: face 1: '1/2/3/4' is not a face vertex");
}
