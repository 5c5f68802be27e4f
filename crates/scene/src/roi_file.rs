//! Regions of interest drawn on a map: a polygon in longitude/latitude
//! (WGS84) from a KML or KMZ file (Google Earth, QGIS, DJI Pilot) or a
//! GeoJSON file (QGIS, geojson.io; RFC 7946), as `vpctl plan --roi-polygon`
//! and the Python `roi_polygon=` read it through [`GeoPolygon::load`].
//!
//! Rules (docs/formats.md, "ROI files"):
//! - The file must hold one polygon; with several (Placemarks, features,
//!   a MultiPolygon), `name` picks the one whose Placemark `<name>` or
//!   feature property `name` matches, else the file is refused with the
//!   names it holds.
//! - The outer boundary is the area; inner boundaries (holes) are cut out
//!   of it. Altitudes in the file are ignored: the area is a prism over
//!   the ground, its height range set by the caller.
//! - Refused: fewer than 3 distinct corners, a boundary that crosses
//!   itself or another boundary, coordinates that are not degrees, a
//!   GeoJSON `crs` other than WGS84, and (in [`GeoPolygon::to_roi`]) a
//!   polygon more than [`MAX_DISTANCE_M`] from the plan's origin.

use std::path::{Path, PathBuf};

use crate::error::{Location, Result, SceneError};
use crate::fsio;
use crate::geodesy::LocalFrame;
use crate::plan::GeodeticOrigin;
use crate::roi::Roi;
use crate::roi_kml::Candidate;

/// Farthest a polygon corner may lie from the plan's origin, metres: a
/// plan spans a site, not a region; farther, the area was drawn somewhere
/// else (or its latitude and longitude are swapped).
pub const MAX_DISTANCE_M: f64 = 10_000.0;

/// A checked polygon in longitude/latitude degrees (WGS84), as read from
/// a file.
#[derive(Debug, Clone, PartialEq)]
pub struct GeoPolygon {
    /// The file it came from (named in later errors).
    pub source: PathBuf,
    /// Its Placemark or feature name, if it has one.
    pub name: Option<String>,
    /// Outer boundary (lon, lat), open (the closing corner dropped).
    pub outer: Vec<[f64; 2]>,
    /// Holes (lon, lat), open.
    pub holes: Vec<Vec<[f64; 2]>>,
}

/// The next step, said after every refusal of a file.
const DRAW_HINT: &str = "draw one polygon around the area in Google Earth (Add > Polygon, save \
                         as KML/KMZ) or QGIS (export the layer as GeoJSON, EPSG:4326)";

impl GeoPolygon {
    /// Reads the polygon of a `.kml`, `.kmz`, `.geojson` or `.json` file;
    /// `name` picks one of several by name (see the module doc).
    pub fn load(path: &Path, name: Option<&str>) -> Result<GeoPolygon> {
        let ext = path
            .extension()
            .and_then(|e| e.to_str())
            .map(str::to_ascii_lowercase)
            .unwrap_or_default();
        let candidates = match ext.as_str() {
            "kml" => crate::roi_kml::polygons(&fsio::read_text(path)?, path)?,
            "kmz" => {
                let text = crate::roi_kml::kml_from_kmz(&fsio::read_file(path)?, path)?;
                crate::roi_kml::polygons(&text, path)?
            }
            "geojson" | "json" => geojson_polygons(&fsio::read_text(path)?, path)?,
            _ => {
                return Err(SceneError::InvalidArgument(format!(
                    "{}: an area file must be .kml, .kmz, .geojson or .json",
                    path.display()
                )))
            }
        };
        let c = choose(candidates, name, path)?;
        let place = match &c.name {
            Some(n) => format!("{} ({n:?})", c.place),
            None => c.place.clone(),
        };
        let bad = |message: String| {
            SceneError::InvalidArgument(format!("{}: {place}: {message}", path.display()))
        };
        let outer = check_ring(&c.outer, "outer boundary").map_err(bad)?;
        let holes = c
            .holes
            .iter()
            .enumerate()
            .map(|(i, h)| check_ring(h, &format!("hole {}", i + 1)))
            .collect::<std::result::Result<Vec<_>, _>>()
            .map_err(bad)?;
        let mut rings = vec![outer.clone()];
        rings.extend(holes.iter().cloned());
        check_no_crossing(&rings).map_err(bad)?;
        Ok(GeoPolygon {
            source: path.to_path_buf(),
            name: c.name,
            outer,
            holes,
        })
    }

