//! The PLY header: format line, elements and their properties.

use std::path::Path;

use crate::error::{Location, Result, SceneError};
use crate::io::text::{self, Lines};

/// Scalar types of PLY, under both their old and their sized names.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub(crate) enum Scalar {
    I8,
    U8,
    I16,
    U16,
    I32,
    U32,
    F32,
    F64,
}

impl Scalar {
    /// Parses a type name of the header.
    pub(crate) fn from_name(name: &str) -> Option<Scalar> {
        Some(match name {
            "char" | "int8" => Scalar::I8,
            "uchar" | "uint8" => Scalar::U8,
            "short" | "int16" => Scalar::I16,
            "ushort" | "uint16" => Scalar::U16,
            "int" | "int32" => Scalar::I32,
            "uint" | "uint32" => Scalar::U32,
            "float" | "float32" => Scalar::F32,
            "double" | "float64" => Scalar::F64,
            _ => return None,
        })
    }

    /// The classic name, as most tools write it.
    pub(crate) fn name(self) -> &'static str {
        match self {
            Scalar::I8 => "char",
            Scalar::U8 => "uchar",
            Scalar::I16 => "short",
            Scalar::U16 => "ushort",
            Scalar::I32 => "int",
            Scalar::U32 => "uint",
            Scalar::F32 => "float",
            Scalar::F64 => "double",
        }
    }

    /// Size in bytes in a binary body.
    pub(crate) fn size(self) -> usize {
        match self {
            Scalar::I8 | Scalar::U8 => 1,
            Scalar::I16 | Scalar::U16 => 2,
            Scalar::I32 | Scalar::U32 | Scalar::F32 => 4,
            Scalar::F64 => 8,
        }
    }

    pub(crate) fn is_integer(self) -> bool {
        !matches!(self, Scalar::F32 | Scalar::F64)
    }

    /// Whether an integer value fits this (integer) type.
    pub(crate) fn holds(self, v: i64) -> bool {
        let (lo, hi) = match self {
            Scalar::I8 => (i64::from(i8::MIN), i64::from(i8::MAX)),
            Scalar::U8 => (0, i64::from(u8::MAX)),
            Scalar::I16 => (i64::from(i16::MIN), i64::from(i16::MAX)),
            Scalar::U16 => (0, i64::from(u16::MAX)),
            Scalar::I32 => (i64::from(i32::MIN), i64::from(i32::MAX)),
            Scalar::U32 => (0, i64::from(u32::MAX)),
            Scalar::F32 | Scalar::F64 => return false,
        };
        (lo..=hi).contains(&v)
    }
}

/// A property: one scalar, or a list with its own count and item types.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub(crate) enum Kind {
    Scalar(Scalar),
    List { count: Scalar, item: Scalar },
}

#[derive(Debug, Clone)]
pub(crate) struct Property {
    pub(crate) name: String,
    pub(crate) kind: Kind,
}

#[derive(Debug, Clone)]
pub(crate) struct Element {
    pub(crate) name: String,
    pub(crate) count: u64,
    pub(crate) props: Vec<Property>,
}

impl Element {
    /// Bytes per instance in a binary body when every property is a scalar.
    pub(crate) fn fixed_size(&self) -> Option<usize> {
        self.props
            .iter()
            .map(|p| match p.kind {
                Kind::Scalar(s) => Some(s.size()),
                Kind::List { .. } => None,
            })
            .sum()
    }

    /// The smallest number of bytes an instance takes in a binary body
    /// (lists empty); bounds memory reserved up front from a header count.
    pub(crate) fn min_size(&self) -> usize {
        self.props
            .iter()
            .map(|p| match p.kind {
                Kind::Scalar(s) | Kind::List { count: s, .. } => s.size(),
            })
            .sum()
    }

    pub(crate) fn property(&self, name: &str) -> Option<usize> {
        self.props.iter().position(|p| p.name == name)
    }
}

/// How the body is encoded.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub(crate) enum Encoding {
    Ascii,
    BinaryLittleEndian,
    BinaryBigEndian,
}

#[derive(Debug, Clone)]
pub(crate) struct Header {
    pub(crate) encoding: Encoding,
    pub(crate) elements: Vec<Element>,
    /// Byte offset of the first body byte.
    pub(crate) body_start: usize,
    /// 1-based line number of the first body line (ascii bodies).
    pub(crate) body_line: usize,
    /// Lines read with a warning: (1-based line number, what happened).
    pub(crate) notes: Vec<(usize, String)>,
}

