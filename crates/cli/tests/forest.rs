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

/// `vpctl sim evaluate` on two quick training sites: one row per fold,
/// material and angle bin whose pixels add up to the printed total; one
/// site is refused with the config named and nothing written.
#[test]
fn sim_evaluate_scores_each_held_out_site_and_refuses_a_single_site() {
    let dir = tempfile::tempdir().unwrap();
    let quick = vpctl(&["sim", "config", "--preset", "quick"]);
    assert!(quick.status.success(), "{}", text(&quick));
    let toml = String::from_utf8(quick.stdout).unwrap();
    let seeds = toml
        .lines()
        .find(|l| l.starts_with("site_seeds = "))
        .expect("the quick preset lists its training sites")
        .to_string();
    let write = |name: &str, line: &str| {
        let p = dir.path().join(name);
        std::fs::write(&p, toml.replace(&seeds, line)).unwrap();
        p
    };
    let one = write("one.toml", "site_seeds = [101]");
    let out = dir.path().join("eval-one");
    let o = vpctl(&[
        "sim",
        "evaluate",
        "--config",
        one.to_str().unwrap(),
        "--out",
        out.to_str().unwrap(),
    ]);
    assert_eq!(o.status.code(), Some(2), "{}", text(&o));
    assert!(
        text(&o).contains("one.toml") && text(&o).contains("at least 2"),
        "{}",
        text(&o)
    );
    assert!(!out.exists());

    let two = write("two.toml", "site_seeds = [101, 102]");
    let out = dir.path().join("eval");
    let o = vpctl(&[
        "sim",
        "evaluate",
        "--config",
        two.to_str().unwrap(),
        "--out",
        out.to_str().unwrap(),
    ]);
    assert!(o.status.success(), "{}", text(&o));
    let printed = String::from_utf8_lossy(&o.stdout).into_owned();
    let csv = std::fs::read_to_string(out.join("forest_eval.csv")).unwrap();
    let mut lines = csv.lines();
    assert_eq!(
        lines.next(),
        Some(
            "matcher,forest,fold,material,angle_bin,pixels,accuracy_labels,accuracy_truth,\
             majority_rate,brier,brier_angle_only"
        )
    );
    let mut folds = std::collections::BTreeSet::new();
    let mut pixels = 0u64;
    for l in lines {
        let f: Vec<&str> = l.split(',').collect();
        assert_eq!(f.len(), 11, "{l}");
        assert_eq!(f[0], "patchmatch");
        folds.insert(f[2].to_string());
        pixels += f[5].parse::<u64>().unwrap();
        let v: Vec<f64> = f[6..].iter().map(|x| x.parse().unwrap()).collect();
        assert!(v.iter().all(|x| (0.0..=1.0).contains(x)), "{l}");
        assert!(
            v[2] >= 0.5,
            "the majority label's share is at least half: {l}"
        );
    }
    assert_eq!(folds.into_iter().collect::<Vec<_>>(), ["101", "102"]);
    assert!(pixels > 0);
    assert!(
        printed.contains(&format!("over 2 folds, {pixels} labelled pixels")),
        "{printed}"
    );
    let summary = std::fs::read_to_string(out.join("summary.txt")).unwrap();
    assert!(printed.starts_with(&summary), "{printed}\n---\n{summary}");

    check_angle_success(&out, &summary);
    check_reliability_and_label_quality(&out, pixels);

    // Same config and seed: the same bytes, file by file.
    let again = dir.path().join("eval-again");
    let o = vpctl(&[
        "sim",
        "evaluate",
        "--config",
        two.to_str().unwrap(),
        "--out",
        again.to_str().unwrap(),
    ]);
    assert!(o.status.success(), "{}", text(&o));
    let mut names: Vec<_> = std::fs::read_dir(&out)
        .unwrap()
        .map(|e| e.unwrap().file_name())
        .collect();
    names.sort();
    assert!(names.len() >= 7, "{names:?}");
    for n in names {
        assert!(
            std::fs::read(out.join(&n)).unwrap() == std::fs::read(again.join(&n)).unwrap(),
            "{n:?} differs between two runs of one config"
        );
    }
}

