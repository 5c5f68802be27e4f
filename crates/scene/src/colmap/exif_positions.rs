//! Image positions from the photos themselves: the GPS latitude, longitude
//! and altitude a drone's camera writes into each photo's EXIF, read with
//! `kamadak-exif` (JPEG, TIFF, PNG, WebP, HEIF). The alternative to a
//! positions CSV for [`align_to_positions`](super::align_to_positions).

use std::collections::BTreeMap;
use std::io::BufReader;
use std::path::{Path, PathBuf};

use exif::{In, Tag, Value};

use crate::error::{Result, SceneError};
use crate::plan::GeodeticOrigin;

/// File extensions (lower case) of the containers whose EXIF is read.
const PHOTO_EXTENSIONS: [&str; 9] = [
    "jpg", "jpeg", "tif", "tiff", "png", "webp", "heic", "heif", "avif",
];

/// Folders deeper than this below the photo folder are not searched (a
/// guard against a symlinked loop or a whole disk passed by mistake).
const MAX_DEPTH: usize = 8;

/// What [`read_positions_exif`] found in a folder of photos.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct ExifPositions {
    /// Image name (path relative to the folder, `/`-separated, as COLMAP
    /// names images) and its GPS position, sorted by name.
    pub positions: Vec<(String, GeodeticOrigin)>,
    /// Photos without a usable GPS position, with the reason, sorted by name.
    pub skipped: Vec<(String, String)>,
    /// Altitude of the take-off point in the GPS altitudes' datum (above mean
    /// sea level), where the photos also carry their height above take-off
    /// (DJI's XMP `drone-dji:RelativeAltitude`): the median over those photos
    /// of GPS altitude minus relative altitude. `None` without such photos.
    pub takeoff_alt_m: Option<f64>,
    /// How many photos gave a relative altitude.
    pub with_relative_alt: usize,
    /// The lowest and the highest take-off altitude of single photos (name,
    /// metres), where they lie more than [`TAKEOFF_SPREAD_M`] apart: then
    /// the photos come from more than one take-off point (or a barometer
    /// drifted), and [`ExifPositions::takeoff_alt_m`] is `None`, since no
    /// one value is the home of all of them.
    pub takeoff_spread: Option<[(String, f64); 2]>,
}

/// How far apart (metres) the take-off altitudes of single photos may lie
/// and still be one take-off point. Within one flight they agree to a few
/// decimetres (the Brighton Beach flight: 0.00 m over 18 photos, DJI's
/// barometric heights); a second take-off point a few metres up a slope is
/// above this, and 2 m is well inside the 5 m safety distance.
pub const TAKEOFF_SPREAD_M: f64 = 2.0;

