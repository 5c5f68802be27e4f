//! Ascii PLY bodies: one element per line, values separated by whitespace.
//!
//! Holding each element to its own line (as every writer does) lets the
//! reader tell a wrong element count from a bad value: a face line read as a
//! vertex has the wrong number of values, and the error names that line.

use std::path::Path;

use super::header::{Header, Kind, Scalar};
use super::{Builder, Plan, Role};
use crate::error::{Location, Result, SceneError};
use crate::io::text::{self, Lines};
use crate::io::Found;

/// Parses one value of type `t`; integers must fit the type.
fn value(t: Scalar, token: &[u8]) -> Option<f64> {
    match t {
        Scalar::F32 => text::parse_f32(token).map(f64::from),
        Scalar::F64 => text::parse_f64(token),
        _ => integer(t, token).map(|v| v as f64),
    }
}

fn integer(t: Scalar, token: &[u8]) -> Option<i64> {
    text::parse_i64(token).filter(|&v| t.holds(v))
}

pub(super) fn read(
    bytes: &[u8],
    header: &Header,
    plan: &Plan,
    path: &Path,
    out: &mut Builder,
) -> Result<Option<Found>> {
    let mut lines = Lines::new(&bytes[header.body_start..], header.body_line);
    for (e, el) in header.elements.iter().enumerate() {
        if el.props.is_empty() {
            continue;
        }
        let is_vertex = e == plan.vertex;
        let is_face = plan.face == Some(e);
        let roles = &plan.roles[e];
        for i in 0..el.count as usize {
            let Some((n, line)) = lines.by_ref().find(|(_, l)| !text::is_blank(l)) else {
                return Err(SceneError::parse(
                    path,
                    Location::Line(lines.line_number()),
                    format!(
                        "file ends before {} {i}: the header declares {} of them",
                        el.name, el.count
                    ),
                ));
            };
            let at = |msg: String| {
                SceneError::parse(path, Location::Line(n), format!("{} {i}: {msg}", el.name))
            };
            let mut tokens = text::tokens(line);
            let mut vals = [0.0f64; 6]; // x y z nx ny nz
            let mut material = None;
            let first_triangle = out.faces.len();
            for (prop, &role) in el.props.iter().zip(roles) {
                let Some(token) = tokens.next() else {
                    return Err(at(ends_before(&prop.name, None)));
                };
                match prop.kind {
                    // Skipped scalars are only counted, not parsed: they
                    // cannot change the mesh.
                    Kind::Scalar(t) => match role {
                        Role::Coord(k) | Role::Normal(k) => {
                            vals[k + role.normal_offset()] = value(t, token)
                                .ok_or_else(|| at(bad_value(token, t, &prop.name)))?;
                        }
                        Role::Material => {
                            material = Some(
                                integer(t, token)
                                    .ok_or_else(|| at(bad_value(token, t, &prop.name)))?,
                            );
                        }
                        Role::Skip | Role::Indices => {}
                    },
                    Kind::List { count, item } => {
                        let len = integer(count, token)
                            .and_then(|c| usize::try_from(c).ok())
                            .ok_or_else(|| at(bad_value(token, count, &prop.name)))?;
                        if role == Role::Indices {
                            // No buffer: the fan pulls each index as it needs it.
                            out.polygon(len, |k| {
                                let token = tokens
                                    .next()
                                    .ok_or_else(|| ends_before(&prop.name, Some(k)))?;
                                integer(item, token)
                                    .ok_or_else(|| bad_value(token, item, &prop.name))
                            })
                            .map_err(at)?;
                        } else {
                            for k in 0..len {
                                if tokens.next().is_none() {
                                    return Err(at(ends_before(&prop.name, Some(k))));
                                }
                            }
                        }
                    }
                }
            }
            if let Some(extra) = tokens.next() {
                return Err(at(format!(
                    "unexpected extra value '{}' after the {} properties of the element \
                     (is an element count in the header wrong?)",
                    text::show(extra),
                    el.props.len()
                )));
            }
            if is_vertex {
                out.vertex(vals);
            }
            if let Some(id) = material {
                out.face_material(id).map_err(at)?;
            }
            if (is_vertex || is_face) && out.hit(is_vertex, first_triangle) {
                return Ok(Some(Found {
                    location: Location::Line(n),
                    index: i,
                }));
            }
        }
    }
    if let Some((n, _)) = lines.find(|(_, l)| !text::is_blank(l)) {
        return Err(SceneError::parse(
            path,
            Location::Line(n),
            "data after the last element declared in the header (is an element count too small?)",
        ));
    }
    Ok(None)
}

fn bad_value(token: &[u8], t: Scalar, name: &str) -> String {
    format!(
        "'{}' is not a valid {} for property '{name}'",
        text::show(token),
        t.name()
    )
}

fn ends_before(name: &str, item: Option<usize>) -> String {
    let what = match item {
        Some(k) => format!("item {k} of list '{name}'"),
        None => format!("property '{name}'"),
    };
    format!("the line ends before {what} (is an element count in the header wrong?)")
}
