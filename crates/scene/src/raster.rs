//! Raster types shared by forest, labelgen and planner: RGB images, label
//! images, confidence images, and the triangulation-angle bins that tie the
//! last two together.
//!
//! Pixel coordinates follow [`crate::camera`]: continuous, top-left corner of
//! the image at (0, 0), the centre of pixel (i, j) at (i + 0.5, j + 0.5).
//!
//! # File formats
//!
//! Both binary formats are little-endian and end with the 64-bit FNV-1a hash
//! ([`fnv1a64`]) of every byte before it, so truncation and bit rot are caught.
//!
//! Label image (`.vplabel`, written by labelgen, read by the forest):
//!
//! | bytes | content |
//! |---|---|
//! | 8 | magic `VPLABEL\0` |
//! | 4 | format version (u32, currently 1) |
//! | 4 + 4 | width, height (u32) |
//! | width x height | label per pixel, row-major: 0 unlabelled, 1 positive, 2 negative |
//! | 4 x n | triangulation angle (f32, degrees) of each of the n labelled pixels, row-major order |
//! | 8 | FNV-1a 64 of all preceding bytes |
//!
//! Confidence image (`.vpconf`, written by the forest, read by the planner):
//!
//! | bytes | content |
//! |---|---|
//! | 8 | magic `VPCONF\0\0` |
//! | 4 | format version (u32, currently 1) |
//! | 4 x 3 | image width, image height, grid step (u32) |
//! | 4 | b, number of angle bins (u32) |
//! | 4 x (b + 1) | bin edges in degrees (f32) |
//! | 4 x gw x gh x b | values (f32), grid row-major, bins innermost |
//! | 8 | FNV-1a 64 of all preceding bytes |
//!
//! The grid size (gw, gh) = (ceil(width / step), ceil(height / step)) is
//! derived, not stored.

use std::io::Cursor;
use std::io::Write;
use std::path::Path;

use serde::{Deserialize, Serialize};

use crate::error::{Location, Result, SceneError};
use crate::fsio::{read_file, write_atomic};

pub use image::RgbImage;

/// 64-bit FNV-1a hash: the checksum of vpctl's binary files. Any single
/// changed byte changes the hash (each step is a bijection of the state).
pub fn fnv1a64(bytes: &[u8]) -> u64 {
    let mut h: u64 = 0xcbf2_9ce4_8422_2325;
    for &b in bytes {
        h ^= u64::from(b);
        h = h.wrapping_mul(0x0100_0000_01b3);
    }
    h
}

/// Loads an image in any format the `image` crate decodes (PNG, JPEG, TIFF)
/// as 8-bit RGB.
pub fn load_rgb(path: &Path) -> Result<RgbImage> {
    let bytes = read_file(path)?;
    let image_error = |source| SceneError::Image {
        path: path.to_path_buf(),
        source,
    };
    let reader = image::ImageReader::new(Cursor::new(bytes))
        .with_guessed_format()
        .map_err(|e| SceneError::io(path, e))?;
    Ok(reader.decode().map_err(image_error)?.to_rgb8())
}

/// Saves an RGB image in the format its extension names, atomically.
pub fn save_rgb(image: &RgbImage, path: &Path) -> Result<()> {
    let image_error = |source| SceneError::Image {
        path: path.to_path_buf(),
        source,
    };
    let format = image::ImageFormat::from_path(path).map_err(image_error)?;
    let mut buf = Cursor::new(Vec::new());
    image.write_to(&mut buf, format).map_err(image_error)?;
    write_atomic(path, |w| w.write_all(buf.get_ref()))
}

/// Encodes an 8-bit grey image as PNG and writes it atomically.
fn save_gray_png(image: &image::GrayImage, path: &Path) -> Result<()> {
    let mut buf = Cursor::new(Vec::new());
    image
        .write_to(&mut buf, image::ImageFormat::Png)
        .map_err(|source| SceneError::Image {
            path: path.to_path_buf(),
            source,
        })?;
    write_atomic(path, |w| w.write_all(buf.get_ref()))
}

/// Triangulation-angle bins in degrees: b bins given by b + 1 increasing edges.
/// The paper's default is 9 bins of 5 deg over [0, gamma_max = 45).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(try_from = "Vec<f32>", into = "Vec<f32>")]
pub struct AngleBins {
    edges: Vec<f32>,
}

impl AngleBins {
    /// Bins from explicit edges: at least two, finite, non-negative, strictly increasing.
    pub fn new(edges: Vec<f32>) -> Result<Self> {
        let ok = edges.len() >= 2
            && edges.iter().all(|e| e.is_finite() && *e >= 0.0)
            && edges.windows(2).all(|w| w[0] < w[1]);
        if !ok {
            return Err(SceneError::InvalidArgument(format!(
                "angle bin edges must be at least two finite, non-negative, strictly increasing degrees, got {edges:?}"
            )));
        }
        Ok(AngleBins { edges })
    }

