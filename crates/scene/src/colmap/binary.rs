//! COLMAP's binary model: `cameras.bin`, `images.bin`, `points3D.bin`.
//!
//! Little-endian throughout, as COLMAP's `reconstruction_io_binary.cc`:
//! - `cameras.bin`: u64 count; per camera u32 id, i32 model id, u64 width,
//!   u64 height, f64 params (count given by the model).
//! - `images.bin`: u64 count; per image u32 id, f64 qw qx qy qz tx ty tz,
//!   u32 camera id, NUL-terminated name, u64 number of 2D points, then per
//!   point f64 x, f64 y, u64 3D point id (`u64::MAX` for none).
//! - `points3D.bin`: u64 count; per point u64 id, f64 x y z, u8 r g b,
//!   f64 error, u64 track length, then per element u32 image id, u32 2D point
//!   index.
//!
//! COLMAP 3.12+ also writes `rigs.bin` and `frames.bin`; the per-image pose
//! in `images.bin` is still complete, so those files are not needed here.

use std::collections::BTreeMap;
use std::io::Write as _;
use std::path::Path;

use nalgebra::{Point2, Point3};

use super::model::{
    pose_from_qt, qt_from_pose, CameraModel, ColmapCamera, ColmapImage, Point2D, Point3D,
};
use super::reconstruction::{insert_unique, Located, Reconstruction};
use crate::binfile::ByteReader;
use crate::error::{Location, Result, SceneError};
use crate::fsio;

/// Smallest encoded sizes, for the count checks.
const CAMERA_MIN: usize = 4 + 4 + 8 + 8;
const IMAGE_MIN: usize = 4 + 7 * 8 + 4 + 1 + 8;
const POINT2D: usize = 8 + 8 + 8;
const POINT3D_MIN: usize = 8 + 3 * 8 + 3 + 8 + 8;
const TRACK_ELEM: usize = 4 + 4;

