//! Binary PLY bodies, little and big endian.
//!
//! The whole file is in memory; values are decoded from byte slices with
//! `from_le_bytes`/`from_be_bytes`, monomorphised per byte order so the inner
//! loop has no branch on endianness.

use std::path::Path;

use super::header::{Element, Header, Kind, Property, Scalar};
use super::{Builder, Plan, Role};
use crate::error::{Location, Result, SceneError};
use crate::io::Found;

/// Byte order of a binary body.
pub(crate) trait Order {
    fn u16(b: [u8; 2]) -> u16;
    fn u32(b: [u8; 4]) -> u32;
    fn u64(b: [u8; 8]) -> u64;
}

/// `binary_little_endian`.
pub(crate) struct Le;
/// `binary_big_endian`.
pub(crate) struct Be;

impl Order for Le {
    #[inline]
    fn u16(b: [u8; 2]) -> u16 {
        u16::from_le_bytes(b)
    }
    #[inline]
    fn u32(b: [u8; 4]) -> u32 {
        u32::from_le_bytes(b)
    }
    #[inline]
    fn u64(b: [u8; 8]) -> u64 {
        u64::from_le_bytes(b)
    }
}

impl Order for Be {
    #[inline]
    fn u16(b: [u8; 2]) -> u16 {
        u16::from_be_bytes(b)
    }
    #[inline]
    fn u32(b: [u8; 4]) -> u32 {
        u32::from_be_bytes(b)
    }
    #[inline]
    fn u64(b: [u8; 8]) -> u64 {
        u64::from_be_bytes(b)
    }
}

/// Decodes a scalar as a float; `b` holds at least `t.size()` bytes.
#[inline]
fn float<O: Order>(t: Scalar, b: &[u8]) -> f64 {
    match t {
        Scalar::F32 => f64::from(f32::from_bits(O::u32([b[0], b[1], b[2], b[3]]))),
        Scalar::F64 => f64::from_bits(O::u64([b[0], b[1], b[2], b[3], b[4], b[5], b[6], b[7]])),
        _ => int::<O>(t, b) as f64,
    }
}

/// Decodes an integer scalar; `b` holds at least `t.size()` bytes.
#[inline]
fn int<O: Order>(t: Scalar, b: &[u8]) -> i64 {
    match t {
        Scalar::I8 => i64::from(b[0] as i8),
        Scalar::U8 => i64::from(b[0]),
        Scalar::I16 => i64::from(O::u16([b[0], b[1]]) as i16),
        Scalar::U16 => i64::from(O::u16([b[0], b[1]])),
        Scalar::I32 => i64::from(O::u32([b[0], b[1], b[2], b[3]]) as i32),
        Scalar::U32 => i64::from(O::u32([b[0], b[1], b[2], b[3]])),
        // The header plan only sends integer types here; a float is
        // converted rather than trusted to be unreachable.
        Scalar::F32 | Scalar::F64 => float::<O>(t, b) as i64,
    }
}

/// The next `n` bytes, or `None` at the end of the file.
#[inline]
fn take<'a>(bytes: &'a [u8], pos: &mut usize, n: usize) -> Option<&'a [u8]> {
    let end = pos.checked_add(n).filter(|&e| e <= bytes.len())?;
    let b = &bytes[*pos..end];
    *pos = end;
    Some(b)
}

fn ends_inside(prop: &Property, len: usize) -> String {
    format!(
        "file truncated: it ends at byte {len}, inside property '{}' of this element",
        prop.name
    )
}

pub(super) fn read<O: Order>(
    bytes: &[u8],
    header: &Header,
    plan: &Plan,
    path: &Path,
    out: &mut Builder,
) -> Result<Option<Found>> {
    let mut pos = header.body_start;
    for (e, el) in header.elements.iter().enumerate() {
        let is_vertex = e == plan.vertex;
        let is_face = plan.face == Some(e);
        if el.props.is_empty() {
            continue;
        }
        if !is_vertex && !is_face {
            if let Some(size) = el.fixed_size() {
                pos = skip_fixed(el, size, pos, bytes.len(), path)?;
                continue;
            }
        }
        let roles = &plan.roles[e];
        for i in 0..el.count as usize {
            let start = pos;
            let location = || Location::Element {
                kind: el.name.clone(),
                index: i,
                byte: Some(start as u64),
            };
            let at = |msg: String| SceneError::parse(path, location(), msg);
            let mut vals = [0.0f64; 6]; // x y z nx ny nz
            let mut material = None;
            let first_triangle = out.faces.len();
            for (prop, &role) in el.props.iter().zip(roles) {
                match prop.kind {
                    Kind::Scalar(t) => {
                        let b = take(bytes, &mut pos, t.size())
                            .ok_or_else(|| at(ends_inside(prop, bytes.len())))?;
                        match role {
                            Role::Coord(k) | Role::Normal(k) => {
                                vals[k + role.normal_offset()] = float::<O>(t, b);
                            }
                            Role::Material => material = Some(int::<O>(t, b)),
                            Role::Skip | Role::Indices => {}
                        }
                    }
                    Kind::List { count, item } => {
                        let b = take(bytes, &mut pos, count.size())
                            .ok_or_else(|| at(ends_inside(prop, bytes.len())))?;
                        let raw = int::<O>(count, b);
                        let n = usize::try_from(raw).map_err(|_| {
                            at(format!("list '{}' has a negative count {raw}", prop.name))
                        })?;
                        let remain = bytes.len() - pos;
                        let items = n
                            .checked_mul(item.size())
                            .and_then(|len| take(bytes, &mut pos, len))
                            .ok_or_else(|| {
                                at(format!(
                                    "list '{}' declares {n} items of {} bytes, but only {remain} \
                                     bytes remain in the file (list count too large or file truncated)",
                                    prop.name,
                                    item.size()
                                ))
                            })?;
                        if role == Role::Indices {
                            let size = item.size();
                            out.polygon(n, |k| Ok(int::<O>(item, &items[k * size..])))
                                .map_err(at)?;
                        }
                    }
                }
            }
            if is_vertex {
                out.vertex(vals);
            }
            if let Some(id) = material {
                out.face_material(id).map_err(at)?;
            }
            if (is_vertex || is_face) && out.hit(is_vertex, first_triangle) {
                return Ok(Some(Found {
                    location: location(),
                    index: i,
                }));
            }
        }
    }
    let rest = &bytes[pos..];
    if !rest.iter().all(u8::is_ascii_whitespace) {
        return Err(SceneError::parse(
            path,
            Location::Byte(pos as u64),
            format!(
                "{} bytes follow the last element declared in the header (is an element count too small?)",
                rest.len()
            ),
        ));
    }
    Ok(None)
}

/// Skips all instances of an element of fixed size in one step.
fn skip_fixed(el: &Element, size: usize, pos: usize, len: usize, path: &Path) -> Result<usize> {
    let remain = len - pos;
    match (el.count as usize).checked_mul(size) {
        Some(total) if total <= remain => Ok(pos + total),
        _ => {
            let index = remain / size;
            Err(SceneError::parse(
                path,
                Location::Element {
                    kind: el.name.clone(),
                    index,
                    byte: Some((pos + index * size) as u64),
                },
                format!(
                    "file truncated: it ends at byte {len}, inside this element ({} declared)",
                    el.count
                ),
            ))
        }
    }
}