    /// The region in the local ENU frame of `origin`: the polygon as a
    /// prism from `z_min` to `z_max` (metres in that frame). Refused when a
    /// corner lies more than [`MAX_DISTANCE_M`] from the origin.
    pub fn to_roi(&self, origin: GeodeticOrigin, z_min: f64, z_max: f64) -> Result<Roi> {
        let frame = LocalFrame::new(origin)?;
        let enu = |&[lon, lat]: &[f64; 2]| {
            let p = frame.to_enu(GeodeticOrigin {
                lat_deg: lat,
                lon_deg: lon,
                alt_m: origin.alt_m,
            });
            [p[0], p[1]]
        };
        let polygon: Vec<[f64; 2]> = self.outer.iter().map(enu).collect();
        let far = polygon
            .iter()
            .map(|p| p[0].hypot(p[1]))
            .fold(0.0_f64, f64::max);
        if far > MAX_DISTANCE_M {
            let [lon, lat] = self.outer[0];
            return Err(SceneError::InvalidArgument(format!(
                "{}: the polygon reaches {:.1} km from the plan's origin (lat {:.6}, lon {:.6}; \
                 the polygon starts at lat {lat:.6}, lon {lon:.6}), more than {} km: it was \
                 drawn somewhere else, or its latitude and longitude are swapped; {DRAW_HINT} \
                 over the model's site",
                self.source.display(),
                far / 1000.0,
                origin.lat_deg,
                origin.lon_deg,
                MAX_DISTANCE_M / 1000.0
            )));
        }
        Ok(Roi::Polygon {
            polygon,
            holes: self
                .holes
                .iter()
                .map(|h| h.iter().map(enu).collect())
                .collect(),
            z_min,
            z_max,
        })
    }
}

/// The one polygon of a file, or the one named `name`.
fn choose(candidates: Vec<Candidate>, name: Option<&str>, path: &Path) -> Result<Candidate> {
    let refuse = |m: String| SceneError::InvalidArgument(format!("{}: {m}", path.display()));
    let names = || {
        candidates
            .iter()
            .map(|c| match &c.name {
                Some(n) => format!("{n:?}"),
                None => format!("unnamed ({})", c.place),
            })
            .collect::<Vec<_>>()
            .join(", ")
    };
    if candidates.is_empty() {
        return Err(refuse(format!(
            "no polygon in the file (a Placemark with a <Polygon>, or a GeoJSON Polygon or \
             MultiPolygon; points and lines are not areas); {DRAW_HINT}"
        )));
    }
    let Some(name) = name else {
        if candidates.len() > 1 {
            return Err(refuse(format!(
                "{} polygons ({}); pick one with --roi-name NAME (Python: roi_name=), or keep \
                 one polygon in the file",
                candidates.len(),
                names()
            )));
        }
        return Ok(candidates.into_iter().next().unwrap_or_default());
    };
    let matching: Vec<usize> = (0..candidates.len())
        .filter(|&i| candidates[i].name.as_deref() == Some(name))
        .collect();
    match matching.as_slice() {
        [i] => Ok(candidates[*i].clone()),
        [] => Err(refuse(format!(
            "no polygon named {name:?}; the file has {}",
            names()
        ))),
        _ => Err(refuse(format!(
            "{} polygons are named {name:?}; rename them in Google Earth or QGIS so the name \
             picks one",
            matching.len()
        ))),
    }
}

/// A ring with finite degree coordinates and at least 3 distinct corners,
/// returned open (a closing corner equal to the first dropped; repeated
/// consecutive corners merged).
fn check_ring(ring: &[[f64; 2]], what: &str) -> std::result::Result<Vec<[f64; 2]>, String> {
    if let Some((i, [lon, lat])) = ring.iter().enumerate().find(|(_, [lon, lat])| {
        !(lon.is_finite() && lat.is_finite() && lat.abs() <= 90.0 && lon.abs() <= 180.0)
    }) {
        return Err(format!(
            "{what}, corner {}: ({lon}, {lat}) is not longitude, latitude in degrees; export \
             the area in WGS84 (EPSG:4326)",
            i + 1
        ));
    }
    let mut open: Vec<[f64; 2]> = Vec::with_capacity(ring.len());
    for p in ring {
        if open.last() != Some(p) {
            open.push(*p);
        }
    }
    while open.len() > 1 && open.first() == open.last() {
        open.pop();
    }
    let mut distinct = open.clone();
    distinct.sort_by(|a, b| a[0].total_cmp(&b[0]).then(a[1].total_cmp(&b[1])));
    distinct.dedup();
    if distinct.len() < 3 {
        return Err(format!(
            "{what} has {} distinct corners: an area needs at least 3; {DRAW_HINT}",
            distinct.len()
        ));
    }
    Ok(open)
}

