//! Tests of the raster types: bins, label and confidence images, their files.
// Exact float comparisons are intended here: the values are exactly representable.
#![allow(clippy::float_cmp)]

use super::*;
use crate::binfile::fnv1a64;

fn labels_fixture() -> LabelImage {
    let mut l = LabelImage::new(5, 4);
    l.set(0, 0, Label::Positive, 3.5).unwrap();
    l.set(4, 1, Label::Negative, 44.0).unwrap();
    l.set(2, 3, Label::Positive, 0.0).unwrap();
    l
}

fn conf_fixture() -> ConfidenceImage {
    let mut c = ConfidenceImage::zeros(20, 12, 8, AngleBins::uniform(3, 30.0).unwrap()).unwrap();
    for (k, v) in c.values_mut().iter_mut().enumerate() {
        *v = k as f32 * 0.01;
    }
    c
}

#[test]
fn angle_bins_place_angles_and_reject_bad_edges() {
    let b = AngleBins::paper();
    assert_eq!(b.len(), 9);
    assert_eq!(b.bin_of(0.0), Some(0));
    assert_eq!(b.bin_of(4.999), Some(0));
    assert_eq!(b.bin_of(5.0), Some(1));
    assert_eq!(b.bin_of(44.9), Some(8));
    assert_eq!(b.bin_of(45.0), None);
    assert_eq!(b.bin_of(-1.0), None);
    assert_eq!(b.bin_of(f32::NAN), None);
    assert!(AngleBins::new(vec![0.0, 5.0, 5.0]).is_err());
    assert!(AngleBins::new(vec![1.0]).is_err());
    assert!(AngleBins::new(vec![-1.0, 2.0]).is_err());
    let json = serde_json::to_string(&b).unwrap();
    assert_eq!(serde_json::from_str::<AngleBins>(&json).unwrap(), b);
    assert!(serde_json::from_str::<AngleBins>("[3.0, 1.0]").is_err());
}

#[test]
fn angle_interpolation_is_linear_between_centres_and_clamped_outside() {
    let b = AngleBins::paper();
    let v: Vec<f32> = (0..9).map(|i| i as f32).collect();
    assert_eq!(b.interpolate(&v, 0.0), 0.0);
    assert_eq!(b.interpolate(&v, 2.5), 0.0);
    assert!((b.interpolate(&v, 5.0) - 0.5).abs() < 1e-6);
    assert!((b.interpolate(&v, 10.0) - 1.5).abs() < 1e-6);
    assert_eq!(b.interpolate(&v, 42.5), 8.0);
    assert_eq!(b.interpolate(&v, 44.0), 8.0);
    assert_eq!(b.interpolate(&v, 90.0), 8.0);
    assert!(b.interpolate(&v, f64::NAN).is_nan());
}

#[test]
fn label_image_round_trips_through_its_file() {
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("a.vplabel");
    let l = labels_fixture();
    l.save(&path).unwrap();
    let back = LabelImage::load(&path).unwrap();
    assert_eq!(back.count(Label::Positive), 2);
    assert_eq!(back.count(Label::Negative), 1);
    assert_eq!(back.label(4, 1), Label::Negative);
    assert_eq!(back.angle(4, 1), 44.0);
    assert!(back.angle(1, 1).is_nan());
    let got: Vec<_> = back.labelled().collect();
    let want: Vec<_> = l.labelled().collect();
    assert_eq!(got, want);
    assert_eq!(back.to_bytes(), l.to_bytes());
}

#[test]
fn label_image_rejects_bad_angles() {
    let mut l = LabelImage::new(2, 2);
    assert!(l.set(0, 0, Label::Positive, f32::NAN).is_err());
    assert!(l.set(0, 0, Label::Negative, -1.0).is_err());
    assert!(l.set(0, 0, Label::Unlabelled, f32::NAN).is_ok());
}

/// Every damaged file must give an error naming the file, never a panic.
fn assert_rejected<T: std::fmt::Debug>(r: Result<T>, needle: &str) {
    let msg = r.unwrap_err().to_string();
    assert!(msg.contains("x.bin"), "{msg}");
    assert!(msg.contains(needle), "{msg} should mention {needle}");
}

#[test]
fn damaged_label_files_are_rejected_with_a_clear_error() {
    let p = Path::new("x.bin");
    let good = labels_fixture().to_bytes();
    assert_rejected(LabelImage::from_bytes(&[], p), "bad magic");
    assert_rejected(
        LabelImage::from_bytes(&good[..good.len() - 3], p),
        "checksum",
    );
    assert_rejected(LabelImage::from_bytes(&good[..15], p), "truncated");
    let mut flipped = good.clone();
    flipped[25] ^= 0x10;
    assert_rejected(LabelImage::from_bytes(&flipped, p), "checksum");
    let mut version = good.clone();
    version[8] = 9;
    assert_rejected(LabelImage::from_bytes(&version, p), "version 9");
    assert_rejected(
        LabelImage::from_bytes(&conf_fixture().to_bytes(), p),
        "bad magic",
    );
    // A bad label byte with a consistent checksum: reported at its offset.
    let mut bad = good[..good.len() - 8].to_vec();
    bad[20 + 1] = 7;
    let sum = fnv1a64(&bad);
    bad.extend_from_slice(&sum.to_le_bytes());
    assert_rejected(LabelImage::from_bytes(&bad, p), "byte 21");
}

