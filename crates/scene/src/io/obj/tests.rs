//! Unit tests of the OBJ reader: face forms, relative indices, polygons,
//! materials and located errors.

use std::path::Path;

use super::parse;
use crate::error::Result;
use crate::mesh::{Material, Mesh};

fn read(text: &str) -> Result<Mesh> {
    parse(text.as_bytes(), Path::new("t.obj"))
}

fn error(text: &str) -> String {
    read(text).unwrap_err().to_string()
}

const SQUARE: &str = "v 0 0 0\nv 1 0 0\nv 1 1 0\nv 0 1 0\n";

#[test]
fn every_face_vertex_form_gives_the_same_triangles() {
    for face in [
        "f 1 2 3 4",
        "f 1/1 2/2 3/3 4/4",
        "f 1//1 2//2 3//3 4//4",
        "f 1/1/1 2/2/2 3/3/3 4/4/4",
        "f -4 -3 -2 -1",
        "f -4/-4/-4 2/2 3//3 -1",
    ] {
        let mesh = read(&format!("{SQUARE}vt 0 0\nvn 0 0 1\n{face}\n")).unwrap();
        assert_eq!(mesh.faces, vec![[0, 1, 2], [0, 2, 3]], "{face}");
        assert_eq!(mesh.materials, None);
    }
}

#[test]
fn relative_indices_count_from_the_vertices_so_far() {
    let mesh = read("v 0 0 0\nv 1 0 0\nv 1 1 0\nf -3 -2 -1\nv 0 1 0\nf -4 -2 -1\n").unwrap();
    assert_eq!(mesh.faces, vec![[0, 1, 2], [0, 2, 3]]);
}

#[test]
fn other_statements_comments_and_extra_vertex_values_are_ignored() {
    let text = "\u{feff}# exported\r\nmtllib a.mtl\r\no thing\r\ng part\r\ns off\r\n\
                v 0 0 0 1 0 0\r\nv 1 0 0 0.5 0.5 0.5\r\nv 1 1 0\r\n\
                vp 0.5\r\nl 1 2\r\nf 1 2 3 # trailing comment\r\n";
    let mesh = read(text).unwrap();
    assert_eq!(mesh.n_vertices(), 3);
    assert_eq!(mesh.faces, vec![[0, 1, 2]]);
}

#[test]
fn usemtl_with_our_names_gives_materials() {
    let text = format!("{SQUARE}usemtl rock\nf 1 2 3\nusemtl Tree\nf 1 3 4\n");
    assert_eq!(
        read(&text).unwrap().materials,
        Some(vec![Material::Rock, Material::Tree])
    );
    // A polygon's material goes to each of its triangles.
    let text = format!("{SQUARE}usemtl marker\nf 1 2 3 4\n");
    assert_eq!(
        read(&text).unwrap().materials,
        Some(vec![Material::Marker; 2])
    );
}

#[test]
fn materials_are_dropped_unless_every_face_has_a_known_one() {
    for text in [
        format!("{SQUARE}f 1 2 3\nusemtl rock\nf 1 3 4\n"),
        format!("{SQUARE}usemtl rock\nf 1 2 3\nusemtl granite\nf 1 3 4\n"),
        format!("{SQUARE}usemtl rock\nf 1 2 3\nusemtl\nf 1 3 4\n"),
    ] {
        let mesh = read(&text).unwrap();
        assert_eq!(mesh.n_faces(), 2);
        assert_eq!(mesh.materials, None, "{text}");
    }
}

#[test]
fn errors_name_the_line() {
    let cases = [
        (
            format!("{SQUARE}f 1 0 3\n"),
            "t.obj: line 5: face 1: vertex index 0 is invalid",
        ),
        (
            format!("{SQUARE}f 1 2 x\n"),
            "line 5: face 1: 'x' is not a face vertex",
        ),
        (
            format!("{SQUARE}f 1 2/a 3\n"),
            "line 5: face 1: '2/a' is not a face vertex",
        ),
        (
            format!("{SQUARE}f 1 2/1/1/1 3\n"),
            "'2/1/1/1' is not a face vertex",
        ),
        (
            format!("{SQUARE}f 1 2 3\nf -5 1 2\n"),
            "line 6: face 2: relative vertex index -5 points before the first vertex (4 vertices",
        ),
        (
            format!("{SQUARE}f 1 2 9999999999\n"),
            "line 5: face 1: vertex index 9999999999 is too large",
        ),
        (
            format!("{SQUARE}f 1 2\n"),
            "line 5: face 1 has 2 vertices; a face needs at least 3",
        ),
        (
            "v 0 0 0\nv 1 0\n".to_string(),
            "line 2: vertex 2 has 2 coordinates; it needs 3",
        ),
        (
            "v 0 0 0\nv 1 0 zero\n".to_string(),
            "line 2: vertex 2: 'zero' is not a number",
        ),
        (
            "v 0 0 0\n\u{1}\u{2} 1 2\n".to_string(),
            "line 2: '\u{1}\u{2}' is not an OBJ statement",
        ),
    ];
    for (text, expected) in cases {
        let e = error(&text);
        assert!(e.contains(expected), "{e}\nexpected: {expected}");
    }
}

#[test]
fn forward_and_out_of_range_indices_are_left_to_validation() {
    // Positive indices may refer to vertices defined later; whether they
    // exist at all is a geometric check, not a format error.
    let mesh = read("f 1 2 3\nv 0 0 0\nv 1 0 0\nv 1 1 0\nf 1 2 7\n").unwrap();
    assert_eq!(mesh.faces, vec![[0, 1, 2], [0, 1, 6]]);
}