/// Reads the EXIF GPS position (WGS84 degrees, metres above sea level) of
/// every photo under `dir` (by extension: JPEG, TIFF, PNG, WebP, HEIF).
/// Photos without EXIF, without GPS tags or with unusable ones (no altitude,
/// no hemisphere, out of range) are listed in [`ExifPositions::skipped`]
/// with the reason. An error when `dir` cannot be read, when a photo cannot
/// be read at the operating-system level, when no photo has a position
/// (the message lists what was wrong with each), or when the photos with a
/// position come from more than one camera model (EXIF `Model`): their
/// altitudes need not share a datum nor their heights a take-off point.
pub fn read_positions_exif(dir: &Path) -> Result<ExifPositions> {
    if !dir.is_dir() {
        return Err(SceneError::io(
            dir,
            std::io::Error::new(std::io::ErrorKind::NotFound, "not a folder of photos"),
        ));
    }
    let mut files = Vec::new();
    collect_photos(dir, dir, 0, &mut files)?;
    files.sort();
    let mut out = ExifPositions::default();
    let mut takeoff = Vec::new();
    let mut cameras: BTreeMap<String, Vec<String>> = BTreeMap::new();
    for (name, path) in &files {
        match read_one(path)? {
            Ok((g, camera)) => {
                if let Some(rel) = dji_relative_altitude(path)? {
                    takeoff.push((g.alt_m - rel, name.clone()));
                }
                if let Some(camera) = camera {
                    cameras.entry(camera).or_default().push(name.clone());
                }
                out.positions.push((name.clone(), g));
            }
            Err(why) => out.skipped.push((name.clone(), why)),
        }
    }
    if cameras.len() > 1 {
        return Err(mixed_cameras(dir, &cameras));
    }
    out.with_relative_alt = takeoff.len();
    takeoff.sort_by(|a, b| a.0.total_cmp(&b.0));
    if let (Some(lo), Some(hi)) = (takeoff.first(), takeoff.last()) {
        if hi.0 - lo.0 > TAKEOFF_SPREAD_M {
            out.takeoff_spread = Some([(lo.1.clone(), lo.0), (hi.1.clone(), hi.0)]);
        } else {
            out.takeoff_alt_m = Some(takeoff[takeoff.len() / 2].0);
        }
    }
    if out.positions.is_empty() {
        let listed: Vec<String> = out
            .skipped
            .iter()
            .take(5)
            .map(|(n, why)| format!("{n}: {why}"))
            .collect();
        let more = out.skipped.len().saturating_sub(listed.len());
        return Err(SceneError::InvalidArgument(format!(
            "{}: no photo has an EXIF GPS position ({} photo(s) read{}{}{})",
            dir.display(),
            files.len(),
            if listed.is_empty() { "" } else { "; " },
            listed.join("; "),
            if more > 0 {
                format!("; and {more} more")
            } else {
                String::new()
            }
        )));
    }
    Ok(out)
}

/// The refusal of photos from more than one camera model, naming each
/// model with its photos and the two ways on.
fn mixed_cameras(dir: &Path, cameras: &BTreeMap<String, Vec<String>>) -> SceneError {
    let list: Vec<String> = cameras
        .iter()
        .map(|(camera, names)| {
            let shown: Vec<&str> = names.iter().take(3).map(String::as_str).collect();
            let more = if names.len() > 3 { ", ..." } else { "" };
            format!("{camera}: {} ({}{more})", names.len(), shown.join(", "))
        })
        .collect();
    SceneError::InvalidArgument(format!(
        "{}: photos with GPS from {} camera models ({}); their GPS altitudes need not share \
         a datum nor their heights a take-off point, so they are not aligned together: \
         align with one camera's photos (move the others to another folder), or give every \
         position in one datum with --positions CSV --datum DATUM",
        dir.display(),
        cameras.len(),
        list.join("; ")
    ))
}

fn collect_photos(
    root: &Path,
    dir: &Path,
    depth: usize,
    out: &mut Vec<(String, PathBuf)>,
) -> Result<()> {
    let entries = std::fs::read_dir(dir).map_err(|e| SceneError::io(dir, e))?;
    for entry in entries {
        let entry = entry.map_err(|e| SceneError::io(dir, e))?;
        let path = entry.path();
        let kind = entry.file_type().map_err(|e| SceneError::io(&path, e))?;
        if kind.is_dir() {
            if depth < MAX_DEPTH {
                collect_photos(root, &path, depth + 1, out)?;
            }
            continue;
        }
        let is_photo = path
            .extension()
            .and_then(|e| e.to_str())
            .is_some_and(|e| PHOTO_EXTENSIONS.contains(&e.to_ascii_lowercase().as_str()));
        if !is_photo || !path.is_file() {
            continue;
        }
        let Ok(rel) = path.strip_prefix(root) else {
            continue;
        };
        let name: Vec<String> = rel
            .components()
            .map(|c| c.as_os_str().to_string_lossy().into_owned())
            .collect();
        out.push((name.join("/"), path));
    }
    Ok(())
}

