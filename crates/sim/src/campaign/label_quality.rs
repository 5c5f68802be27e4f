//! labelgen's labels measured against the renderer's truth, per material:
//! the first honest check of label quality (the paper reports 98.7 % correct
//! at 35 % of KITTI's ground-truth pixels labelled).
//!
//! A pixel is truly positive when the MVS's depth there is within the
//! uncertainty bound (`k_sigma` sigma of the triplet's first-order depth
//! uncertainty) of the true depth, and truly negative otherwise (no depth,
//! or a wrong one). Labelled share: labelled pixels over the pixels with a
//! true surface (the renderer's "ground truth pixels").

use std::fmt::Write as _;

use serde::Serialize;
use vp_scene::raster::{Label, LabelImage};
use vp_scene::Material;

use super::reconstruct::truly_positive;
use crate::virtual_mvs::{PixelStatus, PixelTruth};

/// Counts of one material.
#[derive(Debug, Clone, Copy, Default, PartialEq, Serialize)]
pub struct MaterialCounts {
    /// Pixels with a true surface of the material.
    pub surface: u64,
    /// Of them, pixels labelled positive or negative.
    pub labelled: u64,
    /// Of the labelled, those whose label agrees with the truth.
    pub correct: u64,
    /// Labelled positive.
    pub positive: u64,
    /// Labelled positive and truly positive.
    pub correct_positive: u64,
}

/// Label quality per material (index: `Material as usize`).
#[derive(Debug, Clone, Default, PartialEq, Serialize)]
pub struct LabelQuality {
    /// Counts per material, in `Material::ALL` order.
    pub materials: Vec<(String, MaterialCounts)>,
}

impl LabelQuality {
    /// Adds one label image against its view's truth and the MVS depth the
    /// labels were made from (all at the label's resolution).
    pub fn add(&mut self, label: &LabelImage, truth: &[PixelTruth], depth: &[f32], k_sigma: f32) {
        if self.materials.is_empty() {
            self.materials = Material::ALL
                .iter()
                .map(|m| (m.name().to_string(), MaterialCounts::default()))
                .collect();
        }
        let w = label.width() as usize;
        for (i, (t, &z)) in truth.iter().zip(depth).enumerate() {
            let Some(m) = t.material else {
                continue;
            };
            if t.status == PixelStatus::NoSurface {
                continue;
            }
            let c = &mut self.materials[m as usize].1;
            c.surface += 1;
            let l = label.label((i % w) as u32, (i / w) as u32);
            if l == Label::Unlabelled {
                continue;
            }
            let truly = truly_positive(t, z, k_sigma);
            c.labelled += 1;
            c.correct += u64::from((l == Label::Positive) == truly);
            if l == Label::Positive {
                c.positive += 1;
                c.correct_positive += u64::from(truly);
            }
        }
    }

    /// The table's header and rows: per material and in total, the share
    /// of labels that are correct, of positives that are correct, and of
    /// surface pixels labelled, with the labelled pixel count.
    pub fn cells(&self) -> ([&'static str; 5], Vec<[String; 5]>) {
        let header = [
            "material",
            "correct %",
            "positives correct %",
            "labelled % of surface",
            "labelled px",
        ];
        let rows = self
            .materials
            .iter()
            .filter(|(_, c)| c.surface > 0)
            .map(|(n, c)| (n.as_str(), *c))
            .chain(std::iter::once(("all", self.total())))
            .map(|(name, c)| {
                let pos = 100.0 * c.correct_positive as f64 / c.positive.max(1) as f64;
                [
                    name.to_string(),
                    format!("{:.1}", c.correct_pct()),
                    format!("{pos:.1}"),
                    format!("{:.1}", c.labelled_pct()),
                    c.labelled.to_string(),
                ]
            })
            .collect();
        (header, rows)
    }

    /// [`LabelQuality::cells`] as a Markdown table.
    pub fn markdown(&self) -> String {
        let (header, rows) = self.cells();
        let mut t = format!("| {} |\n|---|---|---|---|---|\n", header.join(" | "));
        for r in rows {
            let _ = writeln!(t, "| {} |", r.join(" | "));
        }
        t
    }

    /// All materials together.
    pub fn total(&self) -> MaterialCounts {
        self.materials
            .iter()
            .fold(MaterialCounts::default(), |mut a, (_, c)| {
                a.surface += c.surface;
                a.labelled += c.labelled;
                a.correct += c.correct;
                a.positive += c.positive;
                a.correct_positive += c.correct_positive;
                a
            })
    }
}

impl MaterialCounts {
    /// Share of labelled pixels whose label is correct, percent.
    pub fn correct_pct(&self) -> f64 {
        100.0 * self.correct as f64 / self.labelled.max(1) as f64
    }

    /// Share of surface pixels labelled, percent.
    pub fn labelled_pct(&self) -> f64 {
        100.0 * self.labelled as f64 / self.surface.max(1) as f64
    }
}
