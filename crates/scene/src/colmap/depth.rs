//! COLMAP dense depth and normal maps (`stereo/depth_maps/*.geometric.bin`,
//! `*.photometric.bin`, `stereo/normal_maps/*.bin`).
//!
//! Format (COLMAP's `mvs/mat.h`, `read_write_dense.py`): an ASCII header
//! `WIDTH&HEIGHT&CHANNELS&`, then `WIDTH * HEIGHT * CHANNELS` little-endian
//! f32, channel after channel, each channel row after row (x fastest). A
//! depth is the distance along the optical axis (camera z); 0 marks a pixel
//! without depth. A normal map has 3 channels (the x, y and z planes of
//! unit normals in the camera frame, one plane after the other); 0 0 0 marks
//! a pixel without normal.

use std::io::Write as _;
use std::path::Path;

use crate::error::{Location, Result, SceneError};
use crate::fsio;

/// Longest header accepted: three 20-digit numbers and their separators.
const MAX_HEADER: usize = 3 * 21;

/// A single-channel depth map, row-major: `data[y * width + x]`.
#[derive(Debug, Clone, PartialEq)]
pub struct DepthMap {
    /// Width in pixels.
    pub width: u32,
    /// Height in pixels.
    pub height: u32,
    /// Depths along the camera's optical axis; 0 (or non-finite) where the
    /// MVS produced none.
    pub data: Vec<f32>,
}

/// Summary of a depth map's valid pixels (depth > 0 and finite).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct DepthStats {
    /// Number of pixels.
    pub total: usize,
    /// Number of valid pixels.
    pub valid: usize,
    /// `valid / total` (0 for an empty map).
    pub valid_share: f64,
    /// Smallest valid depth, if any pixel is valid.
    pub min: Option<f32>,
    /// Largest valid depth, if any pixel is valid.
    pub max: Option<f32>,
    /// Mean valid depth, if any pixel is valid.
    pub mean: Option<f64>,
}

impl DepthMap {
    /// Depth at pixel column `x`, row `y`, or `None` outside the map.
    pub fn get(&self, x: u32, y: u32) -> Option<f32> {
        (x < self.width && y < self.height)
            .then(|| self.data[y as usize * self.width as usize + x as usize])
    }

    /// Share and range of the valid depths.
    pub fn stats(&self) -> DepthStats {
        let mut valid = 0usize;
        let mut sum = 0.0f64;
        let (mut min, mut max) = (f32::INFINITY, f32::NEG_INFINITY);
        for &d in &self.data {
            if d > 0.0 && d.is_finite() {
                valid += 1;
                sum += f64::from(d);
                min = min.min(d);
                max = max.max(d);
            }
        }
        let total = self.data.len();
        DepthStats {
            total,
            valid,
            valid_share: if total == 0 {
                0.0
            } else {
                valid as f64 / total as f64
            },
            min: (valid > 0).then_some(min),
            max: (valid > 0).then_some(max),
            mean: (valid > 0).then(|| sum / valid as f64),
        }
    }
}

/// A normal map, unit normals in the camera frame, row-major:
/// `data[y * width + x]`; `[0, 0, 0]` where the MVS produced none.
#[derive(Debug, Clone, PartialEq)]
pub struct NormalMap {
    /// Width in pixels.
    pub width: u32,
    /// Height in pixels.
    pub height: u32,
    /// Normal per pixel (x right, y down, z along the optical axis).
    pub data: Vec<[f32; 3]>,
}

/// Reads a COLMAP depth map.
pub fn read_depth_map(path: &Path) -> Result<DepthMap> {
    parse_depth_map(path, &fsio::read_file(path)?)
}

/// Parses the bytes of a COLMAP depth map; `path` names it in errors.
pub fn parse_depth_map(path: &Path, bytes: &[u8]) -> Result<DepthMap> {
    let (width, height, data) = parse_mat(path, bytes, 1)?;
    Ok(DepthMap {
        width,
        height,
        data,
    })
}

