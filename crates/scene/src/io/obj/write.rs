//! OBJ writer: `v` and triangle `f` lines, in `usemtl` groups when the mesh
//! carries materials.

use std::io::{self, Write};

use crate::io::{flush_if_full, CHUNK};

use crate::mesh::{Material, Mesh};

/// Writes `mesh` as OBJ. With `single`, coordinates are printed as the
/// nearest `f32` (shorter, lossy); otherwise exactly.
pub(crate) fn write(w: &mut dyn Write, mesh: &Mesh, single: bool) -> io::Result<()> {
    let mut buf = Vec::with_capacity(CHUNK + 256);
    writeln!(
        buf,
        "# written by vpctl (vp-scene)\n# vertices: {}, faces: {}",
        mesh.vertices.len(),
        mesh.faces.len()
    )?;
    for p in &mesh.vertices {
        if single {
            writeln!(buf, "v {:?} {:?} {:?}", p.x as f32, p.y as f32, p.z as f32)?;
        } else {
            writeln!(buf, "v {:?} {:?} {:?}", p.x, p.y, p.z)?;
        }
        flush_if_full(w, &mut buf)?;
    }
    let mut group: Option<Material> = None;
    for (f, face) in mesh.faces.iter().enumerate() {
        if let Some(m) = mesh.material(f) {
            if group != Some(m) {
                writeln!(buf, "usemtl {}", m.name())?;
                group = Some(m);
            }
        }
        // OBJ counts vertices from 1.
        let [a, b, c] = face.map(|i| u64::from(i) + 1);
        writeln!(buf, "f {a} {b} {c}")?;
        flush_if_full(w, &mut buf)?;
    }
    w.write_all(&buf)
}
