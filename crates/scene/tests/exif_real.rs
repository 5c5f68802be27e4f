//! Image positions from EXIF GPS tags written by ExifTool (tests/data/exif,
//! see its README): JPEG and TIFF, all four hemispheres, below sea level,
//! and a photo with EXIF but no GPS.

use std::path::{Path, PathBuf};

use vp_scene::colmap::read_positions_exif;

fn exif_data() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("tests/data/exif")
}

#[test]
fn exif_gps_written_by_exiftool_reads_as_exiftool_reads_it() {
    let found = read_positions_exif(&exif_data()).unwrap();
    let names: Vec<&str> = found.positions.iter().map(|(n, _)| n.as_str()).collect();
    assert_eq!(
        names,
        [
            "gps_north_east.jpg",
            "gps_north_east.tif",
            "gps_south_west_below.jpg"
        ]
    );
    // ExifTool's own read-back (README): 47.0712345000306, 15.4412345000306.
    let expected = [
        [47.071_234_500_030_6, 15.441_234_500_030_6, 351.25],
        [47.071_234_500_030_6, 15.441_234_500_030_6, 351.25],
        [-33.8688, -70.5, -12.5],
    ];
    for ((name, g), e) in found.positions.iter().zip(expected) {
        assert!(
            (g.lat_deg - e[0]).abs() < 1e-9
                && (g.lon_deg - e[1]).abs() < 1e-9
                && (g.alt_m - e[2]).abs() < 1e-9,
            "{name}: {g:?}, ExifTool reads {e:?}"
        );
    }
    assert_eq!(
        found.skipped,
        [(
            "no_gps.jpg".to_string(),
            "no GPS position in its EXIF".to_string()
        )]
    );
}

#[test]
fn exif_positions_of_a_missing_folder_name_the_folder() {
    let e = read_positions_exif(&exif_data().join("absent")).unwrap_err();
    assert!(
        e.to_string().contains("absent") && e.is_input_error(),
        "{e}"
    );
}
