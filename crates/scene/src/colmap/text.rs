//! COLMAP's text model: `cameras.txt`, `images.txt`, `points3D.txt`.
//!
//! Layout (as COLMAP writes it): `#` comment lines and blank lines are
//! skipped; `cameras.txt` has `CAMERA_ID MODEL WIDTH HEIGHT PARAMS...` per
//! line; `images.txt` has two lines per image, `IMAGE_ID QW QX QY QZ TX TY TZ
//! CAMERA_ID NAME` and then `X Y POINT3D_ID` triples (an empty line when the
//! image has no features; `-1` for a feature without a 3D point);
//! `points3D.txt` has `POINT3D_ID X Y Z R G B ERROR (IMAGE_ID POINT2D_IDX)...`.
//!
//! Unlike COLMAP, which keeps only the first word, an image name is the rest
//! of its line, so names with spaces survive a round trip.

use std::collections::BTreeMap;
use std::fmt::Write as _;
use std::io::Write as _;
use std::path::Path;
use std::str::FromStr;

use nalgebra::{Point2, Point3};

use super::model::{
    pose_from_qt, qt_from_pose, CameraModel, ColmapCamera, ColmapImage, Point2D, Point3D,
};
use super::reconstruction::{insert_unique, Located, Reconstruction};
use crate::error::{Location, Result, SceneError};
use crate::fsio;

/// Whitespace-separated fields of one line, with errors naming file and line.
struct Fields<'a> {
    path: &'a Path,
    line: usize,
    rest: &'a str,
}

impl<'a> Fields<'a> {
    fn new(path: &'a Path, line: usize, text: &'a str) -> Self {
        Fields {
            path,
            line,
            rest: text,
        }
    }

    fn err(&self, message: impl Into<String>) -> SceneError {
        SceneError::parse(self.path, Location::Line(self.line), message)
    }

    fn token(&mut self) -> Option<&'a str> {
        let s = self.rest.trim_start();
        if s.is_empty() {
            self.rest = s;
            return None;
        }
        let end = s.find(char::is_whitespace).unwrap_or(s.len());
        self.rest = &s[end..];
        Some(&s[..end])
    }

    fn next<T: FromStr>(&mut self, what: &str) -> Result<T> {
        let tok = self
            .token()
            .ok_or_else(|| self.err(format!("missing {what}")))?;
        tok.parse()
            .map_err(|_| self.err(format!("bad {what} '{tok}': expected {}", kind_of::<T>())))
    }

    fn finite(&mut self, what: &str) -> Result<f64> {
        let v: f64 = self.next(what)?;
        if v.is_finite() {
            Ok(v)
        } else {
            Err(self.err(format!("{what} is {v}, expected a finite number")))
        }
    }

    fn rest(&self) -> &'a str {
        self.rest.trim()
    }
}

fn kind_of<T>() -> &'static str {
    let name = std::any::type_name::<T>();
    if name == "f64" || name == "f32" {
        "a number"
    } else if name == "u8" {
        "an integer from 0 to 255"
    } else if name.starts_with('i') {
        "an integer"
    } else {
        "a non-negative integer"
    }
}

/// Lines that carry data: (1-based line number, text), comments and blank
/// lines dropped.
fn data_lines(text: &str) -> impl Iterator<Item = (usize, &str)> {
    text.lines()
        .enumerate()
        .map(|(i, l)| (i + 1, l.trim()))
        .filter(|(_, l)| !l.is_empty() && !l.starts_with('#'))
}

/// Reads `cameras.txt`.
pub fn read_cameras_text(path: &Path) -> Result<BTreeMap<u32, ColmapCamera>> {
    parse_cameras(path, &fsio::read_text(path)?)
}

/// Reads the three text files, with each element's line.
pub(crate) fn read_located(
    [cams, ims, pts]: &[std::path::PathBuf; 3],
) -> Result<(Reconstruction, [BTreeMap<u64, Location>; 3])> {
    let (cameras, cp) = parse_cameras_located(cams, &fsio::read_text(cams)?)?;
    let (images, ip) = parse_images_located(ims, &fsio::read_text(ims)?)?;
    let (points, pp) = parse_points3d_located(pts, &fsio::read_text(pts)?)?;
    let widen =
        |m: BTreeMap<u32, Location>| m.into_iter().map(|(k, v)| (u64::from(k), v)).collect();
    Ok((
        Reconstruction {
            cameras,
            images,
            points,
        },
        [widen(cp), widen(ip), pp],
    ))
}