/// Parses the header of a PLY file held in `bytes`.
pub(crate) fn parse(bytes: &[u8], path: &Path) -> Result<Header> {
    if !(bytes.starts_with(b"ply\n") || bytes.starts_with(b"ply\r\n")) {
        return Err(SceneError::parse(
            path,
            Location::Line(1),
            "not a PLY file: the first line must be 'ply'",
        ));
    }
    let mut lines = Lines::new(bytes, 1);
    lines.next(); // the magic line
    let mut consumed = next_line_start(bytes, 0);
    let mut state = State::default();
    let mut ended = false;
    let mut notes = Vec::new();
    for (n, raw) in lines.by_ref() {
        // Offsets are tracked on the raw bytes: `raw` lost its '\r' but the
        // body starts after the full line ending.
        consumed = next_line_start(bytes, consumed);
        let line = std::str::from_utf8(raw).map_err(|_| {
            SceneError::parse(
                path,
                Location::Line(n),
                "the header contains bytes that are not text",
            )
        })?;
        if let Some(note) = State::free_text(line) {
            // Old Blender exporters write `Created by Blender3D ...` without
            // `comment`; trimesh and assimp read such files, MeshLab refuses
            // them. Read the line as a comment, but say so: a misspelt
            // keyword would otherwise vanish without a trace. The caller
            // decides how to tell (the CLI prints it, Python warns).
            notes.push((n, note));
            continue;
        }
        if state
            .line(line)
            .map_err(|m| SceneError::parse(path, Location::Line(n), m))?
        {
            ended = true;
            break;
        }
    }
    if !ended {
        return Err(SceneError::parse(
            path,
            Location::Header,
            "the header has no 'end_header' line (file truncated or not PLY)",
        ));
    }
    let Some(encoding) = state.encoding else {
        return Err(SceneError::parse(
            path,
            Location::Header,
            "the header has no 'format' line",
        ));
    };
    Ok(Header {
        encoding,
        elements: state.elements,
        body_start: consumed,
        body_line: lines.line_number(),
        notes,
    })
}

/// What the header lines read so far declared.
#[derive(Default)]
struct State {
    encoding: Option<Encoding>,
    elements: Vec<Element>,
}

impl State {
    /// A header line that starts with no PLY keyword: the warning to give
    /// when reading it as a comment.
    fn free_text(line: &str) -> Option<String> {
        const KEYWORDS: [&str; 6] = [
            "comment",
            "obj_info",
            "format",
            "element",
            "property",
            "end_header",
        ];
        let first = line.split_ascii_whitespace().next()?;
        (!KEYWORDS.contains(&first)).then(|| {
            format!(
                "header line without a PLY keyword read as a comment: '{}'",
                text::show(line.as_bytes())
            )
        })
    }

    /// Takes one header line; `Ok(true)` at `end_header`.
    fn line(&mut self, line: &str) -> std::result::Result<bool, String> {
        let mut words = line.split_ascii_whitespace();
        match words.next() {
            // Blank lines, comments and obj_info carry no structure.
            None | Some("comment" | "obj_info") => {}
            Some("format") => {
                if self.encoding.is_some() {
                    return Err("second 'format' line".into());
                }
                self.encoding = Some(match (words.next(), words.next()) {
                    (Some("ascii"), Some(_)) => Encoding::Ascii,
                    (Some("binary_little_endian"), Some(_)) => Encoding::BinaryLittleEndian,
                    (Some("binary_big_endian"), Some(_)) => Encoding::BinaryBigEndian,
                    _ => {
                        return Err(format!(
                            "unknown format line '{line}' (expected 'format ascii 1.0', \
                             'format binary_little_endian 1.0' or 'format binary_big_endian 1.0')"
                        ))
                    }
                });
            }
            Some("element") => {
                let (Some(name), Some(count), None) = (words.next(), words.next(), words.next())
                else {
                    return Err(format!(
                        "malformed element line '{line}' (expected 'element NAME COUNT')"
                    ));
                };
                let count = count
                    .parse::<u64>()
                    .map_err(|_| format!("element '{name}' has an invalid count '{count}'"))?;
                if self.elements.iter().any(|e| e.name == name) {
                    return Err(format!("element '{name}' is declared twice"));
                }
                self.elements.push(Element {
                    name: name.to_string(),
                    count,
                    props: Vec::new(),
                });
            }
            Some("property") => {
                let Some(element) = self.elements.last_mut() else {
                    return Err("property before any element".into());
                };
                let prop = parse_property(line, &mut words)?;
                if element.property(&prop.name).is_some() {
                    return Err(format!(
                        "property '{}' of element '{}' is declared twice",
                        prop.name, element.name
                    ));
                }
                element.props.push(prop);
            }
            Some("end_header") => return Ok(true),
            Some(other) => {
                return Err(format!(
                    "unknown header keyword '{}'",
                    text::show(other.as_bytes())
                ))
            }
        }
        Ok(false)
    }
}

