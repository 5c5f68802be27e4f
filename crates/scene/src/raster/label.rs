//! Label images (`.vplabel`; the format is in the [`super`] module docs).

use std::path::Path;

use serde::{Deserialize, Serialize};

use super::{save_gray_png, FORMAT_VERSION};
use crate::binfile::{checksummed, ByteReader};
use crate::error::{Result, SceneError};
use crate::fsio::{read_file, write_file_atomic};

const LABEL_MAGIC: [u8; 8] = *b"VPLABEL\0";

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
        checksummed(LABEL_MAGIC, FORMAT_VERSION, |out| {
            for v in [self.width, self.height] {
                out.extend_from_slice(&v.to_le_bytes());
            }
            out.extend(self.labels.iter().map(|&l| l as u8));
            for (_, _, _, a) in self.labelled() {
                out.extend_from_slice(&a.to_le_bytes());
            }
        })
    }

    /// Parses the `.vplabel` format; `path` only names the source in errors.
    pub fn from_bytes(bytes: &[u8], path: &Path) -> Result<Self> {
        let mut r = ByteReader::open_checksummed(
            path,
            bytes,
            LABEL_MAGIC,
            FORMAT_VERSION,
            ("vpctl label image", "`vpctl labelgen run`"),
        )?;
        let width = r.u32("width")?;
        let height = r.u32("height")?;
        let n = width as usize * height as usize;
        let start = r.pos();
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
            let at = r.pos();
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
        r.finish("the last value")?;
        Ok(LabelImage {
            width,
            height,
            labels,
            angles,
        })
    }

    /// Writes the `.vplabel` file atomically.
    pub fn save(&self, path: &Path) -> Result<()> {
        write_file_atomic(path, &self.to_bytes())
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