/// Reads the three binary files, with each element's place.
pub(crate) fn read_located(
    [cams, ims, pts]: &[std::path::PathBuf; 3],
) -> Result<(Reconstruction, [BTreeMap<u64, Location>; 3])> {
    let (cameras, cp) = parse_cameras_located(cams, &fsio::read_file(cams)?)?;
    let (images, ip) = parse_images_located(ims, &fsio::read_file(ims)?)?;
    let (points, pp) = parse_points3d_located(pts, &fsio::read_file(pts)?)?;
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

/// Reads `cameras.bin`.
pub fn read_cameras_binary(path: &Path) -> Result<BTreeMap<u32, ColmapCamera>> {
    parse_cameras_binary(path, &fsio::read_file(path)?)
}

/// Parses the bytes of a `cameras.bin`; `path` names it in errors.
pub fn parse_cameras_binary(path: &Path, data: &[u8]) -> Result<BTreeMap<u32, ColmapCamera>> {
    Ok(parse_cameras_located(path, data)?.0)
}

fn parse_cameras_located(path: &Path, data: &[u8]) -> Result<Located<u32, ColmapCamera>> {
    let mut r = ByteReader::new(path, data);
    let n = r.count("number of cameras", CAMERA_MIN)?;
    let mut located = (BTreeMap::new(), BTreeMap::new());
    for i in 0..n {
        r.set_element(Some(("camera", i)));
        let start = r.pos();
        let id = r.u32("camera id")?;
        let at = r.pos();
        let model_id = r.i32("model id")?;
        let model = CameraModel::from_id(model_id).ok_or_else(|| {
            r.error_at(
                at,
                format!(
                    "camera {id}: unknown camera model id {model_id} (known: 0 to {})",
                    CameraModel::ALL.len() - 1
                ),
            )
        })?;
        let width = r.u64("width")?;
        let height = r.u64("height")?;
        let params = (0..model.num_params())
            .map(|k| r.finite(&format!("camera {id} ({model}) parameter {k}")))
            .collect::<Result<Vec<_>>>()?;
        let cam = ColmapCamera {
            id,
            model,
            width,
            height,
            params,
        };
        insert_unique(&mut located, "camera", id, cam, r.place(start))
            .map_err(|m| r.error_at(start, m))?;
    }
    r.finish("the last element")?;
    Ok(located)
}

/// Reads `images.bin`.
pub fn read_images_binary(path: &Path) -> Result<BTreeMap<u32, ColmapImage>> {
    parse_images_binary(path, &fsio::read_file(path)?)
}

/// Parses the bytes of an `images.bin`; `path` names it in errors.
pub fn parse_images_binary(path: &Path, data: &[u8]) -> Result<BTreeMap<u32, ColmapImage>> {
    Ok(parse_images_located(path, data)?.0)
}

fn parse_images_located(path: &Path, data: &[u8]) -> Result<Located<u32, ColmapImage>> {
    let mut r = ByteReader::new(path, data);
    let n = r.count("number of images", IMAGE_MIN)?;
    let mut located = (BTreeMap::new(), BTreeMap::new());
    for i in 0..n {
        r.set_element(Some(("image", i)));
        let start = r.pos();
        let id = r.u32("image id")?;
        let pose_at = r.pos();
        let mut qt = [0.0; 7];
        for (v, what) in qt
            .iter_mut()
            .zip(["qw", "qx", "qy", "qz", "tx", "ty", "tz"])
        {
            *v = r.finite(what)?;
        }
        let cam_from_world = pose_from_qt([qt[0], qt[1], qt[2], qt[3]], [qt[4], qt[5], qt[6]])
            .map_err(|m| r.error_at(pose_at, format!("image {id}: {m}")))?;
        let camera_id = r.u32("camera id")?;
        let name = r.cstring("image name")?;
        let np = r.count("number of 2D points", POINT2D)?;
        let mut points2d = Vec::with_capacity(np);
        for k in 0..np {
            let x = r.f64("2D point x")?;
            let y = r.f64("2D point y")?;
            let pid = r.u64("2D point's 3D point id")?;
            if !(x.is_finite() && y.is_finite()) {
                return Err(r.error_at(
                    r.pos() - POINT2D,
                    format!("image {id}: 2D point {k} at ({x}, {y})"),
                ));
            }
            points2d.push(Point2D {
                xy: Point2::new(x, y),
                point3d_id: (pid != u64::MAX).then_some(pid),
            });
        }
        let image = ColmapImage {
            id,
            camera_id,
            name,
            cam_from_world,
            points2d,
        };
        insert_unique(&mut located, "image", id, image, r.place(start))
            .map_err(|m| r.error_at(start, m))?;
    }
    r.finish("the last element")?;
    Ok(located)
}

/// Reads `points3D.bin`.
pub fn read_points3d_binary(path: &Path) -> Result<BTreeMap<u64, Point3D>> {
    parse_points3d_binary(path, &fsio::read_file(path)?)
}

/// Parses the bytes of a `points3D.bin`; `path` names it in errors.
pub fn parse_points3d_binary(path: &Path, data: &[u8]) -> Result<BTreeMap<u64, Point3D>> {
    Ok(parse_points3d_located(path, data)?.0)
}

fn parse_points3d_located(path: &Path, data: &[u8]) -> Result<Located<u64, Point3D>> {
    let mut r = ByteReader::new(path, data);
    let n = r.count("number of points", POINT3D_MIN)?;
    let mut located = (BTreeMap::new(), BTreeMap::new());
    for i in 0..n {
        r.set_element(Some(("point", i)));
        let start = r.pos();
        let id = r.u64("point id")?;
        let xyz = Point3::new(r.finite("x")?, r.finite("y")?, r.finite("z")?);
        let rgb = [r.u8("red")?, r.u8("green")?, r.u8("blue")?];
        let error = r.f64("error")?;
        let len = r.count("track length", TRACK_ELEM)?;
        let mut track = Vec::with_capacity(len);
        for _ in 0..len {
            track.push((r.u32("track image id")?, r.u32("track 2D point index")?));
        }
        let point = Point3D {
            id,
            xyz,
            rgb,
            error,
            track,
        };
        insert_unique(&mut located, "point", id, point, r.place(start))
            .map_err(|m| r.error_at(start, m))?;
    }
    r.finish("the last element")?;
    Ok(located)
}

fn put_u64(out: &mut Vec<u8>, v: u64) {
    out.extend_from_slice(&v.to_le_bytes());
}

fn put_f64(out: &mut Vec<u8>, v: f64) {
    out.extend_from_slice(&v.to_le_bytes());
}

/// The bytes of `cameras.bin` for `rec`.
pub fn cameras_to_bytes(rec: &Reconstruction) -> Vec<u8> {
    let mut out = Vec::new();
    put_u64(&mut out, rec.cameras.len() as u64);
    for c in rec.cameras.values() {
        out.extend_from_slice(&c.id.to_le_bytes());
        out.extend_from_slice(&c.model.id().to_le_bytes());
        put_u64(&mut out, c.width);
        put_u64(&mut out, c.height);
        for &p in &c.params {
            put_f64(&mut out, p);
        }
    }
    out
}

/// The bytes of `images.bin` for `rec`.
pub fn images_to_bytes(rec: &Reconstruction) -> Vec<u8> {
    let mut out = Vec::new();
    put_u64(&mut out, rec.images.len() as u64);
    for im in rec.images.values() {
        out.extend_from_slice(&im.id.to_le_bytes());
        let (q, t) = qt_from_pose(&im.cam_from_world);
        for v in q.into_iter().chain(t) {
            put_f64(&mut out, v);
        }
        out.extend_from_slice(&im.camera_id.to_le_bytes());
        out.extend_from_slice(im.name.as_bytes());
        out.push(0);
        put_u64(&mut out, im.points2d.len() as u64);
        for p in &im.points2d {
            put_f64(&mut out, p.xy.x);
            put_f64(&mut out, p.xy.y);
            put_u64(&mut out, p.point3d_id.unwrap_or(u64::MAX));
        }
    }
    out
}

/// The bytes of `points3D.bin` for `rec`.
pub fn points3d_to_bytes(rec: &Reconstruction) -> Vec<u8> {
    let mut out = Vec::new();
    put_u64(&mut out, rec.points.len() as u64);
    for p in rec.points.values() {
        put_u64(&mut out, p.id);
        for v in [p.xyz.x, p.xyz.y, p.xyz.z] {
            put_f64(&mut out, v);
        }
        out.extend_from_slice(&p.rgb);
        put_f64(&mut out, p.error);
        put_u64(&mut out, p.track.len() as u64);
        for &(im, idx) in &p.track {
            out.extend_from_slice(&im.to_le_bytes());
            out.extend_from_slice(&idx.to_le_bytes());
        }
    }
    out
}

/// Writes `cameras.bin`, `images.bin` and `points3D.bin` into `dir`, each
/// atomically. The caller has validated `rec`.
pub(crate) fn write_binary_files(dir: &Path, rec: &Reconstruction) -> Result<()> {
    for im in rec.images.values() {
        if im.name.is_empty() || im.name.contains('\0') {
            return Err(SceneError::InvalidArgument(format!(
                "image {}: name {:?} cannot be written to images.bin (empty or containing NUL)",
                im.id, im.name
            )));
        }
        if im.points2d.iter().any(|p| p.point3d_id == Some(u64::MAX)) {
            return Err(SceneError::InvalidArgument(format!(
                "image {}: 3D point id {} is COLMAP's 'no point' marker",
                im.id,
                u64::MAX
            )));
        }
    }
    for (name, content) in [
        ("cameras.bin", cameras_to_bytes(rec)),
        ("images.bin", images_to_bytes(rec)),
        ("points3D.bin", points3d_to_bytes(rec)),
    ] {
        fsio::write_atomic(&dir.join(name), |w| w.write_all(&content))?;
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    fn p() -> &'static Path {
        Path::new("m/x.bin")
    }

    fn one_camera(model_id: i32, nparams: usize) -> Vec<u8> {
        let mut b = Vec::new();
        put_u64(&mut b, 1);
        b.extend_from_slice(&7u32.to_le_bytes());
        b.extend_from_slice(&model_id.to_le_bytes());
        put_u64(&mut b, 640);
        put_u64(&mut b, 480);
        for k in 0..nparams {
            put_f64(&mut b, 100.0 + k as f64);
        }
        b
    }

    #[test]
    fn camera_layout_matches_colmap() {
        let cams = parse_cameras_binary(p(), &one_camera(1, 4)).unwrap();
        let c = &cams[&7];
        assert_eq!(c.model, CameraModel::Pinhole);
        assert_eq!((c.width, c.height), (640, 480));
        assert_eq!(c.params, vec![100.0, 101.0, 102.0, 103.0]);
        assert_eq!(one_camera(1, 4).len(), 8 + 24 + 32);
    }

    #[test]
    fn unknown_model_id_names_element_and_byte() {
        let e = parse_cameras_binary(p(), &one_camera(42, 4)).unwrap_err();
        assert_eq!(
            e.to_string(),
            "m/x.bin: camera 0 (byte 12): camera 7: unknown camera model id 42 (known: 0 to 17)"
        );
    }

    #[test]
    fn truncation_and_trailing_bytes_are_errors() {
        let b = one_camera(1, 4);
        let e = parse_cameras_binary(p(), &b[..b.len() - 3]).unwrap_err();
        assert!(
            e.to_string().contains("camera 0 (byte 56): file truncated"),
            "{e}"
        );
        let e = parse_cameras_binary(p(), &b[..5]).unwrap_err();
        assert!(e.to_string().contains("byte 0: file truncated"), "{e}");
        let mut long = b.clone();
        long.push(0);
        let e = parse_cameras_binary(p(), &long).unwrap_err();
        assert!(e.to_string().contains("byte 64: 1 unexpected bytes"), "{e}");
        let mut huge = Vec::new();
        put_u64(&mut huge, u64::MAX);
        let e = parse_points3d_binary(p(), &huge).unwrap_err();
        assert!(e.to_string().contains("number of points is"), "{e}");
    }
}
