//! `vpctl train`, `vpctl predict`, `vpctl forest info|eval|defaults`: models,
//! confidence images and exit codes on seeded synthetic textures.

use std::path::{Path, PathBuf};
use std::process::Output;

use vp_forest::synthetic::{label_image, texture_image};
use vp_scene::raster::{load_rgb, save_rgb, ConfidenceImage, Label, PreviewLayout};

mod common;
use common::vpctl;

fn text(o: &Output) -> String {
    format!(
        "{}{}",
        String::from_utf8_lossy(&o.stdout),
        String::from_utf8_lossy(&o.stderr)
    )
}

/// Noisy blocks succeed below 20 deg and fail above; smooth blocks fail.
fn rule(noisy: bool, angle: f32) -> Label {
    if noisy && angle < 20.0 {
        Label::Positive
    } else {
        Label::Negative
    }
}

/// Images `<dir>/images/i<k>.png` and labels in the labelgen layout
/// `<dir>/labels/t000<k>/level1/i<k>.png.vplabel`; image `held` goes to
/// `<dir>/held` instead, for evaluation.
fn write_data(dir: &Path, n: u64, held: u64) -> (PathBuf, PathBuf, PathBuf, PathBuf) {
    let paths = ["images", "labels", "held/images", "held/labels"].map(|p| dir.join(p));
    for seed in 0..n {
        let (images, labels) = if seed == held {
            (&paths[2], &paths[3])
        } else {
            (&paths[0], &paths[1])
        };
        let level = labels.join(format!("t{seed:04}/level1"));
        std::fs::create_dir_all(&level).unwrap();
        std::fs::create_dir_all(images).unwrap();
        let tex = texture_image(96, 64, 16, seed);
        let name = format!("i{seed}.png");
        save_rgb(&tex.image, &images.join(&name)).unwrap();
        label_image(&tex, 3, 45.0, seed + 100, rule)
            .save(&level.join(format!("{name}.vplabel")))
            .unwrap();
    }
    let [a, b, c, d] = paths;
    (a, b, c, d)
}

/// `vpctl train --images .. --labels .. --out .. [extra]`.
fn train(images: &Path, labels: &Path, out: &Path, extra: &[&str]) -> Output {
    let mut args = vec![
        "train",
        "--images",
        images.to_str().unwrap(),
        "--labels",
        labels.to_str().unwrap(),
        "--out",
        out.to_str().unwrap(),
    ];
    args.extend_from_slice(extra);
    vpctl(&args)
}

#[test]
fn train_predict_and_eval_learn_texture_and_angle() {
    let dir = tempfile::tempdir().unwrap();
    let (images, labels, held_images, held_labels) = write_data(dir.path(), 4, 3);
    let config = dir.path().join("forest.toml");
    std::fs::write(
        &config,
        "n_tests = 200\nn_thresholds = 20\nn_node_samples = 400\nmin_samples_split = 20\n",
    )
    .unwrap();
    let model = dir.path().join("m.vpforest");
    let small = [
        "--config",
        config.to_str().unwrap(),
        "--trees",
        "4",
        "--max-depth",
        "10",
        "--seed",
        "7",
    ];
    let train_small = |out: &Path| train(&images, &labels, out, &small);
    let o = train_small(&model);
    assert!(o.status.success(), "{}", text(&o));
    // stderr is not a terminal: one plain progress line per tree, no bar.
    let err = String::from_utf8_lossy(&o.stderr);
    assert!(err.contains("training: tree 1/"), "{err}");
    assert!(!err.contains('\r'), "{err:?}");
    // The default balances the classes: the warning says why that is wrong
    // for planning.
    assert!(
        String::from_utf8_lossy(&o.stderr).contains("confidences are not calibrated"),
        "{}",
        text(&o)
    );
    assert!(
        text(&o).contains("training set: 3 images, 3 label images"),
        "{}",
        text(&o)
    );

    // Same data and seed: same model bytes. An existing model is kept without --force.
    let again = dir.path().join("m2.vpforest");
    assert!(train_small(&again).status.success());
    assert_eq!(
        std::fs::read(&model).unwrap(),
        std::fs::read(&again).unwrap()
    );
    let refused = train_small(&again);
    assert_eq!(refused.status.code(), Some(2), "{}", text(&refused));

    let o = vpctl(&["forest", "info", model.to_str().unwrap(), "--json"]);
    assert!(o.status.success(), "{}", text(&o));
    let info: serde_json::Value = serde_json::from_slice(&o.stdout).unwrap();
    assert_eq!(info["params"]["n_trees"], 4);
    assert_eq!(info["params"]["n_tests"], 200);
    assert_eq!(info["summary"]["seed"], 7);

    // Held-out image: accuracy well above the 50% of a coin.
    let o = vpctl(&[
        "forest",
        "eval",
        "--forest",
        model.to_str().unwrap(),
        "--images",
        held_images.to_str().unwrap(),
        "--labels",
        held_labels.to_str().unwrap(),
    ]);
    assert!(o.status.success(), "{}", text(&o));
    let acc: f64 = text(&o)
        .lines()
        .find_map(|l| l.strip_prefix("accuracy: "))
        .and_then(|v| v.parse().ok())
        .expect("accuracy line");
    assert!(acc > 0.85, "held-out accuracy {acc}\n{}", text(&o));

    let conf_dir = dir.path().join("conf");
    let o = vpctl(&[
        "predict",
        "--forest",
        model.to_str().unwrap(),
        "--out",
        conf_dir.to_str().unwrap(),
        held_images.to_str().unwrap(),
    ]);
    assert!(o.status.success(), "{}", text(&o));
    assert_confidence_learned(&conf_dir.join("i3.png.vpconf"), 3);
    let preview = conf_dir.join("i3.png.preview.png");
    assert!(
        text(&o).contains(&format!("preview: {}", preview.display())),
        "{}",
        text(&o)
    );
    assert_preview_readable(&preview, &conf_dir.join("i3.png.vpconf"), 3);
}