/// Parses the content of a `cameras.txt`; `path` names it in errors.
pub fn parse_cameras(path: &Path, text: &str) -> Result<BTreeMap<u32, ColmapCamera>> {
    Ok(parse_cameras_located(path, text)?.0)
}

/// As [`parse_cameras`], also giving each camera's line.
pub(crate) fn parse_cameras_located(path: &Path, text: &str) -> Result<Located<u32, ColmapCamera>> {
    let mut located = (BTreeMap::new(), BTreeMap::new());
    for (n, line) in data_lines(text) {
        let mut f = Fields::new(path, n, line);
        let id: u32 = f.next("CAMERA_ID")?;
        let name = f.token().ok_or_else(|| f.err("missing MODEL"))?;
        let model = CameraModel::from_name(name).ok_or_else(|| {
            let known: Vec<&str> = CameraModel::ALL.iter().map(|m| m.name()).collect();
            f.err(format!(
                "unknown camera model '{name}' (known: {})",
                known.join(", ")
            ))
        })?;
        let width: u64 = f.next("WIDTH")?;
        let height: u64 = f.next("HEIGHT")?;
        let mut params = Vec::with_capacity(model.num_params());
        while let Some(tok) = f.token() {
            let v: f64 = tok
                .parse()
                .map_err(|_| f.err(format!("bad parameter '{tok}': expected a number")))?;
            if !v.is_finite() {
                return Err(f.err(format!("parameter {} is {v}", params.len())));
            }
            params.push(v);
        }
        model
            .check_param_count(params.len())
            .map_err(|m| f.err(format!("camera {id}: {m}")))?;
        let cam = ColmapCamera {
            id,
            model,
            width,
            height,
            params,
        };
        insert_unique(&mut located, "camera", id, cam, Location::Line(n)).map_err(|m| f.err(m))?;
    }
    Ok(located)
}

/// Reads `images.txt`.
pub fn read_images_text(path: &Path) -> Result<BTreeMap<u32, ColmapImage>> {
    parse_images(path, &fsio::read_text(path)?)
}

/// Parses the content of an `images.txt`; `path` names it in errors.
pub fn parse_images(path: &Path, text: &str) -> Result<BTreeMap<u32, ColmapImage>> {
    Ok(parse_images_located(path, text)?.0)
}

/// As [`parse_images`], also giving each image's line.
pub(crate) fn parse_images_located(path: &Path, text: &str) -> Result<Located<u32, ColmapImage>> {
    let mut located = (BTreeMap::new(), BTreeMap::new());
    let mut lines = text.lines().enumerate().map(|(i, l)| (i + 1, l.trim()));
    while let Some((n, line)) = lines.next() {
        if line.is_empty() || line.starts_with('#') {
            continue;
        }
        let mut f = Fields::new(path, n, line);
        let id: u32 = f.next("IMAGE_ID")?;
        let q = [
            f.finite("QW")?,
            f.finite("QX")?,
            f.finite("QY")?,
            f.finite("QZ")?,
        ];
        let t = [f.finite("TX")?, f.finite("TY")?, f.finite("TZ")?];
        let camera_id: u32 = f.next("CAMERA_ID")?;
        let name = f.rest();
        if name.is_empty() {
            return Err(f.err(format!("image {id}: missing NAME")));
        }
        let cam_from_world = pose_from_qt(q, t).map_err(|m| f.err(format!("image {id}: {m}")))?;
        // The POINTS2D line always follows, even when empty (so it is never
        // skipped as blank). A file cut after the last image line reads as an
        // image without features.
        let mut points2d = Vec::new();
        if let Some((n2, line2)) = lines.next() {
            let mut g = Fields::new(path, n2, line2);
            while let Some(tok) = g.token() {
                let idx = points2d.len();
                let x: f64 = tok
                    .parse()
                    .map_err(|_| g.err(format!("image {id}: bad X of 2D point {idx} '{tok}'")))?;
                let y: f64 = g.next(&format!("Y of 2D point {idx}"))?;
                let pid: i64 = g.next(&format!("POINT3D_ID of 2D point {idx}"))?;
                let point3d_id = match pid {
                    -1 => None,
                    p if p >= 0 => Some(p as u64),
                    p => {
                        return Err(g.err(format!(
                        "image {id}: 2D point {idx} has POINT3D_ID {p} (only -1 may be negative)"
                    )))
                    }
                };
                if !(x.is_finite() && y.is_finite()) {
                    return Err(g.err(format!("image {id}: 2D point {idx} at ({x}, {y})")));
                }
                points2d.push(Point2D {
                    xy: Point2::new(x, y),
                    point3d_id,
                });
            }
        }
        let image = ColmapImage {
            id,
            camera_id,
            name: name.to_string(),
            cam_from_world,
            points2d,
        };
        insert_unique(&mut located, "image", id, image, Location::Line(n)).map_err(|m| f.err(m))?;
    }
    Ok(located)
}