/// `reliability.csv` (one line per forest, angle group and confidence bin:
/// its pixels are every labelled pixel scored, `pixels`, the diagram's PNG
/// beside it) and `label_quality.csv` (per material and angle bin, labelled
/// within surface, correct within labelled) of `vpctl sim evaluate` in `out`.
fn check_reliability_and_label_quality(out: &Path, pixels: u64) {
    let rel = std::fs::read_to_string(out.join("reliability.csv")).unwrap();
    let mut lines = rel.lines();
    assert_eq!(
        lines.next(),
        Some(
            "matcher,forest,angle_lo,angle_hi,conf_lo,conf_hi,pixels,mean_confidence,\
             label_success,truth_success"
        )
    );
    let mut sum = 0u64;
    for l in lines {
        let f: Vec<&str> = l.split(',').collect();
        assert_eq!(f.len(), 10, "{l}");
        sum += f[6].parse::<u64>().unwrap();
        let (lo, hi): (f64, f64) = (f[4].parse().unwrap(), f[5].parse().unwrap());
        let mean: f64 = f[7].parse().unwrap();
        assert!(mean >= lo - 1e-4 && mean <= hi + 1e-4, "{l}");
        assert!(out
            .join(format!("reliability_{}_{}.png", f[0], f[1]))
            .is_file());
    }
    assert_eq!(sum, pixels, "the diagram holds every scored pixel once");
    let q = std::fs::read_to_string(out.join("label_quality.csv")).unwrap();
    assert!(q.starts_with(
        "material,angle_bin,angle_lo,angle_hi,surface_pixels,labelled,labelled_share,correct,"
    ));
    let mut labelled = 0u64;
    for l in q.lines().skip(1) {
        let f: Vec<u64> = [4, 5, 7, 9, 10]
            .iter()
            .map(|&i| l.split(',').nth(i).unwrap().parse().unwrap())
            .collect();
        assert!(
            f[1] <= f[0] && f[2] <= f[1] && f[4] <= f[3] && f[3] <= f[1],
            "{l}"
        );
        labelled += f[1];
    }
    assert!(labelled >= pixels, "{labelled} labelled, {pixels} scored");
    let html = std::fs::read_to_string(out.join("report.html")).unwrap();
    assert!(html.contains("data:image/png;base64,") && html.contains("label-quality-angle"));
}

/// `angle_success.csv` of `vpctl sim evaluate` in `out`: the matcher's
/// measured success per site, material and angle bin, and its fall from
/// 5-15 to 35-45 deg on ground and rock in `summary` where both ranges have
/// pixels on a site.
fn check_angle_success(out: &Path, summary: &str) {
    let success = std::fs::read_to_string(out.join("angle_success.csv")).unwrap();
    let mut lines = success.lines();
    assert_eq!(
        lines.next(),
        Some("matcher,site,material,angle_bin,angle_lo,angle_hi,visible,reconstructed,success")
    );
    let mut ranges = std::collections::BTreeMap::<&str, [bool; 2]>::new();
    for l in lines {
        let f: Vec<&str> = l.split(',').collect();
        assert_eq!(f.len(), 9, "{l}");
        assert!(f[1] == "101" || f[1] == "102", "{l}");
        let (lo, hi): (f64, f64) = (f[4].parse().unwrap(), f[5].parse().unwrap());
        let (visible, ok): (u64, u64) = (f[6].parse().unwrap(), f[7].parse().unwrap());
        assert!(visible > 0 && ok <= visible, "{l}");
        let share: f64 = f[8].parse().unwrap();
        assert!((share - ok as f64 / visible as f64).abs() < 1e-4, "{l}");
        if f[2] == "ground" || f[2] == "rock" {
            let r = ranges.entry(f[1]).or_default();
            r[0] |= lo >= 5.0 && hi <= 15.0;
            r[1] |= lo >= 35.0 && hi <= 45.0;
        }
    }
    let both = ranges.values().filter(|r| r[0] && r[1]).count();
    assert_eq!(
        summary.contains(&format!("mean over {both} sites: 5-15 deg")),
        both > 0,
        "{both} sites with both ranges:\n{summary}"
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
