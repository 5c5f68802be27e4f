//! Mesh file formats: PLY (ascii, binary little and big endian) and OBJ;
//! and [`gltf`], glTF 2.0 binary scenes (mesh, camera frusta, paths) for
//! viewers, written only.
//!
//! Entry points: [`read_mesh`] (load and validate; the error names the file
//! and the vertex, face or line at fault), [`load_mesh_raw`] (load without
//! geometric checks, so that a tool can report what is wrong with a mesh)
//! and [`write_mesh`] / [`write_mesh_with`] (atomic: no partial file). The
//! file type is chosen by extension, `.ply` or `.obj`, in any case. The
//! in-memory forms [`parse_mesh`], [`parse_mesh_raw`] and [`encode_mesh`]
//! do the same on bytes.
//!
//! Both readers are our own rather than a crate's, so that every error can
//! say where in the file it is: a line for text, an element and byte offset
//! for binary PLY.
//!
//! # Performance
//! Files are read whole into memory and parsed from byte slices without
//! per-value allocation: binary PLY with `from_le_bytes`/`from_be_bytes`,
//! text with a tokenizer over the line's bytes.

pub mod gltf;
mod obj;
mod ply;
pub(crate) mod text;
mod validate;

use std::fmt;
use std::io::Write;
use std::path::{Path, PathBuf};
use std::str::FromStr;

use nalgebra::{Point3, Vector3};

use crate::error::{Location, Result, SceneError};
use crate::fsio;
use crate::mesh::Mesh;

use self::ply::header::Encoding;

/// A mesh file format with its encoding, as chosen for writing.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub enum MeshFormat {
    /// PLY with an ascii body.
    PlyAscii,
    /// PLY with a binary little-endian body (what most tools write).
    PlyBinaryLittleEndian,
    /// PLY with a binary big-endian body.
    PlyBinaryBigEndian,
    /// Wavefront OBJ.
    Obj,
}

impl MeshFormat {
    /// All formats.
    pub const ALL: [MeshFormat; 4] = [
        MeshFormat::PlyAscii,
        MeshFormat::PlyBinaryLittleEndian,
        MeshFormat::PlyBinaryBigEndian,
        MeshFormat::Obj,
    ];

    /// Short name for command lines and reports: `ply-ascii`,
    /// `ply-binary-le`, `ply-binary-be` or `obj`.
    pub fn name(self) -> &'static str {
        match self {
            MeshFormat::PlyAscii => "ply-ascii",
            MeshFormat::PlyBinaryLittleEndian => "ply-binary-le",
            MeshFormat::PlyBinaryBigEndian => "ply-binary-be",
            MeshFormat::Obj => "obj",
        }
    }

    /// The usual format for a path's extension: binary little-endian PLY
    /// for `.ply` (compact, and what MeshLab writes), OBJ for `.obj`.
    pub fn for_path(path: &Path) -> Result<MeshFormat> {
        Ok(match FileType::from_path(path)? {
            FileType::Ply => MeshFormat::PlyBinaryLittleEndian,
            FileType::Obj => MeshFormat::Obj,
        })
    }

    /// The file type, which decides the extension.
    pub fn file_type(self) -> FileType {
        match self {
            MeshFormat::Obj => FileType::Obj,
            _ => FileType::Ply,
        }
    }
}

impl fmt::Display for MeshFormat {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(self.name())
    }
}

impl FromStr for MeshFormat {
    type Err = SceneError;

    fn from_str(s: &str) -> Result<Self> {
        MeshFormat::ALL
            .into_iter()
            .find(|f| f.name().eq_ignore_ascii_case(s))
            .ok_or_else(|| {
                let names: Vec<&str> = MeshFormat::ALL.iter().map(|f| f.name()).collect();
                SceneError::InvalidArgument(format!(
                    "unknown mesh format '{s}' (expected one of {})",
                    names.join(", ")
                ))
            })
    }
}

/// A mesh file type, as told by the extension. A PLY file's encoding is in
/// its header, so reading needs only the type.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub enum FileType {
    /// `.ply`
    Ply,
    /// `.obj`
    Obj,
}

impl FileType {
    /// The type of `path` by its extension (case-insensitive).
    pub fn from_path(path: &Path) -> Result<FileType> {
        let ext = path.extension().and_then(|e| e.to_str()).unwrap_or("");
        if ext.eq_ignore_ascii_case("ply") {
            Ok(FileType::Ply)
        } else if ext.eq_ignore_ascii_case("obj") {
            Ok(FileType::Obj)
        } else {
            Err(SceneError::InvalidArgument(format!(
                "{}: unknown mesh file extension '{ext}' (expected .ply or .obj)",
                path.display()
            )))
        }
    }

    /// The extension, without the dot.
    pub fn extension(self) -> &'static str {
        match self {
            FileType::Ply => "ply",
            FileType::Obj => "obj",
        }
    }
}

