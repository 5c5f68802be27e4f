//! What the CLI test binaries share: running `vpctl` and the test data.
#![allow(dead_code)]

pub mod opensfm;

use std::path::{Path, PathBuf};
use std::process::{Command, Output};

use vp_scene::colmap::{self, CameraModel, ColmapCamera, ColmapImage, Reconstruction};
use vp_scene::io::{write_mesh, MeshFormat};
use vp_scene::procedural::{generate_site, Site, SiteParams};
use vp_test_support::rock::{initial_cameras, initial_intrinsics};

/// Runs the `vpctl` binary with `args`.
pub fn vpctl(args: &[&str]) -> Output {
    Command::new(env!("CARGO_BIN_EXE_vpctl"))
        .args(args)
        .output()
        .expect("vpctl runs")
}

/// Standard output as text.
pub fn stdout(o: &Output) -> String {
    String::from_utf8_lossy(&o.stdout).into_owned()
}

/// Standard error as text.
pub fn stderr(o: &Output) -> String {
    String::from_utf8_lossy(&o.stderr).into_owned()
}

/// Test data of vp-scene: real files written by MeshLab and COLMAP.
pub fn scene_data(rel: &str) -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("../scene/tests/data")
        .join(rel)
}

/// A site mesh, a COLMAP model of an initial grid flight over it, and a small config.
pub fn plan_fixture(dir: &Path) -> Site {
    plan_fixture_seeded(dir, 2)
}

/// [`plan_fixture`] on the procedural site of `seed`.
pub fn plan_fixture_seeded(dir: &Path, seed: u64) -> Site {
    let site = generate_site(&SiteParams {
        seed,
        target_faces: 20_000,
        ..SiteParams::default()
    })
    .unwrap();
    write_mesh(
        &dir.join("site.ply"),
        &site.mesh,
        MeshFormat::PlyBinaryLittleEndian,
    )
    .unwrap();
    let k = initial_intrinsics();
    let mut rec = Reconstruction::default();
    rec.cameras.insert(
        1,
        ColmapCamera {
            id: 1,
            model: CameraModel::Pinhole,
            width: u64::from(k.width),
            height: u64::from(k.height),
            params: vec![k.fx, k.fy, k.cx, k.cy],
        },
    );
    for (i, camera) in initial_cameras(&site).iter().enumerate() {
        let id = i as u32 + 1;
        rec.images.insert(
            id,
            ColmapImage {
                id,
                camera_id: 1,
                name: format!("img_{id:03}.jpg"),
                cam_from_world: camera.cam_from_world(),
                points2d: Vec::new(),
            },
        );
    }
    std::fs::create_dir_all(dir.join("model")).unwrap();
    colmap::write_text(&dir.join("model"), &rec).unwrap();
    // The model is already metric ENU: its frame is the identity.
    colmap::ModelFrame::identity(vp_scene::plan::GeodeticOrigin::default())
        .save(&dir.join("model"))
        .unwrap();
    let v = site.flight_volume;
    std::fs::write(
        dir.join("plan.toml"),
        format!(
            // The model's cameras are the true ones and the vehicle flies
            // exactly: no position margin (standard GNSS's 12.8 m leaves no
            // position in this small flight volume).
            "n_triangles = 300\nn_surrogates = 600\nn_selected = 60\nn_triplets = 2\nflight_volume = [[{}, {}, {}], [{}, {}, {}]]\nsafety = {{ gnss = {{ horizontal_m = 0.0, vertical_m = 0.0 }}, tracking_m = 0.0 }}\n",
            v.min.x, v.min.y, v.min.z, v.max.x, v.max.y, v.max.z
        ),
    )
    .unwrap();
    site
}

