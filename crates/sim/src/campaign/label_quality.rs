//! labelgen's labels measured against the renderer's truth, per material:
//! the first honest check of label quality (the paper reports 98.7 % correct
//! at 35 % of KITTI's ground-truth pixels labelled).
//!
//! A pixel is truly positive when the MVS's depth there is within the
//! uncertainty bound (`k_sigma` sigma of the triplet's first-order depth
//! uncertainty) of the true depth, and truly negative otherwise (no depth,
//! or a wrong one). Labelled share: labelled pixels over the pixels with a
//! true surface (the renderer's "ground truth pixels").
//!
//! Per material and per angle bin too (issue 34, item 3): a pixel's bin is
//! its true triangulation angle in its triplet (the renderer's, not
//! labelgen's estimate from SfM's poses), so the labelled share of a bin has
//! every surface pixel of that angle below it. Two more rows per material:
//! pixels all three views see at an angle beyond the last bin (a bin from
//! gamma_max to 180 deg), and pixels that not all three views see (no
//! angle; the truth has no uncertainty bound there, so only a negative
//! label can be correct).

use std::fmt::Write as _;

use serde::Serialize;
use vp_scene::raster::{AngleBins, Label, LabelImage};
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

/// Counts of one material in one angle bin.
#[derive(Debug, Clone, Default, PartialEq, Serialize)]
pub struct AngleCell {
    /// Material name.
    pub material: String,
    /// Bin of the true triangulation angle (the bin count: beyond the last
    /// bin); None: not seen by all three views of the triplet.
    pub angle_bin: Option<usize>,
    /// The bin's range, degrees (0, 0 without a bin).
    pub angle_deg: (f32, f32),
    /// The counts.
    pub counts: MaterialCounts,
}

/// Label quality per material (index: `Material as usize`).
#[derive(Debug, Clone, Default, PartialEq, Serialize)]
pub struct LabelQuality {
    /// Counts per material, in `Material::ALL` order.
    pub materials: Vec<(String, MaterialCounts)>,
    /// Counts per material and angle bin: material-major, the bins in
    /// order, then beyond the last bin, then the pixels without an angle.
    pub by_angle: Vec<AngleCell>,
}

impl LabelQuality {
    /// Adds one label image against its view's truth and the MVS depth the
    /// labels were made from (all at the label's resolution).
    ///
    /// `bins`: the forest's angle bins (the same for every call).
    pub fn add(
        &mut self,
        label: &LabelImage,
        truth: &[PixelTruth],
        depth: &[f32],
        k_sigma: f32,
        bins: &AngleBins,
    ) {
        if self.materials.is_empty() {
            self.materials = Material::ALL
                .iter()
                .map(|m| (m.name().to_string(), MaterialCounts::default()))
                .collect();
        }
        let nb = bins.len();
        let slots = nb + 2;
        if self.by_angle.len() != Material::ALL.len() * slots {
            self.by_angle = Material::ALL
                .iter()
                .flat_map(|m| {
                    (0..slots).map(|b| AngleCell {
                        material: m.name().to_string(),
                        angle_bin: (b <= nb).then_some(b),
                        angle_deg: match b.cmp(&nb) {
                            std::cmp::Ordering::Less => (bins.edges()[b], bins.edges()[b + 1]),
                            std::cmp::Ordering::Equal => (bins.gamma_max(), 180.0),
                            std::cmp::Ordering::Greater => (0.0, 0.0),
                        },
                        counts: MaterialCounts::default(),
                    })
                })
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
            let bin = if t.status == PixelStatus::NotVisible {
                None
            } else {
                Some(bins.bin_of(t.angle_deg).unwrap_or(nb))
            };
            let l = label.label((i % w) as u32, (i / w) as u32);
            let truly = truly_positive(t, z, k_sigma);
            let slot = m as usize * slots + bin.unwrap_or(slots - 1);
            self.materials[m as usize].1.count(l, truly);
            self.by_angle[slot].counts.count(l, truly);
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

    /// `label_quality.csv`: one line per material and angle bin with
    /// surface pixels (the bin past the last: beyond gamma_max; `angle_bin`
    /// "none": not seen by all three views); its counts add up to
    /// [`LabelQuality::total`].
    pub fn csv(&self) -> String {
        let mut s = String::from(
            "material,angle_bin,angle_lo,angle_hi,surface_pixels,labelled,labelled_share,correct,\
             correct_share,positive,positives_correct\n",
        );
        for a in self.by_angle.iter().filter(|a| a.counts.surface > 0) {
            let c = &a.counts;
            let (bin, lo, hi) = match a.angle_bin {
                Some(b) => (
                    b.to_string(),
                    a.angle_deg.0.to_string(),
                    a.angle_deg.1.to_string(),
                ),
                None => ("none".into(), String::new(), String::new()),
            };
            let _ = writeln!(
                s,
                "{},{bin},{lo},{hi},{},{},{:.4},{},{:.4},{},{}",
                a.material,
                c.surface,
                c.labelled,
                c.labelled as f64 / c.surface as f64,
                c.correct,
                c.correct as f64 / c.labelled.max(1) as f64,
                c.positive,
                c.correct_positive,
            );
        }
        s
    }

    /// The per-angle table: a row per material with surface pixels, a
    /// column per angle bin (and one for pixels without a bin); each cell
    /// "correct % / labelled % of surface", "-" without surface pixels.
    pub fn angle_cells(&self) -> (Vec<String>, Vec<Vec<String>>) {
        let slots = self.by_angle.len() / self.materials.len().max(1);
        let mut header = vec!["material".to_string()];
        header.extend(self.by_angle.iter().take(slots).map(|a| match a.angle_bin {
            Some(_) => format!("{}-{} deg", a.angle_deg.0, a.angle_deg.1),
            None => "no angle".into(),
        }));
        let rows = self
            .materials
            .iter()
            .zip(self.by_angle.chunks(slots.max(1)))
            .filter(|((_, c), _)| c.surface > 0)
            .map(|((name, _), cells)| {
                let mut row = vec![name.clone()];
                row.extend(cells.iter().map(|a| {
                    let c = &a.counts;
                    if c.surface == 0 {
                        "-".into()
                    } else {
                        format!("{:.1} / {:.1}", c.correct_pct(), c.labelled_pct())
                    }
                }));
                row
            })
            .collect();
        (header, rows)
    }

    /// [`LabelQuality::angle_cells`] as a Markdown table.
    pub fn angle_markdown(&self) -> String {
        let (header, rows) = self.angle_cells();
        let mut t = format!(
            "| {} |\n|{}\n",
            header.join(" | "),
            "---|".repeat(header.len())
        );
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
    /// Counts one surface pixel labelled `l` whose truth is `truly`.
    fn count(&mut self, l: Label, truly: bool) {
        self.surface += 1;
        if l == Label::Unlabelled {
            return;
        }
        self.labelled += 1;
        self.correct += u64::from((l == Label::Positive) == truly);
        if l == Label::Positive {
            self.positive += 1;
            self.correct_positive += u64::from(truly);
        }
    }

    /// Share of labelled pixels whose label is correct, percent.
    pub fn correct_pct(&self) -> f64 {
        100.0 * self.correct as f64 / self.labelled.max(1) as f64
    }

    /// Share of surface pixels labelled, percent.
    pub fn labelled_pct(&self) -> f64 {
        100.0 * self.labelled as f64 / self.surface.max(1) as f64
    }
}

#[cfg(test)]
#[path = "label_quality_tests.rs"]
mod tests;