/// Precision of the coordinates written.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, Default)]
pub enum Precision {
    /// Single precision where that loses nothing (every coordinate is an
    /// `f32`, e.g. a mesh read from a float PLY), double otherwise. Reading
    /// the file back gives the same mesh, bit for bit.
    #[default]
    Auto,
    /// Single precision: half the size of double for vertices, at about 7
    /// significant digits (steps of 4 µm at 60 m from the origin).
    Single,
    /// Double precision.
    Double,
}

/// How to write a mesh.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub struct WriteOptions {
    /// The format and encoding.
    pub format: MeshFormat,
    /// The coordinate precision.
    pub precision: Precision,
}

impl WriteOptions {
    /// `format` with [`Precision::Auto`].
    pub fn new(format: MeshFormat) -> Self {
        WriteOptions {
            format,
            precision: Precision::Auto,
        }
    }

    /// Sets the coordinate precision.
    pub fn precision(mut self, precision: Precision) -> Self {
        self.precision = precision;
        self
    }
}

/// A vertex or triangle of a parsed mesh whose place in the file is wanted.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub(crate) enum Target {
    /// Vertex index in the mesh.
    Vertex(usize),
    /// Triangle index in the mesh (polygons are split into several).
    Triangle(usize),
}

/// Where a [`Target`] is in the file.
#[derive(Debug, Clone, PartialEq, Eq)]
pub(crate) struct Found {
    pub(crate) location: Location,
    /// Index of the vertex or face (polygon) among the file's own.
    pub(crate) index: usize,
}

/// Something a reader accepted but a user should hear about: a file read
/// in a way its author may not have meant (today: a PLY header line without
/// a keyword, read as a comment). The readers return these instead of
/// printing them, so that the caller (the CLI, Python, a job) tells the
/// user in its own way.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct ReadWarning {
    /// The file read.
    pub path: PathBuf,
    /// Where in it.
    pub location: Location,
    /// What was read how.
    pub message: String,
}

impl fmt::Display for ReadWarning {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(
            f,
            "{}: {}: {}",
            self.path.display(),
            self.location,
            self.message
        )
    }
}

/// The points of a point file with their normals and the reader's warnings.
#[derive(Debug, Clone)]
pub struct PointFile {
    /// The vertices of the file.
    pub points: Vec<Point3<f64>>,
    /// One normal per point when the file is a PLY with vertex properties
    /// `nx ny nz`, else `None`.
    pub normals: Option<Vec<Vector3<f64>>>,
    /// What was read with a warning.
    pub warnings: Vec<ReadWarning>,
}

/// [`parse_mesh_raw`] with what was read with a warning.
pub fn parse_mesh_raw_with_warnings(
    bytes: &[u8],
    file_type: FileType,
    origin: &Path,
) -> Result<(Mesh, Vec<ReadWarning>)> {
    match file_type {
        FileType::Ply => ply::parse(bytes, origin),
        FileType::Obj => Ok((obj::parse(bytes, origin)?, Vec::new())),
    }
}

/// Parses a mesh from memory without geometric checks. `origin` names the
/// source in errors. Warnings are dropped: a caller with a user to tell
/// calls [`parse_mesh_raw_with_warnings`].
pub fn parse_mesh_raw(bytes: &[u8], file_type: FileType, origin: &Path) -> Result<Mesh> {
    Ok(parse_mesh_raw_with_warnings(bytes, file_type, origin)?.0)
}

/// [`parse_mesh`] with what was read with a warning.
pub fn parse_mesh_with_warnings(
    bytes: &[u8],
    file_type: FileType,
    origin: &Path,
) -> Result<(Mesh, Vec<ReadWarning>)> {
    let (mut mesh, warnings) = parse_mesh_raw_with_warnings(bytes, file_type, origin)?;
    match validate::first_problem(&mut mesh) {
        None => Ok((mesh, warnings)),
        Some(problem) => Err(validate::error(&problem, &mesh, bytes, file_type, origin)),
    }
}

/// Parses a mesh from memory and validates it ([`Mesh::validate`]); the
/// error names `origin` and the vertex or face at fault. Warnings are
/// dropped ([`parse_mesh_with_warnings`] returns them).
pub fn parse_mesh(bytes: &[u8], file_type: FileType, origin: &Path) -> Result<Mesh> {
    Ok(parse_mesh_with_warnings(bytes, file_type, origin)?.0)
}