/// A real JPEG (`width` x `height`, a grey ramp, encoded by the `image`
/// crate) with an EXIF APP1 segment right after SOI holding `gps`
/// (latitude, longitude in degrees, altitude in metres; negative = S, W,
/// below sea level), or no EXIF at all for `None`.
///
/// The EXIF block is written here by hand from the EXIF 2.32 layout, so that
/// the reader is checked against bytes it did not write itself: a big-endian
/// TIFF header, IFD0 with only the GPS IFD pointer (tag 0x8825), and a GPS
/// IFD with GPSVersionID, the N/S, E/W references, degrees/minutes/seconds
/// as three RATIONALs (seconds to 1/10000"), GPSAltitudeRef and GPSAltitude
/// (to the millimetre). `altitude: false` leaves both altitude tags out.
pub fn jpeg_with_gps(width: u32, height: u32, gps: Option<[f64; 3]>, altitude: bool) -> Vec<u8> {
    jpeg_with_exif(width, height, gps, altitude, None, None)
}

/// [`jpeg_with_gps`] (with GPS) plus the camera's EXIF `Model` in IFD0 and
/// DJI's height above take-off in an XMP packet (APP1, Adobe's namespace
/// header, `drone-dji:RelativeAltitude="+39.80"` as DJI writes it).
pub fn jpeg_with_exif(
    width: u32,
    height: u32,
    gps: Option<[f64; 3]>,
    altitude: bool,
    model: Option<&str>,
    relative_alt_m: Option<f64>,
) -> Vec<u8> {
    let pixels: Vec<u8> = (0..width * height)
        .map(|i| ((i % width) * 255 / width.max(1)) as u8)
        .collect();
    let mut jpeg = Vec::new();
    image::codecs::jpeg::JpegEncoder::new_with_quality(&mut jpeg, 90)
        .encode(&pixels, width, height, image::ExtendedColorType::L8)
        .unwrap();
    assert_eq!(&jpeg[..2], &[0xFF, 0xD8], "SOI");
    let Some([lat, lon, alt]) = gps else {
        return jpeg;
    };
    let tiff = exif_gps_tiff(lat, lon, alt, altitude, model);
    let mut app1 = b"Exif\0\0".to_vec();
    app1.extend_from_slice(&tiff);
    let mut out = vec![0xFF, 0xD8];
    let mut segment = |body: &[u8]| {
        out.extend_from_slice(&[0xFF, 0xE1]);
        out.extend_from_slice(&u16::try_from(body.len() + 2).unwrap().to_be_bytes());
        out.extend_from_slice(body);
    };
    segment(&app1);
    if let Some(rel) = relative_alt_m {
        let mut xmp = b"http://ns.adobe.com/xap/1.0/\0".to_vec();
        xmp.extend_from_slice(
            format!(
                "<x:xmpmeta xmlns:x=\"adobe:ns:meta/\"><rdf:RDF \
                 xmlns:rdf=\"http://www.w3.org/1999/02/22-rdf-syntax-ns#\"><rdf:Description \
                 xmlns:drone-dji=\"http://www.dji.com/drone-dji/1.0/\" \
                 drone-dji:RelativeAltitude=\"{rel:+.2}\"/></rdf:RDF></x:xmpmeta>"
            )
            .as_bytes(),
        );
        segment(&xmp);
    }
    out.extend_from_slice(&jpeg[2..]);
    out
}