/// Prediction previews were 12x8 px per bin (the grid): a user saw nothing.
/// Now one image per photo: the photo and every bin at 240 px wide, the
/// planted rule visible (noisy blocks bright at 0-5 deg, dark at 40-45 deg).
fn assert_preview_readable(preview: &Path, conf: &Path, seed: u64) {
    let img = load_rgb(preview).unwrap();
    let c = ConfidenceImage::load(conf).unwrap();
    let layout = PreviewLayout::of(&c, 0);
    assert_eq!(img.dimensions(), layout.size);
    assert!(
        img.width() >= 1200 && img.height() >= 300,
        "{:?}",
        img.dimensions()
    );
    assert_eq!(layout.panel, (240, 160));
    assert_eq!(layout.origins.len(), 1 + 9, "the photo and nine bins");
    // The photo panel is the (textured) photo, not a flat fill.
    let (x0, y0) = layout.origins[0];
    let photo: Vec<[u8; 3]> = (0..160)
        .map(|y| img.get_pixel(x0 + 120, y0 + y).0)
        .collect();
    assert!(
        photo.iter().any(|p| *p != photo[0]),
        "the photo panel is flat"
    );
    let luma =
        |p: [u8; 3]| 0.299 * f32::from(p[0]) + 0.587 * f32::from(p[1]) + 0.114 * f32::from(p[2]);
    let tex = texture_image(96, 64, 16, seed);
    let (mut low, mut high) = (vec![], vec![]);
    for y in 0..64 {
        for x in 0..96 {
            if tex.border_distance(x, y) < 4 || !tex.is_noisy(x, y) {
                continue;
            }
            let (px, py) = (x * 240 / 96, y * 160 / 64);
            let at = |panel: usize| {
                let (ox, oy) = layout.origins[panel];
                luma(img.get_pixel(ox + px, oy + py).0)
            };
            low.push(at(1));
            high.push(at(9));
        }
    }
    let mean = |v: &[f32]| v.iter().sum::<f32>() / v.len() as f32;
    assert!(
        mean(&low) > mean(&high) + 60.0,
        "noisy blocks: {} at 0-5 deg, {} at 40-45 deg",
        mean(&low),
        mean(&high)
    );
}