/// Points of a point file (PLY or OBJ; faces ignored) with their normals:
/// `Some` with one per point when the file is a PLY with vertex properties
/// `nx ny nz` (vp-mvs's and COLMAP's `fused.ply`), else `None`. Only format
/// errors are reported; coordinates may be non-finite.
pub fn load_points_with_normals(path: &Path) -> Result<PointFile> {
    let bytes = fsio::read_file(path)?;
    match FileType::from_path(path)? {
        FileType::Ply => ply::parse_with_normals(&bytes, path),
        FileType::Obj => Ok(PointFile {
            points: obj::parse(&bytes, path)?.vertices,
            normals: None,
            warnings: Vec::new(),
        }),
    }
}

/// [`load_mesh_raw`] with what was read with a warning.
pub fn load_mesh_raw_with_warnings(path: &Path) -> Result<(Mesh, Vec<ReadWarning>)> {
    let file_type = FileType::from_path(path)?;
    parse_mesh_raw_with_warnings(&fsio::read_file(path)?, file_type, path)
}

/// Loads a mesh, format by extension, reporting only format errors: the
/// mesh may hold non-finite coordinates, out-of-range indices or degenerate
/// faces, for a tool that reports such problems ([`Mesh::cleaned`]).
/// Warnings are dropped ([`load_mesh_raw_with_warnings`] returns them).
pub fn load_mesh_raw(path: &Path) -> Result<Mesh> {
    Ok(load_mesh_raw_with_warnings(path)?.0)
}

/// [`read_mesh`] with what was read with a warning: what the CLI and
/// Python call, to tell the user.
pub fn read_mesh_with_warnings(path: &Path) -> Result<(Mesh, Vec<ReadWarning>)> {
    let file_type = FileType::from_path(path)?;
    parse_mesh_with_warnings(&fsio::read_file(path)?, file_type, path)
}

/// Loads and validates a mesh, format by extension. Every error names the
/// file and the place: line, element and byte offset, vertex or face.
/// Warnings are dropped ([`read_mesh_with_warnings`] returns them).
pub fn read_mesh(path: &Path) -> Result<Mesh> {
    Ok(read_mesh_with_warnings(path)?.0)
}

/// Writes a mesh atomically with [`Precision::Auto`]. The extension of
/// `path` must match the format.
pub fn write_mesh(path: &Path, mesh: &Mesh, format: MeshFormat) -> Result<()> {
    write_mesh_with(path, mesh, WriteOptions::new(format))
}

/// Writes a mesh atomically (no partial file on failure). The extension of
/// `path` must match the format, so that the file reads back.
pub fn write_mesh_with(path: &Path, mesh: &Mesh, options: WriteOptions) -> Result<()> {
    let expected = options.format.file_type();
    if FileType::from_path(path).ok() != Some(expected) {
        return Err(SceneError::InvalidArgument(format!(
            "{}: a {} file needs the extension .{}",
            path.display(),
            options.format,
            expected.extension()
        )));
    }
    check_materials(mesh)?;
    fsio::write_atomic(path, |w| encode_mesh(w, mesh, options))
}

/// Encodes a mesh into any writer (staged in 64 KiB chunks, so an
/// unbuffered writer is fine).
pub fn encode_mesh(w: &mut dyn Write, mesh: &Mesh, options: WriteOptions) -> std::io::Result<()> {
    check_materials(mesh).map_err(|e| std::io::Error::new(std::io::ErrorKind::InvalidInput, e))?;
    let single = match options.precision {
        Precision::Single => true,
        Precision::Double => false,
        // In OBJ, the shortest decimal of an f64 reads back exactly; the f32
        // form would read back as a different f64.
        Precision::Auto if options.format == MeshFormat::Obj => false,
        Precision::Auto => mesh
            .vertices
            .iter()
            .flat_map(|p| p.iter())
            .all(|&c| f64::from(c as f32).to_bits() == c.to_bits()),
    };
    match options.format {
        MeshFormat::PlyAscii => ply::write(w, mesh, Encoding::Ascii, !single),
        MeshFormat::PlyBinaryLittleEndian => {
            ply::write(w, mesh, Encoding::BinaryLittleEndian, !single)
        }
        MeshFormat::PlyBinaryBigEndian => ply::write(w, mesh, Encoding::BinaryBigEndian, !single),
        MeshFormat::Obj => obj::write(w, mesh, single),
    }
}

fn check_materials(mesh: &Mesh) -> Result<()> {
    match &mesh.materials {
        Some(m) if m.len() != mesh.faces.len() => Err(SceneError::InvalidMesh(format!(
            "{} materials for {} faces",
            m.len(),
            mesh.faces.len()
        ))),
        _ => Ok(()),
    }
}

/// Size at which writers hand their staging buffer to the output.
pub(crate) const CHUNK: usize = 1 << 16;

/// Moves a writer's staging buffer out once it is full.
pub(crate) fn flush_if_full(w: &mut dyn Write, buf: &mut Vec<u8>) -> std::io::Result<()> {
    if buf.len() >= CHUNK {
        w.write_all(buf)?;
        buf.clear();
    }
    Ok(())
}