    /// `count` bins of equal width over [0, `gamma_max_deg`).
    pub fn uniform(count: usize, gamma_max_deg: f32) -> Result<Self> {
        if count == 0 {
            return Err(SceneError::InvalidArgument("zero angle bins".into()));
        }
        let edges = (0..=count)
            .map(|i| gamma_max_deg * i as f32 / count as f32)
            .collect();
        Self::new(edges)
    }

    /// The paper's bins: 9 bins of 5 deg over [0, 45).
    pub fn paper() -> Self {
        AngleBins {
            edges: (0..=9u8).map(|i| 5.0 * f32::from(i)).collect(),
        }
    }

    /// Number of bins b.
    pub fn len(&self) -> usize {
        self.edges.len() - 1
    }

    /// Always false: there is at least one bin.
    pub fn is_empty(&self) -> bool {
        false
    }

    /// The b + 1 edges in degrees.
    pub fn edges(&self) -> &[f32] {
        &self.edges
    }

    /// The last edge, gamma_max: angles at or above it fall in no bin.
    pub fn gamma_max(&self) -> f32 {
        self.edges[self.edges.len() - 1]
    }

    /// Centre of bin `i` in degrees.
    pub fn centre(&self, i: usize) -> f32 {
        0.5 * (self.edges[i] + self.edges[i + 1])
    }

    /// The bin holding `angle_deg`; `None` below the first edge, at or above
    /// gamma_max, or for NaN.
    pub fn bin_of(&self, angle_deg: f32) -> Option<usize> {
        if !(angle_deg >= self.edges[0] && angle_deg < self.gamma_max()) {
            return None;
        }
        // Bins are few (9 by default): a linear scan beats a binary search.
        self.edges[1..].iter().position(|&e| angle_deg < e)
    }

    /// Interpolation in angle as [`ConfidenceImage::sample`] uses it: the two
    /// bins to blend and the weight of the second. Linear between bin centres;
    /// below the first centre the first bin, from the last centre on (also at
    /// or above gamma_max) the last bin. `None` for a NaN angle.
    pub fn interpolation(&self, angle_deg: f64) -> Option<(usize, usize, f32)> {
        if angle_deg.is_nan() {
            return None;
        }
        let b = self.len();
        if angle_deg <= f64::from(self.centre(0)) {
            return Some((0, 0, 0.0));
        }
        for i in 0..b - 1 {
            let (c0, c1) = (f64::from(self.centre(i)), f64::from(self.centre(i + 1)));
            if angle_deg < c1 {
                return Some((i, i + 1, ((angle_deg - c0) / (c1 - c0)) as f32));
            }
        }
        Some((b - 1, b - 1, 0.0))
    }

    /// Interpolates per-bin values (one per bin) at `angle_deg`, as
    /// [`AngleBins::interpolation`] describes; NaN for a NaN angle.
    pub fn interpolate(&self, per_bin: &[f32], angle_deg: f64) -> f32 {
        match self.interpolation(angle_deg) {
            Some((i0, i1, t)) => per_bin[i0] + t * (per_bin[i1] - per_bin[i0]),
            None => f32::NAN,
        }
    }
}

impl Default for AngleBins {
    fn default() -> Self {
        Self::paper()
    }
}

impl TryFrom<Vec<f32>> for AngleBins {
    type Error = SceneError;
    fn try_from(edges: Vec<f32>) -> Result<Self> {
        Self::new(edges)
    }
}

impl From<AngleBins> for Vec<f32> {
    fn from(bins: AngleBins) -> Self {
        bins.edges
    }
}

/// Training label of one pixel: did the MVS reconstruct it correctly?
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, Serialize, Deserialize)]
pub enum Label {
    /// No evidence either way.
    Unlabelled = 0,
    /// The MVS reconstructed this pixel correctly.
    Positive = 1,
    /// The MVS failed here (wrong or missing).
    Negative = 2,
}

impl Label {
    fn from_byte(b: u8) -> Option<Label> {
        match b {
            0 => Some(Label::Unlabelled),
            1 => Some(Label::Positive),
            2 => Some(Label::Negative),
            _ => None,
        }
    }
}

/// Per-pixel training labels of one image for one triplet, with the
/// triangulation angle (degrees) under which each labelled pixel was obtained.
/// Invariant: an unlabelled pixel has a NaN angle, a labelled one a finite,
/// non-negative angle.
#[derive(Debug, Clone, PartialEq)]
pub struct LabelImage {
    width: u32,
    height: u32,
    labels: Vec<Label>,
    angles: Vec<f32>,
}

const LABEL_MAGIC: [u8; 8] = *b"VPLABEL\0";
const CONF_MAGIC: [u8; 8] = *b"VPCONF\0\0";
const FORMAT_VERSION: u32 = 1;

