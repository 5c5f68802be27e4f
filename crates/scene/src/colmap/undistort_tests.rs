//! Tests of [`super`]: undistortion against COLMAP's own numbers.

use super::*;

#[test]
fn pinhole_cameras_keep_size_and_intrinsics() {
    let cam = ColmapCamera {
        id: 1,
        model: CameraModel::SimplePinhole,
        width: 100,
        height: 80,
        params: vec![90.0, 50.0, 40.0],
    };
    let u = undistort_camera(&cam, &UndistortOptions::default()).unwrap();
    assert_eq!(u, cam);
}

#[test]
fn barrel_distortion_grows_the_pinhole_image() {
    // COLMAP on the visp-cube photos: SIMPLE_RADIAL 384x288, f 592.37,
    // k -0.0993, centred -> PINHOLE 387x288, cx 193.5.
    let cam = ColmapCamera {
        id: 1,
        model: CameraModel::SimpleRadial,
        width: 384,
        height: 288,
        params: vec![592.370_586_149_150_4, 192.0, 144.0, -0.0993],
    };
    let u = undistort_camera(&cam, &UndistortOptions::default()).unwrap();
    assert_eq!((u.width, u.height), (387, 288));
    assert!((u.params[2] - 193.5).abs() < 1e-12);
}

#[test]
fn max_image_size_scales_the_pinhole_camera_as_colmap_does() {
    // COLMAP 3.8 mapper on the Brighton Beach photos (../shared/data,
    // DJI FC300S, features at 800 px): OPENCV 4000x2250; its
    // `image_undistorter --max_image_size 2000` wrote
    // PINHOLE 2000 1122 1535.8042963753383 1530.6787133185803 1000 561.
    let cam = ColmapCamera {
        id: 1,
        model: CameraModel::OpenCv,
        width: 4000,
        height: 2250,
        params: vec![
            2_984.067_747_857_282,
            2_975.410_226_156_705_4,
            2000.0,
            1125.0,
            0.018_747_280_137_605_82,
            0.045_167_011_622_628_51,
            -0.002_042_228_928_231_938,
            0.001_503_420_011_284_270_5,
        ],
    };
    let opts = UndistortOptions {
        max_image_size: Some(2000),
        ..UndistortOptions::default()
    };
    let u = undistort_camera(&cam, &opts).unwrap();
    assert_eq!(
        (u.model, u.width, u.height),
        (CameraModel::Pinhole, 2000, 1122)
    );
    let colmap = [
        1_535.804_296_375_338_3,
        1_530.678_713_318_580_3,
        1000.0,
        561.0,
    ];
    for (a, b) in u.params.iter().zip(colmap) {
        assert!((a - b).abs() < 1e-6 * b, "{:?} vs {colmap:?}", u.params);
    }
    // Without the limit the size is COLMAP's too, and a pinhole camera
    // within the limit is unchanged.
    let full = undistort_camera(&cam, &UndistortOptions::default()).unwrap();
    assert!(full.width > 3800 && full.height > 2100, "{full:?}");
    let small = undistort_camera(&u, &opts).unwrap();
    assert_eq!(small, u);
}