/// Noisy blocks are confident at 2.5 deg, not at 42.5 deg; smooth blocks
/// are not confident at all (the planted rule).
fn assert_confidence_learned(path: &Path, seed: u64) {
    let c = ConfidenceImage::load(path).unwrap();
    assert_eq!((c.width(), c.height(), c.step()), (96, 64, 8));
    let tex = texture_image(96, 64, 16, seed);
    let (mut noisy_low, mut noisy_high, mut smooth) = (vec![], vec![], vec![]);
    let (gw, gh) = c.grid_size();
    for j in 0..gh {
        for i in 0..gw {
            let (x, y) = c.node_pixel(i, j);
            if tex.border_distance(x, y) < 4 {
                continue;
            }
            let px = (f64::from(x), f64::from(y));
            if tex.is_noisy(x, y) {
                noisy_low.push(c.sample(px, 2.5));
                noisy_high.push(c.sample(px, 42.5));
            } else {
                smooth.push(c.sample(px, 2.5));
            }
        }
    }
    let mean = |v: &[f32]| v.iter().sum::<f32>() / v.len() as f32;
    assert!(
        mean(&noisy_low) > 0.7,
        "noisy at 2.5 deg: {}",
        mean(&noisy_low)
    );
    assert!(
        mean(&noisy_high) < 0.3,
        "noisy at 42.5 deg: {}",
        mean(&noisy_high)
    );
    assert!(mean(&smooth) < 0.3, "smooth: {}", mean(&smooth));
}

#[test]
fn bad_inputs_exit_2_and_write_nothing() {
    let dir = tempfile::tempdir().unwrap();
    let (images, labels, _, _) = write_data(dir.path(), 2, 99);
    let model = dir.path().join("m.vpforest");

    // A label whose image is missing: named, exit 2, no model.
    std::fs::remove_file(images.join("i1.png")).unwrap();
    let o = train(&images, &labels, &model, &[]);
    assert_eq!(o.status.code(), Some(2), "{}", text(&o));
    assert!(text(&o).contains("i1.png.vplabel"), "{}", text(&o));
    assert!(!model.exists());

    // A bad config field is named.
    let config = dir.path().join("bad.toml");
    std::fs::write(&config, "n_trees = 3\nn_trea = 2\n").unwrap();
    let o = train(
        &images,
        &labels,
        &model,
        &["--config", config.to_str().unwrap()],
    );
    assert_eq!(o.status.code(), Some(2), "{}", text(&o));
    assert!(
        text(&o).contains("bad.toml") && text(&o).contains("n_trea"),
        "{}",
        text(&o)
    );

    // A corrupt model: exit 2, no confidence images.
    std::fs::write(&model, b"not a model").unwrap();
    let conf_dir = dir.path().join("conf");
    let o = vpctl(&[
        "predict",
        "--forest",
        model.to_str().unwrap(),
        "--out",
        conf_dir.to_str().unwrap(),
        images.join("i0.png").to_str().unwrap(),
    ]);
    assert_eq!(o.status.code(), Some(2), "{}", text(&o));
    assert!(text(&o).contains("m.vpforest"), "{}", text(&o));
    assert!(!conf_dir.exists());
}

#[test]
fn defaults_are_the_measured_size_the_paper_is_one_flag_away_and_both_round_trip() {
    let o = vpctl(&["forest", "defaults"]);
    assert!(o.status.success(), "{}", text(&o));
    let t = String::from_utf8_lossy(&o.stdout).into_owned();
    assert!(
        t.contains("n_trees = 10") && t.contains("max_depth = 16") && t.contains("n_tests = 5000"),
        "{t}"
    );
    let o = vpctl(&["forest", "defaults", "--preset", "paper"]);
    let paper = String::from_utf8_lossy(&o.stdout);
    assert!(
        paper.contains("n_trees = 20") && paper.contains("max_depth = 20"),
        "{paper}"
    );
    let o = vpctl(&["forest", "defaults", "--preset", "papr"]);
    assert_eq!(o.status.code(), Some(2), "{}", text(&o));
    assert!(
        text(&o).contains("expected \"default\" or \"paper\""),
        "{}",
        text(&o)
    );
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("d.toml");
    std::fs::write(&path, t.as_bytes()).unwrap();
    // The printed defaults are a valid config (training then fails only for
    // the empty label folder, which is named).
    let o = train(
        dir.path(),
        dir.path(),
        &dir.path().join("m"),
        &["--config", path.to_str().unwrap()],
    );
    assert_eq!(o.status.code(), Some(2), "{}", text(&o));
    assert!(text(&o).contains("no .vplabel files"), "{}", text(&o));
}