/// Refuses boundaries that cross themselves or each other (an area drawn
/// as a figure eight has no inside an operator meant).
fn check_no_crossing(rings: &[Vec<[f64; 2]>]) -> std::result::Result<(), String> {
    let ring_name = |r: usize| {
        if r == 0 {
            "the outer boundary".to_string()
        } else {
            format!("hole {r}")
        }
    };
    let segments: Vec<(usize, usize, [f64; 2], [f64; 2])> = rings
        .iter()
        .enumerate()
        .flat_map(|(r, ring)| {
            (0..ring.len()).map(move |i| (r, i, ring[i], ring[(i + 1) % ring.len()]))
        })
        .collect();
    for (a, &(ra, ia, p1, p2)) in segments.iter().enumerate() {
        for &(rb, ib, q1, q2) in &segments[a + 1..] {
            let n = rings[ra].len();
            let adjacent = ra == rb && (ib == ia + 1 || (ia == 0 && ib == n - 1));
            let crosses = if adjacent {
                // Neighbours share a corner; they only conflict when they
                // fold back over each other.
                let shared = if ib == ia + 1 { p2 } else { p1 };
                let (other_a, other_b) = if ib == ia + 1 { (p1, q2) } else { (p2, q1) };
                orient(shared, other_a, other_b) == 0.0
                    && (other_b[0] - shared[0]) * (other_a[0] - shared[0])
                        + (other_b[1] - shared[1]) * (other_a[1] - shared[1])
                        > 0.0
            } else {
                segments_intersect(p1, p2, q1, q2)
            };
            if crosses {
                let what = if ra == rb {
                    format!("{} crosses itself", ring_name(ra))
                } else {
                    format!("{} crosses {}", ring_name(ra), ring_name(rb))
                };
                return Err(format!(
                    "{what} (edge from corner {} to {} and edge from corner {} to {}, lon/lat \
                     ({:.7}, {:.7})-({:.7}, {:.7}) and ({:.7}, {:.7})-({:.7}, {:.7})); redraw \
                     the area so that its edges do not cross",
                    ia + 1,
                    (ia + 1) % rings[ra].len() + 1,
                    ib + 1,
                    (ib + 1) % rings[rb].len() + 1,
                    p1[0],
                    p1[1],
                    p2[0],
                    p2[1],
                    q1[0],
                    q1[1],
                    q2[0],
                    q2[1],
                ));
            }
        }
    }
    Ok(())
}

/// Twice the signed area of triangle (a, b, c).
fn orient(a: [f64; 2], b: [f64; 2], c: [f64; 2]) -> f64 {
    (b[0] - a[0]) * (c[1] - a[1]) - (b[1] - a[1]) * (c[0] - a[0])
}

/// Whether closed segments p1-p2 and q1-q2 share a point.
pub(crate) fn segments_intersect(p1: [f64; 2], p2: [f64; 2], q1: [f64; 2], q2: [f64; 2]) -> bool {
    let on = |a: [f64; 2], b: [f64; 2], c: [f64; 2]| {
        c[0] >= a[0].min(b[0])
            && c[0] <= a[0].max(b[0])
            && c[1] >= a[1].min(b[1])
            && c[1] <= a[1].max(b[1])
    };
    let d1 = orient(q1, q2, p1);
    let d2 = orient(q1, q2, p2);
    let d3 = orient(p1, p2, q1);
    let d4 = orient(p1, p2, q2);
    if ((d1 > 0.0 && d2 < 0.0) || (d1 < 0.0 && d2 > 0.0))
        && ((d3 > 0.0 && d4 < 0.0) || (d3 < 0.0 && d4 > 0.0))
    {
        return true;
    }
    (d1 == 0.0 && on(q1, q2, p1))
        || (d2 == 0.0 && on(q1, q2, p2))
        || (d3 == 0.0 && on(p1, p2, q1))
        || (d4 == 0.0 && on(p1, p2, q2))
}

