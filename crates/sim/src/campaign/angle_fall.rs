//! How a matcher's measured success changes with the triangulation angle,
//! site by site: the measurement behind the stop rule G1 of the two-matcher
//! experiment (docs/campaign-findings.md). The paper's SURE succeeds less
//! often at wide angles; a PMVS-like matcher does not. Whether vp-mvs's SGM
//! falls with the angle is measured here before any campaign relies on it.
//!
//! Measured success is what the confidence curves call measured
//! ([`super::curves`]): of the pixels all three views of a training triplet
//! see, the share whose depth lies within the uncertainty bound of the true
//! depth. Training triplets are spread evenly over the angle bins, so every
//! bin has its own triplets. The fall is the per-site difference between a
//! wide and a narrow range of angles, pooled over the chosen materials, its
//! mean over sites and a percentile bootstrap interval over sites (sites
//! are the independent unit: one site's triplets share its texture).

use std::fmt::Write as _;

use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;
use vp_scene::raster::AngleBins;
use vp_scene::Material;

/// Bootstrap resamples of the interval.
const RESAMPLES: usize = 10_000;

/// One site's measured success of one material in one angle bin.
#[derive(Debug, Clone, PartialEq)]
pub struct SiteSuccess {
    /// The site's seed.
    pub site: u64,
    /// Material under the pixels.
    pub material: Material,
    /// Angle bin (index into the forest's bins).
    pub bin: usize,
    /// Pixels all three views see.
    pub visible: u64,
    /// Of those, reconstructed within the bound.
    pub reconstructed: u64,
}

/// The fall of measured success from a narrow to a wide range of angles.
#[derive(Debug, Clone, PartialEq)]
pub struct AngleFall {
    /// Materials pooled.
    pub materials: Vec<Material>,
    /// The narrow range, degrees (bins lying inside it).
    pub narrow: (f32, f32),
    /// The wide range, degrees.
    pub wide: (f32, f32),
    /// Per site with pixels in both ranges: (site, narrow success, wide success).
    pub per_site: Vec<(u64, f64, f64)>,
    /// Mean over those sites of wide minus narrow success.
    pub mean_difference: f64,
    /// 95 % percentile bootstrap interval of that mean over sites.
    pub interval: (f64, f64),
}

/// The fall of success from `narrow` to `wide` (degrees; a bin counts when
/// both its edges lie in the range) over `materials`, per site of `rows`;
/// `None` when no site has pixels in both ranges. The bootstrap draws from
/// `seed`.
pub fn angle_fall(
    rows: &[SiteSuccess],
    bins: &AngleBins,
    materials: &[Material],
    narrow: (f32, f32),
    wide: (f32, f32),
    seed: u64,
) -> Option<AngleFall> {
    let edges = bins.edges();
    let inside = |b: usize, r: (f32, f32)| edges[b] >= r.0 && edges[b + 1] <= r.1;
    let mut sites: Vec<u64> = rows.iter().map(|r| r.site).collect();
    sites.sort_unstable();
    sites.dedup();
    let success = |site: u64, range: (f32, f32)| {
        let (ok, n) = rows
            .iter()
            .filter(|r| r.site == site && materials.contains(&r.material) && inside(r.bin, range))
            .fold((0u64, 0u64), |(ok, n), r| {
                (ok + r.reconstructed, n + r.visible)
            });
        (n > 0).then(|| ok as f64 / n as f64)
    };
    let per_site: Vec<(u64, f64, f64)> = sites
        .iter()
        .filter_map(|&s| Some((s, success(s, narrow)?, success(s, wide)?)))
        .collect();
    if per_site.is_empty() {
        return None;
    }
    let diffs: Vec<f64> = per_site.iter().map(|&(_, n, w)| w - n).collect();
    let (mean_difference, interval) = bootstrap_mean(&diffs, seed);
    Some(AngleFall {
        materials: materials.to_vec(),
        narrow,
        wide,
        mean_difference,
        interval,
        per_site,
    })
}

/// The mean of `values` (one per site, the independent unit) and its 95 %
/// percentile bootstrap interval: `RESAMPLES` draws with replacement from
/// `seed`. `values` must not be empty.
pub fn bootstrap_mean(values: &[f64], seed: u64) -> (f64, (f64, f64)) {
    let mean = |v: &[f64]| v.iter().sum::<f64>() / v.len() as f64;
    let mut rng = ChaCha8Rng::seed_from_u64(seed);
    let mut means: Vec<f64> = (0..RESAMPLES)
        .map(|_| {
            let draw: Vec<f64> = (0..values.len())
                .map(|_| values[rng.random_range(0..values.len())])
                .collect();
            mean(&draw)
        })
        .collect();
    means.sort_by(f64::total_cmp);
    let at = |q: f64| means[((q * (RESAMPLES - 1) as f64).round() as usize).min(RESAMPLES - 1)];
    (mean(values), (at(0.025), at(0.975)))
}