/// Reads `points3D.txt`.
pub fn read_points3d_text(path: &Path) -> Result<BTreeMap<u64, Point3D>> {
    parse_points3d(path, &fsio::read_text(path)?)
}

/// Parses the content of a `points3D.txt`; `path` names it in errors.
pub fn parse_points3d(path: &Path, text: &str) -> Result<BTreeMap<u64, Point3D>> {
    Ok(parse_points3d_located(path, text)?.0)
}

/// As [`parse_points3d`], also giving each point's line.
pub(crate) fn parse_points3d_located(path: &Path, text: &str) -> Result<Located<u64, Point3D>> {
    let mut located = (BTreeMap::new(), BTreeMap::new());
    for (n, line) in data_lines(text) {
        let mut f = Fields::new(path, n, line);
        let id: u64 = f.next("POINT3D_ID")?;
        let xyz = Point3::new(f.finite("X")?, f.finite("Y")?, f.finite("Z")?);
        let rgb = [f.next("R")?, f.next("G")?, f.next("B")?];
        let error: f64 = f.next("ERROR")?;
        let mut track = Vec::new();
        while let Some(tok) = f.token() {
            let image_id: u32 = tok.parse().map_err(|_| {
                f.err(format!(
                    "point {id}: bad IMAGE_ID '{tok}' of track element {}",
                    track.len()
                ))
            })?;
            let idx: u32 = f.next(&format!("POINT2D_IDX of track element {}", track.len()))?;
            track.push((image_id, idx));
        }
        let point = Point3D {
            id,
            xyz,
            rgb,
            error,
            track,
        };
        insert_unique(&mut located, "point", id, point, Location::Line(n)).map_err(|m| f.err(m))?;
    }
    Ok(located)
}

/// Shortest text that parses back to exactly `v` (Rust's float printing
/// round-trips); exponent form for very large or small magnitudes, which
/// COLMAP's `std::stold` reads too.
fn num(out: &mut String, v: f64) {
    let a = v.abs();
    if a == 0.0 || (1e-5..1e16).contains(&a) || !v.is_finite() {
        let _ = write!(out, "{v}");
    } else {
        let _ = write!(out, "{v:e}");
    }
}

/// The text of `cameras.txt` for `rec`.
pub fn cameras_to_string(rec: &Reconstruction) -> String {
    let mut s = String::new();
    s.push_str("# Camera list with one line of data per camera:\n");
    s.push_str("#   CAMERA_ID, MODEL, WIDTH, HEIGHT, PARAMS[]\n");
    let _ = writeln!(s, "# Number of cameras: {}", rec.cameras.len());
    for c in rec.cameras.values() {
        let _ = write!(s, "{} {} {} {}", c.id, c.model, c.width, c.height);
        for &p in &c.params {
            s.push(' ');
            num(&mut s, p);
        }
        s.push('\n');
    }
    s
}

