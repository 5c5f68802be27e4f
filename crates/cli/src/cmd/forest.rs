//! `vpctl train`, `vpctl predict`, `vpctl forest ...`: the MVS confidence
//! predictor (Semantic Texton Forest with angle-binned leaves).

use std::io::Write;
use std::path::{Path, PathBuf};

use anyhow::{Context, Result};
use clap::{Args, Subcommand};
use indicatif::{ProgressBar, ProgressStyle};
use vp_forest::{
    load_label_dir, predict_files_with_progress, sparsification, train_with_progress, BatchOptions,
    Forest, Preset, Scored, TrainParams, TrainingSet,
};
use vp_scene::fsio;

/// Arguments of `vpctl train`.
#[derive(Debug, Args)]
pub struct TrainArgs {
    /// Folder of the training images, named as in the label file names.
    #[arg(long)]
    images: PathBuf,
    /// Folder of label images, searched recursively for
    /// `<image name>.vplabel` (the layout `vpctl labelgen run` writes). A label
    /// image smaller than its image pairs with the image scaled to its size.
    #[arg(long)]
    labels: PathBuf,
    /// Output model file.
    #[arg(long)]
    out: PathBuf,
    /// TOML file of training parameters; missing fields keep the defaults
    /// (`vpctl forest defaults` prints them all; `--preset paper` the
    /// paper's).
    #[arg(long)]
    config: Option<PathBuf>,
    /// Named parameters instead of a config: `default` (10 trees of depth
    /// 16, the size chosen by measured held-out accuracy) or `paper` (the
    /// paper's 20 trees of depth 20).
    #[arg(long, conflicts_with = "config", value_name = "NAME")]
    preset: Option<Preset>,
    /// Number of trees (overrides the config).
    #[arg(long)]
    trees: Option<usize>,
    /// Maximum tree depth (overrides the config).
    #[arg(long)]
    max_depth: Option<usize>,
    /// Keep at most this many labelled pixels per label image (a uniform
    /// random subset, so the class ratio holds): bounds memory on large label sets.
    #[arg(long)]
    max_per_label_image: Option<usize>,
    /// Seed: same data, parameters and seed give the same model bytes.
    #[arg(long, default_value_t = 0)]
    seed: u64,
    /// Overwrite the model file if it exists.
    #[arg(long)]
    force: bool,
}

/// Arguments of `vpctl predict`.
#[derive(Debug, Args)]
pub struct PredictArgs {
    /// Forest file written by `vpctl train` (or `vpctl sim train`).
    #[arg(long = "forest", alias = "model", value_name = "FILE")]
    model: PathBuf,
    /// Output folder: `<image name>.vpconf` per image (the name `vpctl plan
    /// --confidence-dir` looks for; an image found in a sub-folder of a given
    /// folder keeps that sub-folder) and `<image name>.preview.png`: the photo
    /// beside the confidence of each angle bin, colour-mapped (viridis, dark
    /// 0 to yellow 1) with a key.
    #[arg(long)]
    out: PathBuf,
    /// Grid step in pixels (the paper: 8).
    #[arg(long, default_value_t = 8)]
    step: u32,
    /// Skip the PNG previews.
    #[arg(long)]
    no_previews: bool,
    /// Replace an earlier `predict` output in --out (only the files vpctl
    /// wrote there; other files stay).
    #[arg(long)]
    force: bool,
    /// Images to predict: files, or folders searched recursively for
    /// .png/.jpg/.jpeg/.tif/.tiff/.pgm/.ppm (named relative to the folder, as COLMAP names them).
    #[arg(required = true)]
    images: Vec<PathBuf>,
}

/// `vpctl forest ...` subcommands.
#[derive(Debug, Subcommand)]
pub enum ForestCommand {
    /// Print a model's parameters, angle bins and training summary.
    Info {
        /// Model file.
        model: PathBuf,
        /// Print JSON instead of text.
        #[arg(long)]
        json: bool,
    },
    /// Score a model on held-out label images: accuracy at confidence 0.5 and
    /// sparsification (AUSC relative to the optimum, and random's).
    Eval {
        /// Forest file.
        #[arg(long = "forest", alias = "model", value_name = "FILE")]
        model: PathBuf,
        /// Folder of the images.
        #[arg(long)]
        images: PathBuf,
        /// Folder of label images (as for `vpctl train`).
        #[arg(long)]
        labels: PathBuf,
    },
    /// Print every training parameter with its default, as TOML.
    Defaults {
        /// `default` (10 trees of depth 16) or `paper` (20 trees of depth 20).
        #[arg(long, default_value = "default", value_name = "NAME")]
        preset: Preset,
    },
}

