//! Confidence images (`.vpconf`; the format is in the [`super`] module docs).

use std::path::Path;

use super::{save_gray_png, AngleBins, FORMAT_VERSION};
use crate::binfile::{checksummed, ByteReader};
use crate::error::{Result, SceneError};
use crate::fsio::{read_file, write_file_atomic};

const CONF_MAGIC: [u8; 8] = *b"VPCONF\0\0";

/// Predicted MVS confidence of one image: b values (one per angle bin) on a
/// regular grid. Grid node (i, j) stands for pixel
/// (i * step + step / 2, j * step + step / 2) (integer division), i.e. the
/// continuous position (i * step + step / 2 + 0.5, ...).
#[derive(Debug, Clone, PartialEq)]
pub struct ConfidenceImage {
    width: u32,
    height: u32,
    step: u32,
    bins: AngleBins,
    values: Vec<f32>,
}

impl ConfidenceImage {
    /// A confidence image of a `width` x `height` image at grid step `step`
    /// with every value 0; fill it with [`ConfidenceImage::values_mut`].
    pub fn zeros(width: u32, height: u32, step: u32, bins: AngleBins) -> Result<Self> {
        if width == 0 || height == 0 || step == 0 {
            return Err(SceneError::InvalidArgument(format!(
                "confidence image {width}x{height} with grid step {step}: all must be positive"
            )));
        }
        let (gw, gh) = (
            width.div_ceil(step) as usize,
            height.div_ceil(step) as usize,
        );
        let values = vec![0.0; gw * gh * bins.len()];
        Ok(ConfidenceImage {
            width,
            height,
            step,
            bins,
            values,
        })
    }

    /// The same confidence `value` everywhere and at every angle: the paper's
    /// NP variant (prediction off) uses `constant(1.0)`. It fits an image of
    /// any size, because sampling clamps to the grid.
    pub fn constant(value: f32) -> Self {
        let bins = AngleBins::paper();
        let values = vec![value; bins.len()];
        ConfidenceImage {
            width: 1,
            height: 1,
            step: 1,
            bins,
            values,
        }
    }

    /// Width of the image the grid covers, pixels.
    pub fn width(&self) -> u32 {
        self.width
    }

    /// Height of the image the grid covers, pixels.
    pub fn height(&self) -> u32 {
        self.height
    }

    /// Grid step in pixels.
    pub fn step(&self) -> u32 {
        self.step
    }

    /// The angle bins of the channels.
    pub fn bins(&self) -> &AngleBins {
        &self.bins
    }

    /// Grid size (columns, rows).
    pub fn grid_size(&self) -> (usize, usize) {
        (
            self.width.div_ceil(self.step) as usize,
            self.height.div_ceil(self.step) as usize,
        )
    }

    /// Pixel (integer) that grid node (i, j) stands for, clamped into the image.
    pub fn node_pixel(&self, i: usize, j: usize) -> (u32, u32) {
        let at = |k: usize, size: u32| ((k as u32) * self.step + self.step / 2).min(size - 1);
        (at(i, self.width), at(j, self.height))
    }

    /// All values: grid row-major, bins innermost.
    pub fn values(&self) -> &[f32] {
        &self.values
    }

    /// All values, mutable: grid row-major, bins innermost.
    pub fn values_mut(&mut self) -> &mut [f32] {
        &mut self.values
    }

    /// The b values of grid node (i, j).
    pub fn node(&self, i: usize, j: usize) -> &[f32] {
        let (gw, _) = self.grid_size();
        let b = self.bins.len();
        let k = (j * gw + i) * b;
        &self.values[k..k + b]
    }

    /// Confidence at continuous pixel position `px` for triangulation angle
    /// `angle_deg`: bilinear between grid nodes (clamped at the border),
    /// linear between bin centres (see [`AngleBins::interpolation`]). NaN for
    /// a NaN position or angle.
    pub fn sample(&self, px: (f64, f64), angle_deg: f64) -> f32 {
        let Some((b0, b1, t)) = self.bins.interpolation(angle_deg) else {
            return f32::NAN;
        };
        if px.0.is_nan() || px.1.is_nan() {
            return f32::NAN;
        }
        let (gw, gh) = self.grid_size();
        let offset = f64::from(self.step / 2) + 0.5;
        let grid = |p: f64, n: usize| {
            let g = ((p - offset) / f64::from(self.step)).clamp(0.0, (n - 1) as f64);
            let i0 = (g.floor() as usize).min(n.saturating_sub(2));
            let i1 = (i0 + 1).min(n - 1);
            (i0, i1, (g - i0 as f64) as f32)
        };
        let (x0, x1, fx) = grid(px.0, gw);
        let (y0, y1, fy) = grid(px.1, gh);
        let at_bin = |bin: usize| {
            let v = |i: usize, j: usize| self.values[(j * gw + i) * self.bins.len() + bin];
            let top = v(x0, y0) + fx * (v(x1, y0) - v(x0, y0));
            let bottom = v(x0, y1) + fx * (v(x1, y1) - v(x0, y1));
            top + fy * (bottom - top)
        };
        let c0 = at_bin(b0);
        if b1 == b0 {
            c0
        } else {
            c0 + t * (at_bin(b1) - c0)
        }
    }