impl LabelImage {
    /// An image with every pixel unlabelled.
    pub fn new(width: u32, height: u32) -> Self {
        let n = width as usize * height as usize;
        LabelImage {
            width,
            height,
            labels: vec![Label::Unlabelled; n],
            angles: vec![f32::NAN; n],
        }
    }

    /// Width in pixels.
    pub fn width(&self) -> u32 {
        self.width
    }

    /// Height in pixels.
    pub fn height(&self) -> u32 {
        self.height
    }

    fn index(&self, x: u32, y: u32) -> usize {
        assert!(
            x < self.width && y < self.height,
            "pixel ({x}, {y}) outside the label image"
        );
        y as usize * self.width as usize + x as usize
    }

    /// Label of pixel (x, y). Panics outside the image (a programming error).
    pub fn label(&self, x: u32, y: u32) -> Label {
        self.labels[self.index(x, y)]
    }

    /// Triangulation angle of pixel (x, y) in degrees; NaN when unlabelled.
    pub fn angle(&self, x: u32, y: u32) -> f32 {
        self.angles[self.index(x, y)]
    }

    /// Labels pixel (x, y) obtained at `angle_deg`; [`Label::Unlabelled`]
    /// clears it (the angle is then ignored).
    pub fn set(&mut self, x: u32, y: u32, label: Label, angle_deg: f32) -> Result<()> {
        if label != Label::Unlabelled && !(angle_deg.is_finite() && angle_deg >= 0.0) {
            return Err(SceneError::InvalidArgument(format!(
                "label at pixel ({x}, {y}): triangulation angle {angle_deg} deg is not a finite non-negative number"
            )));
        }
        let i = self.index(x, y);
        self.labels[i] = label;
        self.angles[i] = if label == Label::Unlabelled {
            f32::NAN
        } else {
            angle_deg
        };
        Ok(())
    }

    /// Number of pixels carrying `label`.
    pub fn count(&self, label: Label) -> usize {
        self.labels.iter().filter(|&&l| l == label).count()
    }

    /// Labelled pixels in row-major order: (x, y, label, angle in degrees).
    pub fn labelled(&self) -> impl Iterator<Item = (u32, u32, Label, f32)> + '_ {
        let w = self.width as usize;
        self.labels
            .iter()
            .zip(&self.angles)
            .enumerate()
            .filter(|(_, (l, _))| **l != Label::Unlabelled)
            .map(move |(i, (l, a))| ((i % w) as u32, (i / w) as u32, *l, *a))
    }

    /// Serialises to the `.vplabel` format (see the module docs).
    pub fn to_bytes(&self) -> Vec<u8> {
        let mut out = Vec::with_capacity(20 + self.labels.len() + 8);
        out.extend_from_slice(&LABEL_MAGIC);
        for v in [FORMAT_VERSION, self.width, self.height] {
            out.extend_from_slice(&v.to_le_bytes());
        }
        out.extend(self.labels.iter().map(|&l| l as u8));
        for (_, _, _, a) in self.labelled() {
            out.extend_from_slice(&a.to_le_bytes());
        }
        out.extend_from_slice(&fnv1a64(&out).to_le_bytes());
        out
    }

    /// Parses the `.vplabel` format; `path` only names the source in errors.
    pub fn from_bytes(bytes: &[u8], path: &Path) -> Result<Self> {
        let mut r = ByteReader::open(bytes, path, LABEL_MAGIC, "label image")?;
        let width = r.u32("width")?;
        let height = r.u32("height")?;
        let n = width as usize * height as usize;
        let start = r.pos;
        let raw = r.take(n, "labels")?;
        let mut labels = Vec::with_capacity(n);
        for (i, &b) in raw.iter().enumerate() {
            labels.push(Label::from_byte(b).ok_or_else(|| {
                r.error_at(start + i, format!("label byte {b} is not 0, 1 or 2"))
            })?);
        }
        let mut angles = vec![f32::NAN; n];
        for (i, _) in labels
            .iter()
            .enumerate()
            .filter(|(_, l)| **l != Label::Unlabelled)
        {
            let at = r.pos;
            let a = r.f32("angle")?;
            if !(a.is_finite() && a >= 0.0) {
                return Err(r.error_at(
                    at,
                    format!(
                        "angle {a} deg of a labelled pixel is not a finite non-negative number"
                    ),
                ));
            }
            angles[i] = a;
        }
        r.finish()?;
        Ok(LabelImage {
            width,
            height,
            labels,
            angles,
        })
    }

    /// Writes the `.vplabel` file atomically.
    pub fn save(&self, path: &Path) -> Result<()> {
        let bytes = self.to_bytes();
        write_atomic(path, |w| w.write_all(&bytes))
    }

    /// Reads a `.vplabel` file.
    pub fn load(path: &Path) -> Result<Self> {
        Self::from_bytes(&read_file(path)?, path)
    }

    /// A PNG for eyes: positive white, negative grey, unlabelled black.
    pub fn save_preview_png(&self, path: &Path) -> Result<()> {
        let img = image::GrayImage::from_fn(self.width, self.height, |x, y| {
            image::Luma([match self.label(x, y) {
                Label::Unlabelled => 0,
                Label::Positive => 255,
                Label::Negative => 110,
            }])
        });
        save_gray_png(&img, path)
    }
}

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
        let mut out = Vec::with_capacity(36 + 4 * (self.bins.edges().len() + self.values.len()));
        out.extend_from_slice(&CONF_MAGIC);
        let b = self.bins.len() as u32;
        for v in [FORMAT_VERSION, self.width, self.height, self.step, b] {
            out.extend_from_slice(&v.to_le_bytes());
        }
        for v in self.bins.edges().iter().chain(&self.values) {
            out.extend_from_slice(&v.to_le_bytes());
        }
        out.extend_from_slice(&fnv1a64(&out).to_le_bytes());
        out
    }

    /// Parses the `.vpconf` format; `path` only names the source in errors.
    pub fn from_bytes(bytes: &[u8], path: &Path) -> Result<Self> {
        let mut r = ByteReader::open(bytes, path, CONF_MAGIC, "confidence image")?;
        let (width, height, step) = (r.u32("width")?, r.u32("height")?, r.u32("step")?);
        let at = r.pos;
        let b = r.u32("bin count")? as usize;
        if b == 0 || b > 1024 {
            return Err(r.error_at(at, format!("{b} angle bins (expected 1 to 1024)")));
        }
        let at = r.pos;
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
        let values_at = r.pos;
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
        r.finish()?;
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
        let bytes = self.to_bytes();
        write_atomic(path, |w| w.write_all(&bytes))
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

/// Bounds-checked little-endian reader whose errors name the file and the
/// byte offset.
struct ByteReader<'a> {
    bytes: &'a [u8],
    pos: usize,
    path: &'a Path,
}

