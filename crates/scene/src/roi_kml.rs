//! The polygons of a KML document (Google Earth, QGIS, DJI) or a KMZ
//! archive, for [`crate::roi_file`]: every `<Polygon>` with its
//! `<outerBoundaryIs>` and `<innerBoundaryIs>` rings, and the name of the
//! `<Placemark>` it sits in (a `<MultiGeometry>` gives several polygons of
//! one name). Element names are matched without their prefix (`kml:Polygon`
//! is a `Polygon`): KML files in the wild bind the namespace both ways.

use std::io::Read;
use std::path::Path;

use quick_xml::events::Event;
use quick_xml::Reader;

use crate::error::{Location, Result, SceneError};

/// One polygon found in a file (KML, KMZ or GeoJSON), before the checks.
#[derive(Debug, Clone, Default, PartialEq)]
pub(crate) struct Candidate {
    /// Placemark `<name>` or feature property `name`.
    pub name: Option<String>,
    /// Where it is in the file, for messages.
    pub place: String,
    /// Outer boundary, (lon, lat) degrees.
    pub outer: Vec<[f64; 2]>,
    /// Inner boundaries, (lon, lat) degrees.
    pub holes: Vec<Vec<[f64; 2]>>,
}

/// The `.kml` document inside a KMZ archive: `doc.kml` at the root (the
/// KML 2.2 rule), else the first `.kml` entry.
pub(crate) fn kml_from_kmz(bytes: &[u8], path: &Path) -> Result<String> {
    let bad = |message: String| SceneError::parse(path, Location::Header, message);
    let mut zip = zip::ZipArchive::new(std::io::Cursor::new(bytes))
        .map_err(|e| bad(format!("not a ZIP archive (a .kmz is one): {e}")))?;
    let names: Vec<String> = zip
        .file_names()
        .filter_map(|n| n.ok().map(std::borrow::Cow::into_owned))
        .collect();
    let kml = names
        .iter()
        .find(|n| n.eq_ignore_ascii_case("doc.kml"))
        .or_else(|| {
            names
                .iter()
                .find(|n| n.to_ascii_lowercase().ends_with(".kml"))
        })
        .ok_or_else(|| {
            bad(format!(
                "no .kml document inside the archive (entries: {}); export the area from Google \
                 Earth or QGIS as KML or KMZ",
                if names.is_empty() {
                    "none".to_string()
                } else {
                    names.join(", ")
                }
            ))
        })?;
    let mut text = String::new();
    zip.by_name(kml)
        .map_err(|e| bad(format!("{kml}: {e}")))?
        .read_to_string(&mut text)
        .map_err(|e| bad(format!("{kml}: not UTF-8 text: {e}")))?;
    Ok(text)
}

/// What the reader is inside of while it walks the document.
#[derive(Default)]
struct Walk {
    /// Local names of the open elements.
    stack: Vec<String>,
    /// Name of the open `<Placemark>` (its `<name>` child).
    placemark_name: Option<String>,
    /// Polygons of the open `<Placemark>`, waiting for its name (which may
    /// come after the geometry).
    pending: Vec<Candidate>,
    /// The open `<Polygon>`.
    polygon: Option<Candidate>,
    /// Text of the open `<coordinates>` or `<name>`.
    text: String,
    /// Every polygon read, in document order.
    done: Vec<Candidate>,
}