/// The position of one photo and its camera (EXIF `Make` and `Model`, where
/// written): `Err(SceneError)` when the file cannot be read, `Ok(Err(reason))`
/// when it has no usable GPS position.
fn read_one(path: &Path) -> Result<std::result::Result<(GeodeticOrigin, Option<String>), String>> {
    let file = std::fs::File::open(path).map_err(|e| SceneError::io(path, e))?;
    let exif = match exif::Reader::new().read_from_container(&mut BufReader::new(file)) {
        Ok(exif) => exif,
        Err(exif::Error::Io(e)) => return Err(SceneError::io(path, e)),
        Err(exif::Error::NotFound(_)) => return Ok(Err("no EXIF data".into())),
        Err(e) => return Ok(Err(format!("EXIF unreadable ({e})"))),
    };
    Ok(gps_position(&exif).map(|g| (g, camera_model(&exif))))
}

/// `Make Model` from the primary IFD (either alone where the other is
/// missing), or `None` when neither is written.
fn camera_model(exif: &exif::Exif) -> Option<String> {
    let text = |tag: Tag| match exif.get_field(tag, In::PRIMARY).map(|f| &f.value) {
        Some(Value::Ascii(parts)) => {
            let t: Vec<String> = parts
                .iter()
                .map(|p| {
                    String::from_utf8_lossy(p)
                        .trim_matches(['\0', ' '])
                        .to_string()
                })
                .filter(|p| !p.is_empty())
                .collect();
            (!t.is_empty()).then(|| t.join(" "))
        }
        _ => None,
    };
    match (text(Tag::Make), text(Tag::Model)) {
        (Some(make), Some(model)) => Some(format!("{make} {model}")),
        (one, other) => one.or(other),
    }
}

/// DJI writes its XMP packet near the start of the file, in the first
/// segments of a JPEG; 256 KiB covers it with room for a large thumbnail.
const XMP_SCAN_BYTES: u64 = 256 * 1024;

/// The height above the take-off point that DJI drones write into a photo's
/// XMP (`drone-dji:RelativeAltitude`, as an attribute `="+39.80"` or as an
/// element), or `None` when the photo has none or it is not a number.
fn dji_relative_altitude(path: &Path) -> Result<Option<f64>> {
    use std::io::Read;
    let file = std::fs::File::open(path).map_err(|e| SceneError::io(path, e))?;
    let mut head = Vec::new();
    file.take(XMP_SCAN_BYTES)
        .read_to_end(&mut head)
        .map_err(|e| SceneError::io(path, e))?;
    Ok(xmp_number(&head, "drone-dji:RelativeAltitude"))
}

/// The number after `key` in an XMP packet, written as an attribute
/// (`key="+39.80"`) or an element (`<key>+39.80</key>`).
fn xmp_number(bytes: &[u8], key: &str) -> Option<f64> {
    let k = key.as_bytes();
    let at = bytes.windows(k.len()).position(|w| w == k)? + k.len();
    let rest = &bytes[at..bytes.len().min(at + 64)];
    let rest = std::str::from_utf8(rest)
        .or_else(|e| std::str::from_utf8(&rest[..e.valid_up_to()]))
        .ok()?;
    let value = rest.trim_start().strip_prefix(['=', '>'])?.trim_start();
    let value = value.strip_prefix('"').unwrap_or(value);
    let end = value.find(['"', '<']).unwrap_or(value.len());
    let v: f64 = value[..end].trim().parse().ok()?;
    v.is_finite().then_some(v)
}