/// The TIFF structure of an EXIF block with a GPS IFD (see [`jpeg_with_gps`]).
fn exif_gps_tiff(lat: f64, lon: f64, alt: f64, altitude: bool, model: Option<&str>) -> Vec<u8> {
    // An entry's value: inline bytes, or rationals stored after the IFD.
    enum V {
        Inline([u8; 4]),
        Rationals(Vec<(u32, u32)>),
    }
    const BYTE: u16 = 1;
    const ASCII: u16 = 2;
    const LONG: u16 = 4;
    const RATIONAL: u16 = 5;
    let dms = |v: f64| -> [(u32, u32); 3] {
        let v = v.abs();
        let d = v.floor();
        let m = ((v - d) * 60.0).floor();
        let s = ((v - d) * 60.0 - m) * 60.0;
        [
            (d as u32, 1),
            (m as u32, 1),
            ((s * 10_000.0).round() as u32, 10_000),
        ]
    };
    let mut gps: Vec<(u16, u16, u32, V)> = vec![
        (0x0000, BYTE, 4, V::Inline([2, 3, 0, 0])),
        (
            0x0001,
            ASCII,
            2,
            V::Inline([if lat < 0.0 { b'S' } else { b'N' }, 0, 0, 0]),
        ),
        (0x0002, RATIONAL, 3, V::Rationals(dms(lat).to_vec())),
        (
            0x0003,
            ASCII,
            2,
            V::Inline([if lon < 0.0 { b'W' } else { b'E' }, 0, 0, 0]),
        ),
        (0x0004, RATIONAL, 3, V::Rationals(dms(lon).to_vec())),
    ];
    if altitude {
        gps.push((0x0005, BYTE, 1, V::Inline([u8::from(alt < 0.0), 0, 0, 0])));
        gps.push((
            0x0006,
            RATIONAL,
            1,
            V::Rationals(vec![((alt.abs() * 1000.0).round() as u32, 1000)]),
        ));
    }
    // IFD0: the Model (0x0110, ASCII, NUL-terminated, stored after the
    // GPS IFD's rationals) if given, then the GPS IFD pointer.
    // Longer than 3 characters: shorter values would be stored inline.
    let model = model.map(|m| [m.as_bytes(), &[0]].concat());
    assert!(
        model.as_ref().is_none_or(|m| m.len() > 4),
        "a model name of 4+ characters"
    );
    let ifd0_entries = 1 + u16::from(model.is_some());
    let ifd0_at = 8u32;
    let gps_at = ifd0_at + 2 + 12 * u32::from(ifd0_entries) + 4;
    let mut data_at = gps_at + 2 + 12 * gps.len() as u32 + 4;
    let rationals: u32 = gps
        .iter()
        .map(|e| match &e.3 {
            V::Rationals(r) => 8 * r.len() as u32,
            V::Inline(_) => 0,
        })
        .sum();
    let model_at = data_at + rationals;
    let mut t = Vec::new();
    t.extend_from_slice(b"MM");
    t.extend_from_slice(&42u16.to_be_bytes());
    t.extend_from_slice(&ifd0_at.to_be_bytes());
    t.extend_from_slice(&ifd0_entries.to_be_bytes());
    if let Some(m) = &model {
        t.extend_from_slice(&0x0110u16.to_be_bytes());
        t.extend_from_slice(&ASCII.to_be_bytes());
        t.extend_from_slice(&(m.len() as u32).to_be_bytes());
        t.extend_from_slice(&model_at.to_be_bytes());
    }
    t.extend_from_slice(&0x8825u16.to_be_bytes());
    t.extend_from_slice(&LONG.to_be_bytes());
    t.extend_from_slice(&1u32.to_be_bytes());
    t.extend_from_slice(&gps_at.to_be_bytes());
    t.extend_from_slice(&0u32.to_be_bytes());
    // GPS IFD, then the rationals it points to.
    t.extend_from_slice(&(gps.len() as u16).to_be_bytes());
    let mut tail = Vec::new();
    for (tag, ty, count, v) in &gps {
        t.extend_from_slice(&tag.to_be_bytes());
        t.extend_from_slice(&ty.to_be_bytes());
        t.extend_from_slice(&count.to_be_bytes());
        match v {
            V::Inline(b) => t.extend_from_slice(b),
            V::Rationals(r) => {
                t.extend_from_slice(&data_at.to_be_bytes());
                for (n, d) in r {
                    tail.extend_from_slice(&n.to_be_bytes());
                    tail.extend_from_slice(&d.to_be_bytes());
                }
                data_at += 8 * r.len() as u32;
            }
        }
    }
    t.extend_from_slice(&0u32.to_be_bytes());
    t.extend_from_slice(&tail);
    t.extend_from_slice(model.as_deref().unwrap_or_default());
    t
}

/// Runs the `vpctl` binary with `args` in the folder `cwd`.
pub fn vpctl_in(cwd: &Path, args: &[&str]) -> Output {
    Command::new(env!("CARGO_BIN_EXE_vpctl"))
        .current_dir(cwd)
        .args(args)
        .output()
        .expect("vpctl runs")
}

