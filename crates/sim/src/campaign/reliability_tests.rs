//! Tests of the reliability diagrams (`reliability.rs`).

use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;
use vp_scene::raster::AngleBins;

use super::*;

/// A predictor whose confidence is the true probability of success lies on
/// the diagonal: every bin's observed success within 0.02 of its mean
/// confidence (about 20,000 pixels per bin: 3 binomial standard deviations
/// are under 0.011).
#[test]
fn a_calibrated_predictor_lies_on_the_diagonal() {
    let bins = AngleBins::default();
    let mut r = Reliability::new("t", &bins);
    let mut rng = ChaCha8Rng::seed_from_u64(7);
    for i in 0..200_000 {
        let c: f32 = rng.random();
        let y = rng.random::<f32>() < c;
        r.add(i % bins.len(), c, y, y);
    }
    let pts = Reliability::points(&r.pooled());
    assert_eq!(pts.len(), CONF_BINS);
    for (p, o, t, n) in pts {
        assert!((p - o).abs() < 0.02, "mean {p:.3}, observed {o:.3}, {n} px");
        assert!((o - t).abs() < 1e-12, "labels and truth agree here");
    }
    assert!(r.ece() < 0.01, "{}", r.ece());
}

/// A constant predictor gives one point, at its confidence and the base
/// rate, and a large calibration error when the two differ; the CSV's
/// pixels add up to the pixels counted, in one group per angle range.
#[test]
fn a_constant_predictor_gives_one_point_at_the_base_rate() {
    let bins = AngleBins::default();
    let mut r = Reliability::new("t", &bins);
    let n = 9_000;
    for i in 0..n {
        // 60 % positive, truly positive on a third.
        r.add(i % bins.len(), 0.3, i % 5 < 3, i % 3 == 0);
    }
    let pts = Reliability::points(&r.pooled());
    assert_eq!(pts.len(), 1);
    let (p, o, t, count) = pts[0];
    assert!((p - 0.3).abs() < 1e-6 && (o - 0.6).abs() < 1e-9 && (t - 1.0 / 3.0).abs() < 1e-9);
    assert_eq!(count, n as u64);
    assert!((r.ece() - 0.3).abs() < 1e-6);

    let csv = csv("patchmatch", &[r.clone()]);
    let rows: Vec<Vec<&str>> = csv
        .lines()
        .skip(1)
        .map(|l| l.split(',').collect())
        .collect();
    assert_eq!(rows.len(), ANGLE_GROUPS, "{csv}");
    let total: u64 = rows.iter().map(|f| f[6].parse::<u64>().unwrap()).sum();
    assert_eq!(total, n as u64);
    let ranges: Vec<(&str, &str)> = rows.iter().map(|f| (f[2], f[3])).collect();
    assert_eq!(ranges, [("0", "15"), ("15", "30"), ("30", "45")]);
    assert!(rows.iter().all(|f| f[4] == "0.3" && f[5] == "0.4"), "{csv}");
}

/// Confidence 1.0 falls in the last bin, not past it; an angle bin the
/// forest does not have is not counted.
#[test]
fn confidence_one_is_in_the_last_bin_and_unknown_bins_are_skipped() {
    assert_eq!(conf_bin(1.0), CONF_BINS - 1);
    assert_eq!(conf_bin(0.0), 0);
    assert_eq!(conf_bin(0.1), 1);
    let mut r = Reliability::new("t", &AngleBins::default());
    r.add(99, 0.5, true, true);
    assert!(Reliability::points(&r.pooled()).is_empty());
}

/// The picture: the diagonal of a calibrated forest is drawn, and a
/// calibrated predictor's markers sit on it (black pixels near the centre).
#[test]
fn the_plot_draws_the_diagonal_and_the_points() {
    let bins = AngleBins::default();
    let mut r = Reliability::new("6x14", &bins);
    for i in 0..1000u32 {
        r.add(0, 0.55, i % 100 < 55, true);
    }
    let img = plot("patchmatch", &r);
    let (x0, y1, x1, y0) = AREA;
    let at = |p: f64| {
        let x = (x0 + (x1 - x0) * p) as u32;
        let y = (y0 + (y1 - y0) * p) as u32;
        *img.get_pixel(x, y)
    };
    assert_eq!(at(0.25), Rgb([200, 200, 200]), "the diagonal at 0.25");
    assert_eq!(at(0.55), BLACK, "the pooled point at (0.55, 0.55)");
}