impl<'a> ByteReader<'a> {
    /// Checks magic, version and checksum, and positions after the version.
    fn open(bytes: &'a [u8], path: &'a Path, magic: [u8; 8], what: &str) -> Result<Self> {
        let r = ByteReader {
            bytes,
            pos: 0,
            path,
        };
        if bytes.len() < 8 || bytes[..8] != magic {
            return Err(r.error_at(0, format!("not a vpctl {what} file (bad magic number)")));
        }
        if bytes.len() < 20 {
            return Err(r.error_at(
                bytes.len(),
                format!("truncated {what}: {} bytes", bytes.len()),
            ));
        }
        let version = u32::from_le_bytes([bytes[8], bytes[9], bytes[10], bytes[11]]);
        if version != FORMAT_VERSION {
            return Err(r.error_at(
                8,
                format!(
                    "{what} format version {version}, this build reads version {FORMAT_VERSION}"
                ),
            ));
        }
        let body = bytes.len() - 8;
        let mut stored = [0u8; 8];
        stored.copy_from_slice(&bytes[body..]);
        if u64::from_le_bytes(stored) != fnv1a64(&bytes[..body]) {
            return Err(r.error_at(
                body,
                "checksum mismatch: the file is truncated or corrupted".to_string(),
            ));
        }
        Ok(ByteReader {
            bytes: &bytes[..body],
            pos: 12,
            path,
        })
    }

    fn error_at(&self, pos: usize, message: String) -> SceneError {
        SceneError::parse(self.path, Location::Byte(pos as u64), message)
    }

    fn take(&mut self, n: usize, what: &str) -> Result<&'a [u8]> {
        let end = self.pos.checked_add(n).filter(|&e| e <= self.bytes.len());
        let Some(end) = end else {
            return Err(self.error_at(self.pos, format!("file ends inside {what}")));
        };
        let s = &self.bytes[self.pos..end];
        self.pos = end;
        Ok(s)
    }

    fn u32(&mut self, what: &str) -> Result<u32> {
        let s = self.take(4, what)?;
        Ok(u32::from_le_bytes([s[0], s[1], s[2], s[3]]))
    }

    fn f32(&mut self, what: &str) -> Result<f32> {
        Ok(f32::from_bits(self.u32(what)?))
    }

    fn finish(&self) -> Result<()> {
        if self.pos != self.bytes.len() {
            return Err(self.error_at(
                self.pos,
                format!(
                    "{} unexpected bytes before the checksum",
                    self.bytes.len() - self.pos
                ),
            ));
        }
        Ok(())
    }
}

#[cfg(test)]
#[path = "raster_tests.rs"]
mod tests;