/// Every file under `dir` with its bytes, for before-and-after comparisons.
pub fn snapshot(dir: &Path) -> std::collections::BTreeMap<PathBuf, Vec<u8>> {
    fn walk(root: &Path, d: &Path, out: &mut std::collections::BTreeMap<PathBuf, Vec<u8>>) {
        for e in std::fs::read_dir(d).unwrap() {
            let p = e.unwrap().path();
            if p.is_dir() {
                walk(root, &p, out);
            } else {
                let bytes = std::fs::read(&p).unwrap();
                out.insert(p.strip_prefix(root).unwrap().to_path_buf(), bytes);
            }
        }
    }
    let mut out = std::collections::BTreeMap::new();
    walk(dir, dir, &mut out);
    out
}

/// Issue 39, item 4: a command that writes a folder never deletes or
/// changes what vpctl did not write. `args` run in `cwd` (without `--out`)
/// and read their inputs from `input_dir` (relative to `cwd`: an input
/// folder or a folder holding inputs). Checks, with a precious file beside
/// the outputs:
/// - `--out . --force`, `--out <input_dir> --force` and `--out <a folder of
///   someone else's files> --force` exit 2 naming the reason and the fix,
///   and change no file at all (once they deleted everything);
/// - `--out rep` writes vpctl's manifest; again without `--force` exits 2;
///   with `--force` it succeeds and the user's `rep/notes.txt` stays.
pub fn assert_output_guards(cwd: &Path, args: &[&str], input_dir: &str) {
    std::fs::write(cwd.join("precious.txt"), "the operator's notes").unwrap();
    std::fs::create_dir_all(cwd.join("foreign")).unwrap();
    std::fs::write(cwd.join("foreign/thesis.tex"), "years of work").unwrap();
    let before = snapshot(cwd);
    let with = |extra: &[&str]| -> Output {
        let mut all = args.to_vec();
        all.extend_from_slice(extra);
        vpctl_in(cwd, &all)
    };
    for (out, why) in [
        (".", "is the current folder"),
        (input_dir, "the input"),
        ("foreign", "is not a vpctl output"),
    ] {
        let o = with(&["--out", out, "--force"]);
        let err = stderr(&o);
        assert_eq!(o.status.code(), Some(2), "--out {out}: {err}");
        assert!(
            err.contains(why) && err.contains("nothing was written") && err.contains("--out "),
            "--out {out}: {err}"
        );
        assert!(
            snapshot(cwd) == before,
            "`{} --out {out} --force` changed files in {}",
            args.join(" "),
            cwd.display()
        );
    }
    let o = with(&["--out", "rep"]);
    assert!(o.status.success(), "{}", stderr(&o));
    assert!(cwd.join("rep/.vpctl-output.json").is_file());
    std::fs::write(cwd.join("rep/notes.txt"), "mine").unwrap();
    let o = with(&["--out", "rep"]);
    assert_eq!(o.status.code(), Some(2), "{}", stderr(&o));
    assert!(stderr(&o).contains("--force"), "{}", stderr(&o));
    let o = with(&["--out", "rep", "--force"]);
    assert!(o.status.success(), "{}", stderr(&o));
    assert_eq!(
        std::fs::read_to_string(cwd.join("rep/notes.txt")).unwrap(),
        "mine"
    );
    let manifest = std::fs::read_to_string(cwd.join("rep/.vpctl-output.json")).unwrap();
    assert!(!manifest.contains("notes.txt"), "{manifest}");
    // Everything outside rep/ is as it was, and nothing is left beside it.
    let after: Vec<_> = snapshot(cwd)
        .into_iter()
        .filter(|(p, _)| !p.starts_with("rep"))
        .collect();
    assert!(
        after == before.into_iter().collect::<Vec<_>>(),
        "files outside rep/ changed"
    );
    let names: Vec<String> = std::fs::read_dir(cwd)
        .unwrap()
        .map(|e| e.unwrap().file_name().to_string_lossy().into_owned())
        .collect();
    assert!(!names.iter().any(|n| n.contains("vpctl-")), "{names:?}");
}
