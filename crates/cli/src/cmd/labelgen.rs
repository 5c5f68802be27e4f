//! `vpctl labelgen ...`: training labels without ground truth.

use std::io::Write;
use std::path::PathBuf;

use anyhow::Result;
use clap::{Args, Subcommand};
use vp_labelgen::triplets::{self, TripletParams};
use vp_labelgen::{LabelOutput, LabelParams, LabelRunRequest};
use vp_scene::fsio;

use super::sparse_model::SparseModelArgs;

/// Label-generation subcommands.
#[derive(Debug, Subcommand)]
pub enum LabelgenCommand {
    /// Sample image triplets from triangulation-angle bins (4-8-16-32-64-128
    /// deg) of a COLMAP model, for the MVS to reconstruct one by one.
    ///
    /// Writes the triplet list (one line per triplet: bin, angle, three image
    /// names, tab-separated; triplet i has the id t0000, t0001, ...) and, with
    /// --image-lists, one COLMAP image list per triplet (<id>.txt).
    Triplets(TripletsArgs),
    /// Label every image of every triplet from the triplets' depth maps by
    /// consistency voting (support, voting, missing parts).
    ///
    /// Depth maps: <depth-dir>/<triplet id>/level<L>/<image name>.geometric.bin
    /// (COLMAP's format; .photometric.bin if no geometric map), L = 1, 2, 3
    /// for the pyramid levels; each level is an independent reconstruction.
    /// Writes <out-dir>/<triplet id>/level<L>/<image name>.vplabel and
    /// <out-dir>/summary.json.
    Run(RunArgs),
    /// Print every label parameter with its default, as TOML (for `run --config`).
    Defaults,
}

/// Arguments of `labelgen triplets`.
#[derive(Debug, Args)]
pub struct TripletsArgs {
    #[command(flatten)]
    model: SparseModelArgs,
    /// Triplets drawn per angle bin.
    #[arg(long, default_value_t = 10)]
    per_bin: usize,
    /// RNG seed: same model and seed, same triplets.
    #[arg(long, default_value_t = 0)]
    seed: u64,
    /// Fewest sparse points the three images must share.
    #[arg(long, default_value_t = 20)]
    min_shared_points: usize,
    /// Fewest shared points as a share of the points of the image that sees fewest.
    #[arg(long, allow_negative_numbers = true, default_value_t = 0.1)]
    min_shared_share: f64,
    /// Smallest / largest pairwise angle at the median point.
    #[arg(long, allow_negative_numbers = true, default_value_t = 0.5)]
    min_equilateral: f64,
    /// Output triplet list.
    #[arg(long)]
    out: PathBuf,
    /// Also write one COLMAP image list per triplet into this folder.
    #[arg(long)]
    image_lists: Option<PathBuf>,
    /// Overwrite existing output files.
    #[arg(long)]
    force: bool,
}

/// Arguments of `labelgen run`.
#[derive(Debug, Args)]
pub struct RunArgs {
    /// The model with the poses of every image, of the undistorted images
    /// the depth maps are of: COLMAP's aligned by `vpctl colmap align` (its
    /// `frame.json` is checked), OpenSfM's by its geodetic reference.
    #[command(flatten)]
    model: SparseModelArgs,
    /// Skip the frame check (`frame.json` or the OpenSfM reference, scale,
    /// gravity): only for a model already in metric, gravity-aligned local ENU.
    #[arg(long)]
    frame_unchecked: bool,
    /// Triplet list written by `vpctl labelgen triplets`.
    #[arg(long)]
    triplets: PathBuf,
    /// Folder of depth maps (layout above).
    #[arg(long)]
    depth_dir: PathBuf,
    /// Surface mesh (PLY/OBJ, e.g. from the sparse points) for missing-part
    /// negatives (stage 3). Without it, holes stay unlabelled.
    #[arg(long)]
    mesh: Option<PathBuf>,
    /// Output folder for label images and summary.json.
    #[arg(long = "out", alias = "out-dir", value_name = "DIR")]
    out_dir: PathBuf,
    /// Label parameters as TOML (any subset of the keys `vpctl labelgen
    /// defaults` prints).
    #[arg(long, alias = "params")]
    config: Option<PathBuf>,
    /// Replace an earlier `labelgen run` output in --out (only the files
    /// vpctl wrote there; other files stay).
    #[arg(long)]
    force: bool,
}

pub fn run(cmd: LabelgenCommand, out: &mut dyn Write) -> Result<()> {
    match cmd {
        LabelgenCommand::Triplets(a) => sample(&a, out),
        LabelgenCommand::Run(a) => label(&a, out),
        LabelgenCommand::Defaults => {
            write!(out, "{}", toml::to_string(&LabelParams::default())?)?;
            Ok(())
        }
    }
}

fn sample(a: &TripletsArgs, out: &mut dyn Write) -> Result<()> {
    fsio::check_output_file(&a.out, a.force)?;
    let source = a.model.source();
    let model = source.read()?;
    let params = TripletParams {
        per_bin: a.per_bin,
        seed: a.seed,
        min_shared_points: a.min_shared_points,
        min_shared_share: a.min_shared_share,
        min_equilateral: a.min_equilateral,
        ..TripletParams::default()
    };
    let sampled = triplets::sample_triplets(&model, &params)?;
    if sampled.is_empty() {
        return Err(super::UsageError(format!(
            "no triplet found in {} ({} images, {} points): no three images share {} points \
             (--min-shared-points) and {} of their points (--min-shared-share) at the \
             angles of the bins; lower those, or acquire images with more overlap",
            source.path().display(),
            model.images.len(),
            model.points.len(),
            a.min_shared_points,
            a.min_shared_share
        ))
        .into());
    }
    // Image lists first: they refuse to overwrite one by one, and a refusal
    // should leave no triplet list behind either.
    if let Some(dir) = &a.image_lists {
        triplets::write_image_lists(dir, &sampled, a.force)?;
    }
    triplets::write_triplet_list(&a.out, &sampled)?;
    writeln!(out, "triplets: {}", sampled.len())?;
    for (b, e) in params.bin_edges.windows(2).enumerate() {
        let n = sampled.iter().filter(|t| t.bin == b).count();
        writeln!(out, "bin {b} [{}, {}) deg: {n}", e[0], e[1])?;
    }
    writeln!(out, "written: {}", a.out.display())?;
    Ok(())
}

fn label(a: &RunArgs, out: &mut dyn Write) -> Result<()> {
    let mut req = LabelRunRequest::new(a.model.source(), &a.triplets, &a.depth_dir);
    req.mesh.clone_from(&a.mesh);
    req.frame_unchecked = a.frame_unchecked;
    let output = LabelOutput {
        out: a.out_dir.clone(),
        inputs: a.config.iter().cloned().collect(),
        force: a.force,
    };
    if let Some(path) = &a.config {
        req.params = LabelParams::load(path)?;
    }
    let progress = super::Progress::new();
    let (s, warnings) =
        vp_labelgen::run_labelling_with_progress(&req, &output, &mut |m| progress.message(m))?;
    progress.finish();
    super::print_warnings(&warnings);
    writeln!(out, "reconstructions: {}", s.reconstructions)?;
    writeln!(out, "measured pixels: {}", s.measured)?;
    writeln!(out, "positive: {}", s.positive)?;
    writeln!(out, "negative (voting): {}", s.negative_voted)?;
    writeln!(out, "negative (missing parts): {}", s.negative_missing)?;
    writeln!(out, "labelled share: {:.4}", s.labelled_share)?;
    writeln!(out, "written: {}", a.out_dir.display())?;
    Ok(())
}