/// The text of `images.txt` for `rec`.
pub fn images_to_string(rec: &Reconstruction) -> String {
    let mut s = String::new();
    s.push_str("# Image list with two lines of data per image:\n");
    s.push_str("#   IMAGE_ID, QW, QX, QY, QZ, TX, TY, TZ, CAMERA_ID, NAME\n");
    s.push_str("#   POINTS2D[] as (X, Y, POINT3D_ID)\n");
    let _ = writeln!(
        s,
        "# Number of images: {}, mean observations per image: {}",
        rec.images.len(),
        rec.mean_observations_per_image()
    );
    for im in rec.images.values() {
        let (q, t) = qt_from_pose(&im.cam_from_world);
        let _ = write!(s, "{}", im.id);
        for v in q.into_iter().chain(t) {
            s.push(' ');
            num(&mut s, v);
        }
        let _ = writeln!(s, " {} {}", im.camera_id, im.name);
        for (i, p) in im.points2d.iter().enumerate() {
            if i > 0 {
                s.push(' ');
            }
            num(&mut s, p.xy.x);
            s.push(' ');
            num(&mut s, p.xy.y);
            match p.point3d_id {
                Some(id) => {
                    let _ = write!(s, " {id}");
                }
                None => s.push_str(" -1"),
            }
        }
        s.push('\n');
    }
    s
}

/// The text of `points3D.txt` for `rec`.
pub fn points3d_to_string(rec: &Reconstruction) -> String {
    let mut s = String::new();
    s.push_str("# 3D point list with one line of data per point:\n");
    s.push_str("#   POINT3D_ID, X, Y, Z, R, G, B, ERROR, TRACK[] as (IMAGE_ID, POINT2D_IDX)\n");
    let _ = writeln!(
        s,
        "# Number of points: {}, mean track length: {}",
        rec.points.len(),
        rec.mean_track_length()
    );
    for p in rec.points.values() {
        let _ = write!(s, "{}", p.id);
        for v in [p.xyz.x, p.xyz.y, p.xyz.z] {
            s.push(' ');
            num(&mut s, v);
        }
        let _ = write!(s, " {} {} {} ", p.rgb[0], p.rgb[1], p.rgb[2]);
        num(&mut s, p.error);
        for (im, idx) in &p.track {
            let _ = write!(s, " {im} {idx}");
        }
        s.push('\n');
    }
    s
}

/// Image names that the two-lines-per-image layout cannot hold.
pub(crate) fn check_names_for_text(rec: &Reconstruction) -> Result<()> {
    for im in rec.images.values() {
        if im.name.trim().is_empty() || im.name.trim() != im.name || im.name.contains(['\n', '\r'])
        {
            return Err(SceneError::InvalidArgument(format!(
                "image {}: name {:?} cannot be written to images.txt (empty, surrounding \
                 whitespace or line break)",
                im.id, im.name
            )));
        }
    }
    Ok(())
}

