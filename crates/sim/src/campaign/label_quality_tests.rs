//! Tests of the label quality counts (`label_quality.rs`).

use vp_scene::raster::{AngleBins, Label, LabelImage};
use vp_scene::Material;

use super::*;
use crate::virtual_mvs::{PixelStatus, PixelTruth};

fn truth(material: Option<Material>, status: PixelStatus, depth: f32, angle: f32) -> PixelTruth {
    PixelTruth {
        status,
        material,
        true_depth: 10.0,
        depth,
        angle_deg: angle,
        probability: 0.5,
        sigma_depth: 0.1,
    }
}

/// A 5-pixel image: a ground pixel at 12 deg reconstructed right but
/// labelled negative (a mislabel), a rock pixel at 33 deg labelled positive
/// with a wrong depth (a mislabelled positive), a grass pixel only two
/// views see (no angle) left unlabelled, sky, and a rock pixel at 50 deg
/// labelled positive and right.
fn tiny() -> LabelQuality {
    let mut label = LabelImage::new(5, 1);
    label.set(4, 0, Label::Positive, 50.0).unwrap();
    label.set(0, 0, Label::Negative, 12.0).unwrap();
    label.set(1, 0, Label::Positive, 33.0).unwrap();
    let truth = [
        truth(
            Some(Material::Ground),
            PixelStatus::Reconstructed,
            10.0,
            12.0,
        ),
        truth(Some(Material::Rock), PixelStatus::Outlier, 11.0, 33.0),
        truth(Some(Material::Grass), PixelStatus::NotVisible, 0.0, 0.0),
        truth(None, PixelStatus::NoSurface, 0.0, 0.0),
        truth(Some(Material::Rock), PixelStatus::Reconstructed, 10.0, 50.0),
    ];
    let depth = [10.0, 11.0, 0.0, 0.0, 10.0];
    let mut q = LabelQuality::default();
    q.add(&label, &truth, &depth, 3.0, &AngleBins::paper());
    q
}

fn cell<'a>(q: &'a LabelQuality, material: &str, bin: Option<usize>) -> &'a MaterialCounts {
    &q.by_angle
        .iter()
        .find(|a| a.material == material && a.angle_bin == bin)
        .unwrap()
        .counts
}

/// Each mislabelled pixel lands in its material's row at its true angle's
/// bin, and the pixel without an angle in its own row.
#[test]
fn a_mislabelled_pixel_lands_in_its_material_and_angle_bin() {
    let q = tiny();
    let ground = cell(&q, "ground", Some(2));
    assert_eq!((ground.surface, ground.labelled, ground.correct), (1, 1, 0));
    let rock = cell(&q, "rock", Some(6));
    assert_eq!(
        (
            rock.labelled,
            rock.positive,
            rock.correct_positive,
            rock.correct
        ),
        (1, 1, 0, 0)
    );
    let grass = cell(&q, "grass", None);
    assert_eq!((grass.surface, grass.labelled), (1, 0));
    let wide = cell(&q, "rock", Some(9));
    assert_eq!(
        (wide.labelled, wide.correct),
        (1, 1),
        "beyond 45 deg: its own bin"
    );
    let counted: u64 = q.by_angle.iter().map(|a| a.counts.surface).sum();
    assert_eq!(counted, 4, "sky is no surface");

    let csv = q.csv();
    assert!(
        csv.contains("\nground,2,10,15,1,1,1.0000,0,0.0000,0,0\n"),
        "{csv}"
    );
    assert!(
        csv.contains("\ngrass,none,,,1,0,0.0000,0,0.0000,0,0\n"),
        "{csv}"
    );
    let (header, rows) = q.angle_cells();
    assert_eq!(
        header.len(),
        12,
        "material, 9 bins, beyond, no angle: {header:?}"
    );
    assert_eq!(header[10], "45-180 deg");
    assert_eq!(rows.len(), 3, "{rows:?}");
    assert_eq!(rows[0][3], "0.0 / 100.0", "{rows:?}");
}

/// The per-angle counts add up to the per-material table, material by
/// material, over many labelled images.
#[test]
fn per_angle_counts_add_up_to_the_aggregate_table() {
    let mut q = tiny();
    let bins = AngleBins::paper();
    for k in 0..50u32 {
        let mut label = LabelImage::new(5, 1);
        let mut truths = Vec::new();
        let mut depth = Vec::new();
        for x in 0..5u32 {
            let angle = ((k * 7 + x * 11) % 50) as f32;
            let m = Material::ALL[((k + x) as usize) % Material::ALL.len()];
            let l = [Label::Positive, Label::Negative, Label::Unlabelled][((k + x) % 3) as usize];
            label.set(x, 0, l, angle).unwrap();
            let status = if (k + x) % 4 == 0 {
                PixelStatus::NotVisible
            } else {
                PixelStatus::Reconstructed
            };
            truths.push(truth(Some(m), status, 10.0, angle));
            depth.push(if x % 2 == 0 { 10.0 } else { 12.0 });
        }
        q.add(&label, &truths, &depth, 3.0, &bins);
    }
    for (name, total) in &q.materials {
        let mut sum = MaterialCounts::default();
        for a in q.by_angle.iter().filter(|a| &a.material == name) {
            let c = &a.counts;
            sum.surface += c.surface;
            sum.labelled += c.labelled;
            sum.correct += c.correct;
            sum.positive += c.positive;
            sum.correct_positive += c.correct_positive;
        }
        assert_eq!(&sum, total, "{name}");
    }
    let csv_surface: u64 = q
        .csv()
        .lines()
        .skip(1)
        .map(|l| l.split(',').nth(4).unwrap().parse::<u64>().unwrap())
        .sum();
    assert_eq!(csv_surface, q.total().surface);
}