/// Runs `vpctl train`.
pub fn train(a: &TrainArgs, out: &mut dyn Write) -> Result<()> {
    fsio::check_output_file(&a.out, a.force)?;
    let mut params = match &a.config {
        Some(path) => read_params(path)?,
        None => TrainParams::preset(a.preset.unwrap_or_default()),
    };
    params.n_trees = a.trees.unwrap_or(params.n_trees);
    params.max_depth = a.max_depth.unwrap_or(params.max_depth);
    params.validate()?;
    if params.balance_classes {
        // The default (the paper's balanced draw) stays for compatibility,
        // but the simulated campaigns found that it leaves the confidences
        // uncalibrated, and the planner reads them as probabilities.
        eprintln!(
            "warning: balance_classes = true: both classes are weighted equally, so the \
             confidences are not calibrated probabilities of MVS success and the planner's \
             expected gains are biased (the simulated campaigns train with \
             balance_classes = false for this reason); for planning, set \
             balance_classes = false in --config (vpctl forest defaults prints one)"
        );
    }

    let set = TrainingSet::from_label_dir(&a.images, &a.labels, a.max_per_label_image, a.seed)?;
    writeln!(
        out,
        "training set: {} images, {} label images, {} positive and {} negative pixels",
        set.n_images(),
        set.n_label_images(),
        set.n_positive(),
        set.n_negative()
    )?;

    // A bar on a terminal; one plain line per tree otherwise (a log file).
    let tty = std::io::IsTerminal::is_terminal(&std::io::stderr());
    let bar = if tty {
        ProgressBar::new(params.n_trees as u64).with_style(
            ProgressStyle::with_template("training {bar:30} {pos}/{len} trees, {elapsed}")
                .unwrap_or_else(|_| ProgressStyle::default_bar()),
        )
    } else {
        ProgressBar::hidden()
    };
    let done = std::sync::atomic::AtomicUsize::new(0);
    let n_trees = params.n_trees;
    let forest = train_with_progress(&set, &params, a.seed, &|_| {
        bar.inc(1);
        if !tty {
            let k = done.fetch_add(1, std::sync::atomic::Ordering::Relaxed) + 1;
            eprintln!("training: tree {k}/{n_trees}");
        }
    })?;
    bar.finish_and_clear();
    forest.save(&a.out)?;
    print_summary(&forest, out)?;
    writeln!(out, "written: {}", a.out.display())?;
    Ok(())
}

/// Runs `vpctl predict` (the library's [`vp_forest::predict_files`]).
pub fn predict(a: &PredictArgs, out: &mut dyn Write) -> Result<()> {
    let inputs: Vec<&Path> = std::iter::once(a.model.as_path())
        .chain(a.images.iter().map(PathBuf::as_path))
        .collect();
    let target = vp_scene::outdir::OutDir::check(&a.out, "predict", &inputs, a.force)?;
    let forest = Forest::load(&a.model)?;
    let images = vp_scene::image_files::find_images(&a.images)?;
    let options = BatchOptions {
        step: a.step,
        previews: !a.no_previews,
        force: false,
    };
    let progress = super::Progress::new();
    let predicted = target.write(|stage| -> Result<_> {
        let mut predicted =
            predict_files_with_progress(&forest, &images, stage, &options, &mut |m| {
                progress.message(m);
            })?;
        // Named where they will be, not where they are staged.
        let moved = |f: &Path| {
            f.strip_prefix(stage)
                .map_or_else(|_| f.to_path_buf(), |r| a.out.join(r))
        };
        for p in &mut predicted {
            p.confidence_file = moved(&p.confidence_file);
            p.preview_file = p.preview_file.as_deref().map(moved);
        }
        Ok(predicted)
    })?;
    progress.finish();
    for line in vp_forest::batch::report(&predicted, &a.out) {
        writeln!(out, "{line}")?;
    }
    Ok(())
}

/// Runs `vpctl forest ...`.
pub fn run(cmd: ForestCommand, out: &mut dyn Write) -> Result<()> {
    match cmd {
        ForestCommand::Info { model, json } => {
            let forest = Forest::load(&model)?;
            if json {
                let v = serde_json::json!({
                    "params": forest.params(),
                    "summary": forest.summary(),
                });
                writeln!(out, "{}", serde_json::to_string_pretty(&v)?)?;
            } else {
                writeln!(out, "model: {}", model.display())?;
                print_summary(&forest, out)?;
            }
            Ok(())
        }
        ForestCommand::Eval {
            model,
            images,
            labels,
        } => eval(&model, &images, &labels, out),
        ForestCommand::Defaults { preset } => {
            write!(out, "{}", toml::to_string(&TrainParams::preset(preset))?)?;
            Ok(())
        }
    }
}

fn eval(model: &Path, images: &Path, labels: &Path, out: &mut dyn Write) -> Result<()> {
    let forest = Forest::load(model)?;
    let mut scored: Vec<Scored> = Vec::new();
    for li in load_label_dir(images, labels)? {
        for (l, path) in li.labels.iter().zip(&li.label_paths) {
            let s = forest
                .score_labels(&li.image, l)
                .with_context(|| format!("{}: scoring failed", path.display()))?;
            scored.extend(s);
        }
    }
    let acc = vp_forest::accuracy(&scored, 0.5)?;
    let sp = sparsification(&scored, 20)?;
    writeln!(out, "labelled pixels: {}", scored.len())?;
    writeln!(out, "negative share: {:.4}", sp.error_rate)?;
    writeln!(out, "accuracy: {acc:.4}")?;
    writeln!(out, "relative AUSC: {:.3}", sp.relative_ausc)?;
    writeln!(out, "random relative AUSC: {:.3}", sp.random_relative_ausc)?;
    Ok(())
}

fn print_summary(forest: &Forest, out: &mut dyn Write) -> Result<()> {
    let p = forest.params();
    let s = forest.summary();
    writeln!(
        out,
        "trees: {}, max depth {} (reached {}), nodes {}, leaves {}",
        p.n_trees, p.max_depth, s.max_depth_reached, s.n_nodes, s.n_leaves
    )?;
    writeln!(out, "angle bin edges (deg): {:?}", forest.bins().edges())?;
    writeln!(
        out,
        "trained on: {} positive, {} negative samples (seed {})",
        s.n_positive, s.n_negative, s.seed
    )?;
    writeln!(out, "training accuracy: {:.4}", s.train_accuracy)?;
    Ok(())
}

fn read_params(path: &Path) -> Result<TrainParams> {
    Ok(vp_scene::config_file::load_section(path, "")?)
}