/// Reads a COLMAP normal map.
pub fn read_normal_map(path: &Path) -> Result<NormalMap> {
    parse_normal_map(path, &fsio::read_file(path)?)
}

/// Parses the bytes of a COLMAP normal map; `path` names it in errors.
pub fn parse_normal_map(path: &Path, bytes: &[u8]) -> Result<NormalMap> {
    let (width, height, planes) = parse_mat(path, bytes, 3)?;
    let n = width as usize * height as usize;
    let data = (0..n)
        .map(|i| [planes[i], planes[n + i], planes[2 * n + i]])
        .collect();
    Ok(NormalMap {
        width,
        height,
        data,
    })
}

/// Parses a COLMAP `Mat<float>` with `want` channels into its planes.
fn parse_mat(path: &Path, bytes: &[u8], want: usize) -> Result<(u32, u32, Vec<f32>)> {
    let header_err = |m: String| SceneError::parse(path, Location::Header, m);
    let mut dims = [0usize; 3];
    let mut pos = 0;
    for (k, name) in ["width", "height", "channels"].iter().enumerate() {
        let rest = &bytes[pos..bytes.len().min(MAX_HEADER)];
        let Some(end) = rest.iter().position(|&b| b == b'&') else {
            return Err(header_err(format!(
                "expected '{name}&' at byte {pos} (header is WIDTH&HEIGHT&CHANNELS&)"
            )));
        };
        let field = std::str::from_utf8(&rest[..end]).ok().map(str::trim);
        dims[k] = field
            .and_then(|s| s.parse::<usize>().ok())
            .filter(|&v| v > 0)
            .ok_or_else(|| {
                header_err(format!(
                    "{name} '{}' at byte {pos} is not a positive integer",
                    String::from_utf8_lossy(&rest[..end])
                ))
            })?;
        pos += end + 1;
    }
    let [width, height, channels] = dims;
    let (Ok(w), Ok(h)) = (u32::try_from(width), u32::try_from(height)) else {
        return Err(header_err(format!("size {width}x{height} is too large")));
    };
    if channels != want {
        let hint = if want == 1 {
            "a depth map has 1 (is this a normal map?)"
        } else {
            "a normal map has 3 (is this a depth map?)"
        };
        return Err(header_err(format!("{channels} channels, but {hint}")));
    }
    let expected = width
        .checked_mul(height)
        .and_then(|n| n.checked_mul(4 * want))
        .ok_or_else(|| header_err(format!("size {width}x{height} is too large")))?;
    let actual = bytes.len() - pos;
    if actual != expected {
        return Err(SceneError::parse(
            path,
            Location::Byte(pos as u64),
            format!(
                "header says {width}x{height}x{want} float32 = {expected} bytes of data, file has {actual}"
            ),
        ));
    }
    let data = bytes[pos..]
        .chunks_exact(4)
        .map(|c| f32::from_le_bytes([c[0], c[1], c[2], c[3]]))
        .collect();
    Ok((w, h, data))
}

/// Writes a depth map in COLMAP's format, atomically.
pub fn write_depth_map(path: &Path, depth: &DepthMap) -> Result<()> {
    let n = depth.width as usize * depth.height as usize;
    if depth.width == 0 || depth.height == 0 || depth.data.len() != n {
        return Err(SceneError::InvalidArgument(format!(
            "depth map {}x{} with {} values (expected a positive size and {n} values)",
            depth.width,
            depth.height,
            depth.data.len()
        )));
    }
    fsio::write_atomic(path, |w| {
        write!(w, "{}&{}&1&", depth.width, depth.height)?;
        for d in &depth.data {
            w.write_all(&d.to_le_bytes())?;
        }
        Ok(())
    })
}