/// Byte offset just past the line ending that follows `from`.
fn next_line_start(bytes: &[u8], from: usize) -> usize {
    match bytes[from..].iter().position(|&b| b == b'\n') {
        Some(i) => from + i + 1,
        None => bytes.len(),
    }
}

fn parse_property<'a>(
    line: &str,
    words: &mut impl Iterator<Item = &'a str>,
) -> std::result::Result<Property, String> {
    let scalar = |w: Option<&str>| -> std::result::Result<Scalar, String> {
        let w = w.ok_or_else(|| format!("malformed property line '{line}'"))?;
        Scalar::from_name(w).ok_or_else(|| format!("unknown property type '{w}' in '{line}'"))
    };
    let first = words.next();
    let kind = if first == Some("list") {
        let count = scalar(words.next())?;
        let item = scalar(words.next())?;
        if !count.is_integer() {
            return Err(format!(
                "list count type must be an integer type in '{line}'"
            ));
        }
        Kind::List { count, item }
    } else {
        Kind::Scalar(scalar(first)?)
    };
    let (Some(name), None) = (words.next(), words.next()) else {
        return Err(format!("malformed property line '{line}'"));
    };
    Ok(Property {
        name: name.to_string(),
        kind,
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    fn parse_str(s: &str) -> Result<Header> {
        parse(s.as_bytes(), Path::new("t.ply"))
    }

    #[test]
    fn header_with_every_type_name_parses() {
        let h = parse_str(
            "ply\r\nformat binary_big_endian 1.0\r\ncomment hi\r\nobj_info x\r\n\
             element vertex 2\r\nproperty float32 x\r\nproperty float64 y\r\nproperty double z\r\n\
             property int8 a\r\nproperty uint16 b\r\nproperty list uint8 int32 c\r\n\
             element face 0\r\nproperty list uchar uint vertex_index\r\nend_header\r\nBODY",
        )
        .unwrap();
        assert_eq!(h.encoding, Encoding::BinaryBigEndian);
        assert_eq!(h.elements.len(), 2);
        assert_eq!(h.elements[0].props[1].kind, Kind::Scalar(Scalar::F64));
        assert_eq!(
            h.elements[0].props[5].kind,
            Kind::List {
                count: Scalar::U8,
                item: Scalar::I32
            }
        );
        assert_eq!(h.elements[0].fixed_size(), None);
        assert_eq!(h.elements[0].min_size(), 4 + 8 + 8 + 1 + 2 + 1);
        assert_eq!(h.body_line, 15);
        assert_eq!(
            &b"ply\r\nformat binary_big_endian 1.0\r\ncomment hi\r\nobj_info x\r\n\
             element vertex 2\r\nproperty float32 x\r\nproperty float64 y\r\nproperty double z\r\n\
             property int8 a\r\nproperty uint16 b\r\nproperty list uint8 int32 c\r\n\
             element face 0\r\nproperty list uchar uint vertex_index\r\nend_header\r\nBODY"
                [h.body_start..],
            b"BODY"
        );
    }

    #[test]
    fn header_errors_name_the_line() {
        let e = parse_str("plx\n").unwrap_err().to_string();
        assert!(e.contains("t.ply: line 1: not a PLY file"), "{e}");
        let e = parse_str("ply\nformat binary_middle_endian 1.0\nend_header\n")
            .unwrap_err()
            .to_string();
        assert!(e.contains("line 2: unknown format line"), "{e}");
        let e = parse_str("ply\nformat ascii 1.0\nproperty float x\nend_header\n")
            .unwrap_err()
            .to_string();
        assert!(e.contains("line 3: property before any element"), "{e}");
        let e = parse_str("ply\nformat ascii 1.0\nelement vertex 1\nproperty real x\nend_header\n")
            .unwrap_err()
            .to_string();
        assert!(e.contains("line 4: unknown property type 'real'"), "{e}");
        let e = parse_str("ply\nformat ascii 1.0\nelement vertex -3\nend_header\n")
            .unwrap_err()
            .to_string();
        assert!(
            e.contains("line 3: element 'vertex' has an invalid count '-3'"),
            "{e}"
        );
        let e = parse_str("ply\nformat ascii 1.0\nelement vertex 3\n")
            .unwrap_err()
            .to_string();
        assert!(e.contains("header: the header has no 'end_header'"), "{e}");
        let e = parse_str("ply\nelement vertex 3\nend_header\n")
            .unwrap_err()
            .to_string();
        assert!(e.contains("no 'format' line"), "{e}");
        let e = parse_str(
            "ply\nformat ascii 1.0\nelement face 1\nproperty list float int vertex_indices\nend_header\n",
        )
        .unwrap_err()
        .to_string();
        assert!(
            e.contains("line 4: list count type must be an integer"),
            "{e}"
        );
    }
}