/// The polygons of a GeoJSON text: a FeatureCollection, a Feature or a bare
/// geometry (Polygon, MultiPolygon, GeometryCollection).
fn geojson_polygons(text: &str, path: &Path) -> Result<Vec<Candidate>> {
    let v: serde_json::Value = serde_json::from_str(text).map_err(|e| {
        SceneError::parse(
            path,
            Location::Line(e.line()),
            format!("column {}: not JSON: {e}", e.column()),
        )
    })?;
    let bad = |m: String| SceneError::parse(path, Location::Header, m);
    if let Some(crs) = v.get("crs") {
        let name = crs
            .pointer("/properties/name")
            .and_then(|n| n.as_str())
            .unwrap_or_default();
        let wgs84 = ["CRS84", "EPSG::4326", "EPSG:4326"]
            .iter()
            .any(|w| name.to_ascii_uppercase().ends_with(w));
        if !wgs84 {
            return Err(bad(format!(
                "\"crs\" is {name:?}, not WGS84 longitude/latitude: export the layer from QGIS \
                 with CRS EPSG:4326 (RFC 7946 GeoJSON)"
            )));
        }
    }
    let mut out = Vec::new();
    match v.get("type").and_then(|t| t.as_str()) {
        Some("FeatureCollection") => {
            let features = v
                .get("features")
                .and_then(|f| f.as_array())
                .ok_or_else(|| bad("a FeatureCollection without a \"features\" array".into()))?;
            for (i, f) in features.iter().enumerate() {
                feature(f, &format!("feature {i}"), &mut out).map_err(&bad)?;
            }
        }
        Some("Feature") => feature(&v, "the feature", &mut out).map_err(&bad)?,
        Some(_) => geometry(&v, None, "the geometry", &mut out).map_err(&bad)?,
        None => return Err(bad("not GeoJSON: no \"type\" member".into())),
    }
    Ok(out)
}

fn feature(
    f: &serde_json::Value,
    place: &str,
    out: &mut Vec<Candidate>,
) -> std::result::Result<(), String> {
    let name = f.pointer("/properties/name").and_then(|n| match n {
        serde_json::Value::String(s) => Some(s.clone()),
        serde_json::Value::Number(x) => Some(x.to_string()),
        _ => None,
    });
    match f.get("geometry") {
        Some(g) if !g.is_null() => geometry(g, name, place, out),
        _ => Ok(()),
    }
}

fn geometry(
    g: &serde_json::Value,
    name: Option<String>,
    place: &str,
    out: &mut Vec<Candidate>,
) -> std::result::Result<(), String> {
    let coords = || {
        g.get("coordinates")
            .ok_or_else(|| format!("{place}: a geometry without \"coordinates\""))
    };
    match g.get("type").and_then(|t| t.as_str()) {
        Some("Polygon") => out.push(polygon(coords()?, name, place)?),
        Some("MultiPolygon") => {
            let parts = coords()?
                .as_array()
                .ok_or_else(|| format!("{place}: MultiPolygon coordinates are not an array"))?;
            for (i, p) in parts.iter().enumerate() {
                out.push(polygon(p, name.clone(), &format!("{place}, polygon {i}"))?);
            }
        }
        Some("GeometryCollection") => {
            let parts = g
                .get("geometries")
                .and_then(|x| x.as_array())
                .ok_or_else(|| format!("{place}: a GeometryCollection without \"geometries\""))?;
            for (i, p) in parts.iter().enumerate() {
                geometry(p, name.clone(), &format!("{place}, geometry {i}"), out)?;
            }
        }
        _ => {}
    }
    Ok(())
}

fn polygon(
    c: &serde_json::Value,
    name: Option<String>,
    place: &str,
) -> std::result::Result<Candidate, String> {
    let rings: Vec<Vec<[f64; 2]>> = c
        .as_array()
        .ok_or_else(|| format!("{place}: Polygon coordinates are not an array of rings"))?
        .iter()
        .enumerate()
        .map(|(r, ring)| {
            ring.as_array()
                .ok_or_else(|| format!("{place}, ring {r}: not an array of positions"))?
                .iter()
                .enumerate()
                .map(|(i, p)| {
                    let xy = p.as_array().map(|a| {
                        (
                            a.first().and_then(serde_json::Value::as_f64),
                            a.get(1).and_then(serde_json::Value::as_f64),
                        )
                    });
                    match xy {
                        Some((Some(lon), Some(lat))) => Ok([lon, lat]),
                        _ => Err(format!(
                            "{place}, ring {r}, position {i}: expected [longitude, latitude]"
                        )),
                    }
                })
                .collect()
        })
        .collect::<std::result::Result<_, String>>()?;
    let mut it = rings.into_iter();
    Ok(Candidate {
        name,
        place: place.to_string(),
        outer: it.next().unwrap_or_default(),
        holes: it.collect(),
    })
}

#[cfg(test)]
#[path = "roi_file_tests.rs"]
mod tests;