/// Every polygon of the KML `text`; `path` names the file in errors, which
/// give the line.
pub(crate) fn polygons(text: &str, path: &Path) -> Result<Vec<Candidate>> {
    let line_of = |pos: u64| {
        let end = usize::try_from(pos).unwrap_or(usize::MAX).min(text.len());
        text.as_bytes()[..end].split(|&b| b == b'\n').count()
    };
    let err =
        |pos: u64, message: String| SceneError::parse(path, Location::Line(line_of(pos)), message);
    let mut reader = Reader::from_str(text);
    let mut w = Walk::default();
    loop {
        let pos = reader.buffer_position();
        let event = reader
            .read_event()
            .map_err(|e| err(pos, format!("not well-formed XML: {e}")))?;
        match event {
            Event::Start(s) => {
                let name = String::from_utf8_lossy(s.local_name().as_ref()).into_owned();
                match name.as_str() {
                    "Placemark" => {
                        w.placemark_name = None;
                        w.pending.clear();
                    }
                    "Polygon" => {
                        w.polygon = Some(Candidate {
                            place: format!("<Polygon> at line {}", line_of(pos)),
                            ..Candidate::default()
                        });
                    }
                    _ => {}
                }
                w.text.clear();
                w.stack.push(name);
            }
            Event::End(_) => {
                let Some(name) = w.stack.pop() else {
                    return Err(err(pos, "end tag without a start".into()));
                };
                end_element(&mut w, &name).map_err(|m| err(pos, m))?;
            }
            Event::Text(t) => {
                let s = t
                    .decode()
                    .map_err(|e| err(pos, format!("text is not UTF-8: {e}")))?;
                w.text.push_str(&s);
            }
            Event::CData(t) => w.text.push_str(&String::from_utf8_lossy(&t)),
            Event::GeneralRef(r) => {
                let c = match r.resolve_char_ref() {
                    Ok(Some(c)) => c,
                    _ => match r.decode().as_deref() {
                        Ok("amp") => '&',
                        Ok("lt") => '<',
                        Ok("gt") => '>',
                        Ok("quot") => '"',
                        Ok("apos") => '\'',
                        _ => return Err(err(pos, "unknown entity reference".into())),
                    },
                };
                w.text.push(c);
            }
            Event::Eof => break,
            _ => {}
        }
    }
    if let Some(open) = w.stack.first() {
        return Err(err(
            reader.buffer_position(),
            format!("the element <{open}> is never closed"),
        ));
    }
    Ok(w.done)
}

/// Closes element `name` (already popped from the stack).
fn end_element(w: &mut Walk, name: &str) -> std::result::Result<(), String> {
    let parent = w.stack.last().map(String::as_str);
    match name {
        "name" if parent == Some("Placemark") => {
            w.placemark_name = Some(w.text.trim().to_string());
        }
        "coordinates" if parent == Some("LinearRing") => {
            let boundary = w.stack.iter().rev().nth(1).map(String::as_str);
            let ring = parse_coordinates(&w.text)?;
            if let Some(p) = w.polygon.as_mut() {
                match boundary {
                    Some("outerBoundaryIs") if p.outer.is_empty() => p.outer = ring,
                    Some("outerBoundaryIs") => {
                        return Err("a <Polygon> with two outer boundaries".into());
                    }
                    Some("innerBoundaryIs") => p.holes.push(ring),
                    _ => {}
                }
            }
        }
        "Polygon" => {
            if let Some(p) = w.polygon.take() {
                if w.stack.iter().any(|s| s == "Placemark") {
                    w.pending.push(p);
                } else {
                    w.done.push(p);
                }
            }
        }
        "Placemark" => {
            for mut p in w.pending.drain(..) {
                p.name.clone_from(&w.placemark_name);
                w.done.push(p);
            }
        }
        _ => {}
    }
    w.text.clear();
    Ok(())
}

/// A KML `<coordinates>` list: `lon,lat[,alt]` tuples separated by white
/// space (altitudes are ignored: the ROI is a prism over the ground).
fn parse_coordinates(text: &str) -> std::result::Result<Vec<[f64; 2]>, String> {
    text.split_whitespace()
        .enumerate()
        .map(|(i, tuple)| {
            let v: Vec<f64> = tuple
                .split(',')
                .map(|x| x.trim().parse::<f64>())
                .collect::<std::result::Result<_, _>>()
                .map_err(|e| format!("<coordinates> tuple {} {tuple:?}: {e}", i + 1))?;
            match v.as_slice() {
                [lon, lat] | [lon, lat, _] => Ok([*lon, *lat]),
                _ => Err(format!(
                    "<coordinates> tuple {} {tuple:?}: expected lon,lat or lon,lat,alt",
                    i + 1
                )),
            }
        })
        .collect()
}