/// Regression: `vpctl predict` wrote `<stem>.vpconf` (dropping the image's
/// extension and sub-folders) while the planner looked for the COLMAP image
/// name with its extension replaced, and training dropped the sub-folders of
/// label files, so an image named `sub/dir/img.v2.JPG` could be neither
/// trained on nor planned with. One naming rule now serves all of them.
#[test]
fn image_names_with_sub_folders_and_dots_survive_train_and_predict() {
    let dir = tempfile::tempdir().unwrap();
    let name = "sub/dir/img.v2.JPG";
    let images = dir.path().join("images");
    let labels = dir.path().join("labels/t0000/level1");
    std::fs::create_dir_all(images.join("sub/dir")).unwrap();
    let tex = texture_image(96, 64, 16, 5);
    save_rgb(&tex.image, &images.join(name)).unwrap();
    let label = label_image(&tex, 3, 45.0, 105, rule);
    let label_file = vp_scene::image_files::label_file(&labels, name).unwrap();
    std::fs::create_dir_all(label_file.parent().unwrap()).unwrap();
    label.save(&label_file).unwrap();

    let model = dir.path().join("m.vpforest");
    let o = train(
        &images,
        &dir.path().join("labels"),
        &model,
        &["--trees", "2"],
    );
    assert!(o.status.success(), "{}", text(&o));

    let conf = dir.path().join("conf");
    let o = vpctl(&[
        "predict",
        "--forest",
        model.to_str().unwrap(),
        "--out",
        conf.to_str().unwrap(),
        "--no-previews",
        images.to_str().unwrap(),
    ]);
    assert!(o.status.success(), "{}", text(&o));
    // The file the planner reads for the COLMAP image `sub/dir/img.v2.JPG`.
    let wanted = vp_scene::image_files::confidence_file(&conf, name).unwrap();
    assert_eq!(wanted, conf.join("sub/dir/img.v2.JPG.vpconf"));
    assert!(wanted.exists(), "{}", text(&o));
}

/// Regression (issue 39): `predict --out <folder> --force` wrote into any
/// folder, the current one or its own images' folder included.
#[test]
fn predict_never_deletes_what_it_did_not_write() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    let (images, labels, _, _) = write_data(&d.join("in"), 3, 99);
    let o = train(
        &images,
        &labels,
        &d.join("in/m.vpforest"),
        &["--trees", "2"],
    );
    assert!(o.status.success(), "{}", text(&o));
    common::assert_output_guards(
        d,
        &["predict", "--forest", "in/m.vpforest", "in/images"],
        "in/images",
    );
}

/// Regression (issue 40): `predict` into a log wrote a line per image on
/// stderr (two with previews), and its result a line per image on stdout
/// (10,000 lines for 5,000 images); now timestamped summary lines, a few
/// per stage, and a summary of the result beyond 20 images.
#[test]
fn predict_in_a_log_writes_few_timestamped_lines_not_one_per_image() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    let (images, labels, _, _) = write_data(&d.join("in"), 3, 99);
    let model = d.join("m.vpforest");
    let o = train(&images, &labels, &model, &["--trees", "2"]);
    assert!(o.status.success(), "{}", text(&o));
    let many = d.join("many");
    std::fs::create_dir_all(&many).unwrap();
    let n = 40;
    for i in 0..n {
        std::fs::copy(images.join("i0.png"), many.join(format!("p{i:02}.png"))).unwrap();
    }
    let t0 = std::time::Instant::now();
    let o = vpctl(&[
        "predict",
        "--forest",
        model.to_str().unwrap(),
        "--out",
        d.join("conf").to_str().unwrap(),
        "--no-previews",
        many.to_str().unwrap(),
    ]);
    let secs = t0.elapsed().as_secs();
    assert!(o.status.success(), "{}", text(&o));
    let err = String::from_utf8_lossy(&o.stderr).into_owned();
    let lines: Vec<&str> = err.lines().collect();
    // Start and end of the prediction, the writing stage, and at most one
    // line per 5 s of a stage on a slow machine: never one per image.
    let bound = 3 + 2 * (secs as usize / 5 + 1);
    assert!(
        lines.len() <= bound && lines.len() < n,
        "{} lines for {n} images in {secs} s:\n{err}",
        lines.len()
    );
    for l in &lines {
        assert!(
            l.starts_with('[') && l.contains(" s] "),
            "no timestamp: {l}"
        );
    }
    assert!(err.contains(&format!("predicted: {n}/{n}")), "{err}");
    assert!(
        !err.contains('\r') && !err.contains('\u{1b}'),
        "no terminal codes in a log: {err:?}"
    );
    let out = String::from_utf8_lossy(&o.stdout);
    assert!(out.lines().count() <= 3, "{out}");
    assert!(
        out.contains(&format!("predicted {n} images: mean confidence "))
            && out.contains(&format!(
                "written: {n} confidence files <image name>.vpconf in "
            )),
        "{out}"
    );
}