impl AngleFall {
    /// One paragraph for the summary.
    pub fn summary(&self) -> String {
        let names: Vec<&str> = self.materials.iter().map(|m| m.name()).collect();
        let avg = |f: fn(&(u64, f64, f64)) -> f64| {
            self.per_site.iter().map(f).sum::<f64>() / self.per_site.len() as f64
        };
        let mut s = format!(
            "measured success on {} (depth within the bound of the truth, pixels all three views see), \
             mean over {} sites: {:.0}-{:.0} deg {:.1} %, {:.0}-{:.0} deg {:.1} %; wide - narrow {:+.3} \
             (95 % bootstrap interval over sites {:+.3} .. {:+.3})\n  per site (narrow, wide):",
            names.join(" and "),
            self.per_site.len(),
            self.narrow.0,
            self.narrow.1,
            100.0 * avg(|r| r.1),
            self.wide.0,
            self.wide.1,
            100.0 * avg(|r| r.2),
            self.mean_difference,
            self.interval.0,
            self.interval.1,
        );
        for (site, n, w) in &self.per_site {
            let _ = write!(s, " {site}: {:.1}/{:.1} %", 100.0 * n, 100.0 * w);
        }
        s.push('\n');
        s
    }
}

/// `angle_success.csv`: one line per (site, material, angle bin).
pub fn csv(matcher: &str, rows: &[SiteSuccess], bins: &AngleBins) -> String {
    let e = bins.edges();
    let mut s = String::from(
        "matcher,site,material,angle_bin,angle_lo,angle_hi,visible,reconstructed,success\n",
    );
    for r in rows {
        let _ = writeln!(
            s,
            "{matcher},{},{},{},{},{},{},{},{:.4}",
            r.site,
            r.material.name(),
            r.bin,
            e[r.bin],
            e[r.bin + 1],
            r.visible,
            r.reconstructed,
            r.reconstructed as f64 / r.visible.max(1) as f64
        );
    }
    s
}

#[cfg(test)]
mod tests {
    use super::*;

    fn row(site: u64, material: Material, bin: usize, visible: u64, ok: u64) -> SiteSuccess {
        SiteSuccess {
            site,
            material,
            bin,
            visible,
            reconstructed: ok,
        }
    }

    #[test]
    fn the_fall_pools_materials_per_site_and_its_interval_brackets_the_sites() {
        let bins = AngleBins::paper(); // 5-degree bins, 0-45
        let mut rows = Vec::new();
        for (site, wide_ok) in [(1, 50), (2, 60), (3, 70)] {
            // Narrow: bins 1, 2 (5-15 deg), 90 % on ground and on rock.
            for bin in [1, 2] {
                rows.push(row(site, Material::Ground, bin, 100, 90));
                rows.push(row(site, Material::Rock, bin, 100, 90));
            }
            // Wide: bins 7, 8 (35-45 deg).
            for bin in [7, 8] {
                rows.push(row(site, Material::Ground, bin, 100, wide_ok));
                rows.push(row(site, Material::Rock, bin, 100, wide_ok));
            }
            // Another material and a bin outside both ranges do not count.
            rows.push(row(site, Material::Tree, 8, 1000, 1000));
            rows.push(row(site, Material::Ground, 4, 1000, 0));
        }
        let f = angle_fall(
            &rows,
            &bins,
            &[Material::Ground, Material::Rock],
            (5.0, 15.0),
            (35.0, 45.0),
            7,
        )
        .unwrap();
        assert_eq!(f.per_site.len(), 3);
        assert!((f.per_site[0].1 - 0.9).abs() < 1e-12 && (f.per_site[0].2 - 0.5).abs() < 1e-12);
        assert!(
            (f.mean_difference + 0.3).abs() < 1e-12,
            "{}",
            f.mean_difference
        );
        // The bootstrap mean of three differences (-0.4, -0.3, -0.2) stays within them.
        assert!(
            f.interval.0 >= -0.4 - 1e-12 && f.interval.1 <= -0.2 + 1e-12,
            "{:?}",
            f.interval
        );
        assert!(f.interval.0 < f.interval.1);
        // A site without pixels in a range is left out; none at all is None.
        assert!(angle_fall(
            &rows,
            &bins,
            &[Material::Grass],
            (5.0, 15.0),
            (35.0, 45.0),
            7
        )
        .is_none());
    }
}