/// Writes a normal map in COLMAP's format (three planes x, y, z),
/// atomically.
pub fn write_normal_map(path: &Path, normals: &NormalMap) -> Result<()> {
    let n = normals.width as usize * normals.height as usize;
    if normals.width == 0 || normals.height == 0 || normals.data.len() != n {
        return Err(SceneError::InvalidArgument(format!(
            "normal map {}x{} with {} values (expected a positive size and {n} values)",
            normals.width,
            normals.height,
            normals.data.len()
        )));
    }
    fsio::write_atomic(path, |w| {
        write!(w, "{}&{}&3&", normals.width, normals.height)?;
        for c in 0..3 {
            for v in &normals.data {
                w.write_all(&v[c].to_le_bytes())?;
            }
        }
        Ok(())
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    fn p() -> &'static Path {
        Path::new("d/a.geometric.bin")
    }

    fn bytes(header: &str, values: &[f32]) -> Vec<u8> {
        let mut b = header.as_bytes().to_vec();
        for v in values {
            b.extend_from_slice(&v.to_le_bytes());
        }
        b
    }

    #[test]
    fn layout_is_row_major() {
        // 3 wide, 2 high: the second value is pixel (x=1, y=0).
        let d = parse_depth_map(p(), &bytes("3&2&1&", &[1., 2., 3., 4., 5., 6.])).unwrap();
        assert_eq!((d.width, d.height), (3, 2));
        assert_eq!(d.get(1, 0), Some(2.0));
        assert_eq!(d.get(0, 1), Some(4.0));
        assert_eq!(d.get(3, 0), None);
    }

    #[test]
    fn normal_map_is_planar_and_round_trips() {
        // 2 wide, 1 high: planes x x, y y, z z.
        let b = bytes("2&1&3&", &[1., 2., 3., 4., 5., 6.]);
        let n = parse_normal_map(p(), &b).unwrap();
        assert_eq!(n.data, vec![[1., 3., 5.], [2., 4., 6.]]);
        let e = parse_depth_map(p(), &b).unwrap_err();
        assert!(e.to_string().contains("is this a normal map?"), "{e}");
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("a.bin");
        write_normal_map(&path, &n).unwrap();
        assert_eq!(std::fs::read(&path).unwrap(), b);
        assert_eq!(read_normal_map(&path).unwrap(), n);
    }

    #[test]
    fn stats_count_only_positive_finite_depths() {
        let d = DepthMap {
            width: 3,
            height: 2,
            data: vec![0.0, 2.0, f32::NAN, 4.0, -1.0, f32::INFINITY],
        };
        let s = d.stats();
        assert_eq!((s.total, s.valid), (6, 2));
        assert!((s.valid_share - 1.0 / 3.0).abs() < 1e-12);
        assert_eq!((s.min, s.max, s.mean), (Some(2.0), Some(4.0), Some(3.0)));
        let empty = DepthMap {
            width: 1,
            height: 1,
            data: vec![0.0],
        }
        .stats();
        assert_eq!(
            (empty.valid_share, empty.min, empty.mean),
            (0.0, None, None)
        );
    }

    #[test]
    fn bad_inputs_name_the_problem() {
        let e = parse_depth_map(p(), &bytes("3&2&1&", &[1.0; 5])).unwrap_err();
        assert_eq!(
            e.to_string(),
            "d/a.geometric.bin: byte 6: header says 3x2x1 float32 = 24 bytes of data, file has 20"
        );
        let e = parse_depth_map(p(), &bytes("3&2&3&", &[1.0; 18])).unwrap_err();
        assert!(e.to_string().contains("header: 3 channels"), "{e}");
        let e = parse_depth_map(p(), b"3&x&1&").unwrap_err();
        assert!(e.to_string().contains("height 'x' at byte 2"), "{e}");
        let e = parse_depth_map(p(), b"").unwrap_err();
        assert!(e.to_string().contains("expected 'width&'"), "{e}");
        let e = parse_depth_map(p(), b"99999999999999999999999&1&1&").unwrap_err();
        assert!(e.to_string().contains("header"), "{e}");
    }
}