    /// Serialises to the `.vpconf` format (see the module docs).
    pub fn to_bytes(&self) -> Vec<u8> {
        let b = self.bins.len() as u32;
        checksummed(CONF_MAGIC, FORMAT_VERSION, |out| {
            for v in [self.width, self.height, self.step, b] {
                out.extend_from_slice(&v.to_le_bytes());
            }
            for v in self.bins.edges().iter().chain(&self.values) {
                out.extend_from_slice(&v.to_le_bytes());
            }
        })
    }

    /// Parses the `.vpconf` format; `path` only names the source in errors.
    pub fn from_bytes(bytes: &[u8], path: &Path) -> Result<Self> {
        let mut r = ByteReader::open_checksummed(
            path,
            bytes,
            CONF_MAGIC,
            FORMAT_VERSION,
            ("vpctl confidence image", "`vpctl predict`"),
        )?;
        let (width, height, step) = (r.u32("width")?, r.u32("height")?, r.u32("step")?);
        let at = r.pos();
        let b = r.u32("bin count")? as usize;
        if b == 0 || b > 1024 {
            return Err(r.error_at(at, format!("{b} angle bins (expected 1 to 1024)")));
        }
        let at = r.pos();
        let edges = (0..=b)
            .map(|_| r.f32("bin edge"))
            .collect::<Result<Vec<_>>>()?;
        let bins = AngleBins::new(edges).map_err(|e| r.error_at(at, e.to_string()))?;
        if width == 0 || height == 0 || step == 0 {
            return Err(r.error_at(
                12,
                format!("image {width}x{height} with grid step {step}: all must be positive"),
            ));
        }
        // Check the size against the file before allocating anything.
        let n = (width.div_ceil(step) as usize)
            .checked_mul(height.div_ceil(step) as usize)
            .and_then(|g| g.checked_mul(b));
        let values_at = r.pos();
        let raw = r.take(
            n.and_then(|n| n.checked_mul(4)).unwrap_or(usize::MAX),
            "values",
        )?;
        let mut values = Vec::with_capacity(raw.len() / 4);
        for (k, c) in raw.chunks_exact(4).enumerate() {
            let v = f32::from_le_bytes([c[0], c[1], c[2], c[3]]);
            if !v.is_finite() {
                return Err(r.error_at(
                    values_at + 4 * k,
                    format!("confidence value {v} is not finite"),
                ));
            }
            values.push(v);
        }
        r.finish("the last value")?;
        Ok(ConfidenceImage {
            width,
            height,
            step,
            bins,
            values,
        })
    }

    /// Writes the `.vpconf` file atomically.
    pub fn save(&self, path: &Path) -> Result<()> {
        write_file_atomic(path, &self.to_bytes())
    }

    /// Reads a `.vpconf` file.
    pub fn load(path: &Path) -> Result<Self> {
        Self::from_bytes(&read_file(path)?, path)
    }

    /// A greyscale PNG of one bin at grid resolution: confidence 0 black,
    /// 1 white (values clamped to [0, 1]).
    pub fn save_bin_png(&self, bin: usize, path: &Path) -> Result<()> {
        if bin >= self.bins.len() {
            return Err(SceneError::InvalidArgument(format!(
                "bin {bin} of a confidence image with {} bins",
                self.bins.len()
            )));
        }
        let (gw, gh) = self.grid_size();
        let img = image::GrayImage::from_fn(gw as u32, gh as u32, |i, j| {
            let v = self.node(i as usize, j as usize)[bin];
            image::Luma([(v.clamp(0.0, 1.0) * 255.0).round() as u8])
        });
        save_gray_png(&img, path)
    }
}
