//! PLY writer: the layout MeshLab writes (uchar count, int indices), with
//! the face property `material` when the mesh carries materials.

use std::io::{self, Write};

use crate::io::{flush_if_full, CHUNK};

use super::header::Encoding;
use crate::mesh::Mesh;

/// Writes `mesh` as PLY; `double` selects `double` over `float` coordinates.
pub(crate) fn write(
    w: &mut dyn Write,
    mesh: &Mesh,
    encoding: Encoding,
    double: bool,
) -> io::Result<()> {
    let coord = if double { "double" } else { "float" };
    // int is what most tools expect; switch to uint only when an index
    // would not fit.
    let wide = mesh.faces.iter().flatten().any(|&i| i > i32::MAX as u32);
    let index = if wide { "uint" } else { "int" };
    let format = match encoding {
        Encoding::Ascii => "ascii",
        Encoding::BinaryLittleEndian => "binary_little_endian",
        Encoding::BinaryBigEndian => "binary_big_endian",
    };
    let mut buf = Vec::with_capacity(CHUNK + 256);
    write!(
        buf,
        "ply\nformat {format} 1.0\ncomment written by vpctl (vp-scene)\n\
         element vertex {}\nproperty {coord} x\nproperty {coord} y\nproperty {coord} z\n\
         element face {}\nproperty list uchar {index} vertex_indices\n",
        mesh.vertices.len(),
        mesh.faces.len()
    )?;
    if mesh.materials.is_some() {
        buf.extend_from_slice(b"property uchar material\n");
    }
    buf.extend_from_slice(b"end_header\n");
    let le = encoding == Encoding::BinaryLittleEndian;
    for p in &mesh.vertices {
        match (encoding, double) {
            (Encoding::Ascii, true) => writeln!(buf, "{:?} {:?} {:?}", p.x, p.y, p.z)?,
            (Encoding::Ascii, false) => {
                writeln!(buf, "{:?} {:?} {:?}", p.x as f32, p.y as f32, p.z as f32)?;
            }
            (_, true) => {
                for c in p.iter() {
                    buf.extend_from_slice(&if le { c.to_le_bytes() } else { c.to_be_bytes() });
                }
            }
            (_, false) => {
                for &c in p.iter() {
                    let c = c as f32;
                    buf.extend_from_slice(&if le { c.to_le_bytes() } else { c.to_be_bytes() });
                }
            }
        }
        flush_if_full(w, &mut buf)?;
    }
    for (f, face) in mesh.faces.iter().enumerate() {
        let material = mesh.materials.as_ref().map(|m| m[f] as u8);
        if encoding == Encoding::Ascii {
            write!(buf, "3 {} {} {}", face[0], face[1], face[2])?;
            if let Some(id) = material {
                write!(buf, " {id}")?;
            }
            buf.push(b'\n');
        } else {
            buf.push(3);
            for &i in face {
                // Same bytes for int and uint: `wide` only changes the
                // declared type, and then every index is a valid uint.
                buf.extend_from_slice(&if le { i.to_le_bytes() } else { i.to_be_bytes() });
            }
            buf.extend(material);
        }
        flush_if_full(w, &mut buf)?;
    }
    w.write_all(&buf)
}