/// Writes `cameras.txt`, `images.txt` and `points3D.txt` into `dir`, each
/// atomically. The caller has validated `rec`.
pub(crate) fn write_text_files(dir: &Path, rec: &Reconstruction) -> Result<()> {
    check_names_for_text(rec)?;
    for (name, content) in [
        ("cameras.txt", cameras_to_string(rec)),
        ("images.txt", images_to_string(rec)),
        ("points3D.txt", points3d_to_string(rec)),
    ] {
        fsio::write_atomic(&dir.join(name), |w| w.write_all(content.as_bytes()))?;
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    fn p() -> &'static Path {
        Path::new("m/x.txt")
    }

    #[test]
    fn cameras_parse_with_comments_and_errors_name_the_line() {
        let text =
            "# c\n\n1 PINHOLE 640 480 500 501 320 240\n2 SIMPLE_RADIAL 100 80 90 50 40 -0.01\n";
        let cams = parse_cameras(p(), text).unwrap();
        assert_eq!(cams[&1].params, vec![500.0, 501.0, 320.0, 240.0]);
        assert_eq!(cams[&2].model, CameraModel::SimpleRadial);

        let e = parse_cameras(p(), "# c\n1 PINHOLE 640 480 500 501 320\n").unwrap_err();
        assert_eq!(
            e.to_string(),
            "m/x.txt: line 2: camera 1: PINHOLE expects 4 parameters, found 3"
        );
        let e = parse_cameras(p(), "1 BROWN 640 480 500\n").unwrap_err();
        assert!(e
            .to_string()
            .starts_with("m/x.txt: line 1: unknown camera model 'BROWN'"));
        let e = parse_cameras(p(), "1 PINHOLE 640 4x0 1 1 1 1\n").unwrap_err();
        assert!(e.to_string().contains("line 1: bad HEIGHT '4x0'"), "{e}");
        let e = parse_cameras(p(), "1 PINHOLE 6 4 1 1 1 1\n1 PINHOLE 6 4 1 1 1 1\n").unwrap_err();
        assert!(
            e.to_string().contains("line 2: duplicate camera id 1"),
            "{e}"
        );
    }

    #[test]
    fn images_keep_empty_points_line_and_minus_one() {
        let text = "# h\n1 1 0 0 0 0 0 0 1 a.jpg\n\n2 1 0 0 0 1 2 3 1 b c.jpg\n10.5 20 -1 3 4 7\n";
        let ims = parse_images(p(), text).unwrap();
        assert!(ims[&1].points2d.is_empty());
        assert_eq!(ims[&2].name, "b c.jpg");
        assert_eq!(ims[&2].points2d[0].point3d_id, None);
        assert_eq!(ims[&2].points2d[1].point3d_id, Some(7));
        assert_eq!(ims[&2].points2d[0].xy, Point2::new(10.5, 20.0));
    }

    #[test]
    fn images_errors_name_the_line() {
        let e = parse_images(p(), "1 0 0 0 0 0 0 0 1 a.jpg\n\n").unwrap_err();
        assert!(e.to_string().contains("line 1: image 1: quaternion"), "{e}");
        let e = parse_images(p(), "1 1 0 0 0 0 0 0 1 a.jpg\n1 2 -1 3\n").unwrap_err();
        assert!(
            e.to_string().contains("line 2: missing Y of 2D point 1"),
            "{e}"
        );
        let e = parse_images(p(), "1 1 0 0 0 0 0 0 1 a.jpg\n1 2 -2\n").unwrap_err();
        assert!(
            e.to_string()
                .contains("line 2: image 1: 2D point 0 has POINT3D_ID -2"),
            "{e}"
        );
        let e = parse_images(p(), "1 1 0 0 0 0 0 nan 1 a.jpg\n\n").unwrap_err();
        assert!(e.to_string().contains("line 1: TZ is NaN"), "{e}");
        let e = parse_images(p(), "1 1 0 0 0 0 0 0 1\n\n").unwrap_err();
        assert!(
            e.to_string().contains("line 1: image 1: missing NAME"),
            "{e}"
        );
    }

    #[test]
    fn points_parse_and_errors() {
        let pts = parse_points3d(p(), "5 1 2 3 255 0 7 0.5 1 0 2 3\n").unwrap();
        assert_eq!(pts[&5].track, vec![(1, 0), (2, 3)]);
        assert_eq!(pts[&5].rgb, [255, 0, 7]);
        let e = parse_points3d(p(), "5 1 2 3 256 0 7 0.5\n").unwrap_err();
        assert!(e.to_string().contains("line 1: bad R '256'"), "{e}");
        let e = parse_points3d(p(), "\n5 1 2 3 2 0 7 0.5 1\n").unwrap_err();
        assert!(
            e.to_string()
                .contains("line 2: missing POINT2D_IDX of track element 0"),
            "{e}"
        );
    }

    #[test]
    fn numbers_round_trip_exactly() {
        for v in [
            0.1,
            1e-20,
            -3.5e300,
            123_456.789,
            1.0 / 3.0,
            0.0,
            -0.0,
            5e-324,
        ] {
            let mut s = String::new();
            num(&mut s, v);
            assert_eq!(s.parse::<f64>().unwrap().to_bits(), v.to_bits(), "{s}");
        }
    }
}