/// Latitude, longitude and altitude from the GPS IFD, or why not.
fn gps_position(exif: &exif::Exif) -> std::result::Result<GeodeticOrigin, String> {
    let field = |tag: Tag| exif.get_field(tag, In::PRIMARY).map(|f| &f.value);
    let lat_field = field(Tag::GPSLatitude);
    let lon_field = field(Tag::GPSLongitude);
    if lat_field.is_none() && lon_field.is_none() {
        return Err("no GPS position in its EXIF".into());
    }
    let lat = degrees(lat_field, "latitude")?
        * hemisphere(field(Tag::GPSLatitudeRef), "latitude", b'N', b'S')?;
    let lon = degrees(lon_field, "longitude")?
        * hemisphere(field(Tag::GPSLongitudeRef), "longitude", b'E', b'W')?;
    let alt = match field(Tag::GPSAltitude) {
        Some(Value::Rational(v)) if v.len() == 1 => v[0].to_f64(),
        Some(_) => return Err("GPS altitude is not one rational number".into()),
        None => return Err("no GPS altitude (a 3D alignment needs it)".into()),
    };
    // GPSAltitudeRef 1: below sea level; absent: above (the EXIF default).
    let below = match field(Tag::GPSAltitudeRef) {
        None => false,
        Some(Value::Byte(b)) if b.len() == 1 && b[0] <= 1 => b[0] == 1,
        Some(_) => return Err("GPS altitude reference is neither 0 nor 1".into()),
    };
    let alt = if below { -alt } else { alt };
    if !alt.is_finite() {
        return Err("GPS altitude is not a finite number".into());
    }
    GeodeticOrigin::new(lat, lon, alt).map_err(|e| format!("GPS position out of range: {e}"))
}

/// Degrees from the EXIF degrees, minutes, seconds rationals.
fn degrees(value: Option<&Value>, what: &str) -> std::result::Result<f64, String> {
    let Some(value) = value else {
        return Err(format!("no GPS {what}"));
    };
    let Value::Rational(dms) = value else {
        return Err(format!("GPS {what} is not degrees, minutes, seconds"));
    };
    if dms.is_empty() || dms.len() > 3 {
        return Err(format!(
            "GPS {what} has {} numbers, not degrees, minutes, seconds",
            dms.len()
        ));
    }
    let d = dms
        .iter()
        .zip([1.0, 60.0, 3600.0])
        .map(|(r, div)| r.to_f64() / div)
        .sum::<f64>();
    if d.is_finite() {
        Ok(d)
    } else {
        Err(format!("GPS {what} is not a finite number"))
    }
}

/// +1 or -1 from a `N`/`S` or `E`/`W` reference tag.
fn hemisphere(
    value: Option<&Value>,
    what: &str,
    plus: u8,
    minus: u8,
) -> std::result::Result<f64, String> {
    let first = match value {
        Some(Value::Ascii(v)) => v.first().and_then(|s| s.first()).copied(),
        _ => None,
    };
    match first.map(|c| c.to_ascii_uppercase()) {
        Some(c) if c == plus => Ok(1.0),
        Some(c) if c == minus => Ok(-1.0),
        _ => Err(format!(
            "no GPS {what} reference ({} or {})",
            plus as char, minus as char
        )),
    }
}

#[cfg(test)]
mod xmp_tests {
    use super::xmp_number;

    #[test]
    fn relative_altitude_reads_as_attribute_and_as_element() {
        let attr = br#"<rdf:Description drone-dji:AbsoluteAltitude="+198.31" drone-dji:RelativeAltitude="+39.80" drone-dji:GimbalRollDegree="+0.00""#;
        assert_eq!(xmp_number(attr, "drone-dji:RelativeAltitude"), Some(39.8));
        assert_eq!(xmp_number(attr, "drone-dji:AbsoluteAltitude"), Some(198.31));
        let elem = b"<drone-dji:RelativeAltitude>-2.5</drone-dji:RelativeAltitude>";
        assert_eq!(xmp_number(elem, "drone-dji:RelativeAltitude"), Some(-2.5));
        assert_eq!(
            xmp_number(b"no xmp here", "drone-dji:RelativeAltitude"),
            None
        );
        assert_eq!(
            xmp_number(
                br#"drone-dji:RelativeAltitude="nan""#,
                "drone-dji:RelativeAltitude"
            ),
            None
        );
    }
}