#[test]
fn confidence_image_round_trips_and_rejects_damage() {
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("c.vpconf");
    let c = conf_fixture();
    assert_eq!(c.grid_size(), (3, 2));
    c.save(&path).unwrap();
    assert_eq!(ConfidenceImage::load(&path).unwrap(), c);
    let p = Path::new("x.bin");
    let good = c.to_bytes();
    assert_rejected(
        ConfidenceImage::from_bytes(&good[..good.len() - 1], p),
        "checksum",
    );
    assert_rejected(ConfidenceImage::from_bytes(b"hello world", p), "bad magic");
    let mut flipped = good.clone();
    flipped[40] ^= 1;
    assert_rejected(ConfidenceImage::from_bytes(&flipped, p), "checksum");
    assert!(ConfidenceImage::load(&dir.path().join("missing.vpconf")).is_err());
}

#[test]
fn confidence_sampling_is_bilinear_in_pixels_and_linear_in_angle() {
    let bins = AngleBins::uniform(2, 20.0).unwrap(); // centres 5 and 15
    let mut c = ConfidenceImage::zeros(16, 16, 8, bins).unwrap();
    // Nodes at continuous positions 4.5 and 12.5; bin 0 holds x-ramp, bin 1 = 2 * bin 0.
    for j in 0..2 {
        for i in 0..2 {
            let k = (j * 2 + i) * 2;
            c.values_mut()[k] = i as f32;
            c.values_mut()[k + 1] = 2.0 * i as f32;
        }
    }
    assert_eq!(c.sample((4.5, 4.5), 5.0), 0.0);
    assert_eq!(c.sample((12.5, 4.5), 5.0), 1.0);
    assert!((c.sample((8.5, 9.0), 5.0) - 0.5).abs() < 1e-6);
    assert!((c.sample((8.5, 9.0), 10.0) - 0.75).abs() < 1e-6);
    assert!((c.sample((8.5, 9.0), 15.0) - 1.0).abs() < 1e-6);
    assert!((c.sample((8.5, 9.0), 60.0) - 1.0).abs() < 1e-6);
    assert!((c.sample((8.5, 9.0), 0.0) - 0.5).abs() < 1e-6);
    // Clamped outside the node grid.
    assert_eq!(c.sample((0.0, 0.0), 5.0), 0.0);
    assert_eq!(c.sample((100.0, -3.0), 15.0), 2.0);
    assert!(c.sample((f64::NAN, 1.0), 5.0).is_nan());
}

#[test]
fn constant_confidence_reads_the_same_everywhere() {
    let c = ConfidenceImage::constant(1.0);
    for (px, a) in [
        ((0.0, 0.0), 0.0),
        ((4000.0, 3000.0), 44.0),
        ((-5.0, 7.0), 90.0),
    ] {
        assert_eq!(c.sample(px, a), 1.0);
    }
}

#[test]
fn previews_are_written_as_png() {
    let dir = tempfile::tempdir().unwrap();
    let p = dir.path().join("l.png");
    labels_fixture().save_preview_png(&p).unwrap();
    let img = load_rgb(&p).unwrap();
    assert_eq!(img.dimensions(), (5, 4));
    assert_eq!(img.get_pixel(0, 0).0, [255, 255, 255]);
    let q = dir.path().join("c.png");
    conf_fixture().save_bin_png(1, &q).unwrap();
    assert_eq!(load_rgb(&q).unwrap().dimensions(), (3, 2));
    assert!(conf_fixture().save_bin_png(3, &q).is_err());
}

#[test]
fn rgb_images_round_trip_and_bad_files_name_the_file() {
    let dir = tempfile::tempdir().unwrap();
    let p = dir.path().join("i.png");
    let img = RgbImage::from_fn(7, 3, |x, y| image::Rgb([x as u8 * 10, y as u8 * 20, 5]));
    save_rgb(&img, &p).unwrap();
    assert_eq!(load_rgb(&p).unwrap(), img);
    let bad = dir.path().join("bad.png");
    std::fs::write(&bad, b"not a png").unwrap();
    assert!(load_rgb(&bad).unwrap_err().to_string().contains("bad.png"));
    assert!(save_rgb(&img, &dir.path().join("i.unknownext")).is_err());
}
