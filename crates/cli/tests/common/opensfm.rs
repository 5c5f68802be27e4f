//! Writing a COLMAP model as OpenSfM (and OpenDroneMap) would, so that a
//! test can run a command on both and compare.

use std::fmt::Write as _;
use std::path::Path;

use serde_json::json;
use vp_scene::colmap;
use vp_scene::plan::GeodeticOrigin;

/// The fixture's COLMAP model written as OpenSfM would write it, in an
/// OpenDroneMap project layout (`odm/opensfm/reconstruction.json` and
/// `tracks.csv`): `perspective` camera with focal / larger side, principal
/// point at the centre; shots with the world-to-camera rotation as an
/// axis-angle vector and the translation; points by track id; each
/// observation in normalised coordinates (pixel minus half the size, over
/// the larger side); the model's origin as `reference_lla`.
pub fn as_opensfm(model: &Path, project: &Path) {
    let rec = colmap::read_model(model).unwrap();
    let cam = &rec.cameras[&1];
    assert_eq!(cam.model, colmap::CameraModel::Pinhole);
    let size = cam.width.max(cam.height) as f64;
    // OpenSfM's `perspective`: one focal, principal point at the centre.
    let centre = [cam.width as f64 / 2.0, cam.height as f64 / 2.0];
    assert!((cam.params[0] - cam.params[1]).abs() < 1e-12);
    assert!((cam.params[2] - centre[0]).abs() + (cam.params[3] - centre[1]).abs() < 1e-12);
    let mut shots = serde_json::Map::new();
    for im in rec.images.values() {
        let r = im.cam_from_world.rotation.scaled_axis();
        let t = im.cam_from_world.translation.vector;
        shots.insert(
            im.name.clone(),
            json!({"camera": "cam", "rotation": [r.x, r.y, r.z], "translation": [t.x, t.y, t.z]}),
        );
    }
    let mut points = serde_json::Map::new();
    let mut tracks = String::from("OPENSFM_TRACKS_VERSION_v2\n");
    for p in rec.points.values() {
        points.insert(
            p.id.to_string(),
            json!({"coordinates": [p.xyz.x, p.xyz.y, p.xyz.z], "color": p.rgb}),
        );
        for &(image, idx) in &p.track {
            let im = &rec.images[&image];
            let xy = im.points2d[idx as usize].xy;
            let x = (xy.x - cam.width as f64 / 2.0) / size;
            let y = (xy.y - cam.height as f64 / 2.0) / size;
            writeln!(
                tracks,
                "{}\t{}\t{idx}\t{x}\t{y}\t0.001\t0\t0\t0\t-1\t-1",
                im.name, p.id
            )
            .unwrap();
        }
    }
    let o = GeodeticOrigin::default();
    let doc = json!([{
        "cameras": {"cam": {"projection_type": "perspective", "width": cam.width,
                            "height": cam.height, "focal": cam.params[0] / size,
                            "k1": 0.0, "k2": 0.0}},
        "shots": shots,
        "points": points,
        "reference_lla": {"latitude": o.lat_deg, "longitude": o.lon_deg, "altitude": o.alt_m},
    }]);
    std::fs::create_dir_all(project.join("opensfm")).unwrap();
    std::fs::write(project.join("opensfm/reconstruction.json"), doc.to_string()).unwrap();
    std::fs::write(project.join("opensfm/tracks.csv"), tracks).unwrap();
}
