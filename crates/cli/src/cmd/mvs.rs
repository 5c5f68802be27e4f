//! `vpctl mvs ...`: dense multi-view stereo on a COLMAP dense workspace.

use std::io::Write;
use std::path::{Path, PathBuf};

use anyhow::{Context, Result};
use clap::{Args, Subcommand};
use vp_mvs::{
    reconstruct_image_sets, reconstruct_workspace, Algorithm, ImageSet, ImageSetsRequest,
    MvsParams, RunOptions, WorkspaceRequest,
};

/// MVS subcommands.
#[derive(Debug, Subcommand)]
pub enum MvsCommand {
    /// Reconstruct a COLMAP dense workspace (as `colmap image_undistorter`
    /// writes it): every image against its best source images, then the
    /// geometric filter and fusion. Writes `stereo/depth_maps`,
    /// `stereo/normal_maps` (`.photometric.bin`, `.geometric.bin`) and
    /// `fused.ply` in COLMAP's formats. Progress on stderr.
    Run(RunArgs),
    /// Print the default parameters as a commented TOML config (PatchMatch's
    /// and, in its `[sgm]` table, the semi-global matcher's).
    Defaults,
}

/// Arguments of `vpctl mvs run`.
#[derive(Debug, Args)]
pub struct RunArgs {
    /// The dense workspace: `images/`, `sparse/`, optionally
    /// `stereo/patch-match.cfg`.
    #[arg(long)]
    workspace: PathBuf,
    /// Reconstruct only these images (comma-separated names under `images/`),
    /// each against sources among them.
    #[arg(long, value_delimiter = ',')]
    images: Option<Vec<String>>,
    /// Depth range MIN,MAX (metres along the optical axis) for every image;
    /// needed when the model has no 3D points.
    #[arg(long, value_parser = parse_range, allow_hyphen_values = true)]
    depth_range: Option<(f64, f64)>,
    /// Parameters (TOML, see `vpctl mvs defaults`).
    #[arg(long)]
    config: Option<PathBuf>,
    /// Seed of every random choice (overrides the config's).
    #[arg(long)]
    seed: Option<u64>,
    /// Dense matcher: slanted-plane PatchMatch, or semi-global matching on
    /// rectified pairs (its parameters: the config's `[sgm]` table).
    /// Overrides the config's `algorithm`.
    #[arg(long, value_parser = parse_algorithm)]
    algorithm: Option<Algorithm>,
    /// Reconstruct each triplet of this list (written by `vpctl labelgen
    /// triplets`) on its own instead of the whole workspace; needs --out.
    #[arg(long, requires = "out")]
    triplets: Option<PathBuf>,
    /// Pyramid levels of the triplet reconstructions (1 = full size).
    #[arg(long, value_delimiter = ',', default_value = "1")]
    levels: Vec<u32>,
    /// With --triplets: the depth folder `vpctl labelgen run --depth-dir`
    /// reads, one `<triplet id>/level<L>/` per triplet and level.
    #[arg(long)]
    out: Option<PathBuf>,
    /// Overwrite an existing `fused.ply` (or replace an earlier --out
    /// output: only the files vpctl wrote there; other files stay).
    #[arg(long)]
    force: bool,
}

fn parse_algorithm(s: &str) -> std::result::Result<Algorithm, String> {
    match s {
        "patchmatch" => Ok(Algorithm::PatchMatch),
        "sgm" => Ok(Algorithm::Sgm),
        _ => Err(format!("'{s}' is not a matcher (patchmatch, sgm)")),
    }
}

fn parse_range(s: &str) -> std::result::Result<(f64, f64), String> {
    let (a, b) = s
        .split_once(',')
        .ok_or_else(|| format!("'{s}' is not MIN,MAX"))?;
    let p = |v: &str| {
        v.trim()
            .parse::<f64>()
            .map_err(|e| format!("'{v}' in '{s}': {e}"))
    };
    Ok((p(a)?, p(b)?))
}

pub fn run(cmd: MvsCommand, out: &mut dyn Write) -> Result<()> {
    match cmd {
        MvsCommand::Defaults => {
            write!(out, "{}", MvsParams::defaults_toml())?;
            Ok(())
        }
        MvsCommand::Run(args) => {
            let mut params = match &args.config {
                Some(path) => {
                    let text = std::fs::read_to_string(path)
                        .with_context(|| format!("{}: cannot read config", path.display()))?;
                    MvsParams::from_toml(&text, path)?
                }
                None => MvsParams::default(),
            };
            if let Some(seed) = args.seed {
                params.seed = seed;
            }
            if let Some(algorithm) = args.algorithm {
                params.algorithm = algorithm;
            }
            if let (Some(list), Some(out_dir)) = (&args.triplets, &args.out) {
                return run_triplets(&args, list, out_dir, params, out);
            }
            let mut req = WorkspaceRequest::new(&args.workspace);
            req.options = RunOptions {
                images: args.images,
                depth_range: args.depth_range,
                params,
            };
            req.force = args.force;
            let start = std::time::Instant::now();
            let summary = {
                let progress = super::Progress::new();
                reconstruct_workspace(&req, &mut |line| progress.message(line))?
            };
            for (name, share) in summary
                .reconstructed
                .iter()
                .zip(&summary.geometric_valid_share)
            {
                writeln!(
                    out,
                    "{name}: {:.1}% of pixels with a geometric depth",
                    100.0 * share
                )?;
            }
            writeln!(
                out,
                "fused: {} points -> {}",
                summary.fused_points,
                summary.fused_path.display()
            )?;
            writeln!(out, "time: {:.1} s", start.elapsed().as_secs_f64())?;
            Ok(())
        }
    }
}

/// `mvs run --triplets`: every triplet at every level, into the layout
/// labelgen reads ([`reconstruct_image_sets`]).
fn run_triplets(
    args: &RunArgs,
    list: &Path,
    out_dir: &Path,
    params: MvsParams,
    out: &mut dyn Write,
) -> Result<()> {
    let sets = vp_labelgen::triplets::read_image_sets(list)?;
    let mut req = ImageSetsRequest::new(
        &args.workspace,
        sets.into_iter().map(ImageSet::from).collect(),
        out_dir,
    );
    req.list = Some(list.to_path_buf());
    req.levels.clone_from(&args.levels);
    req.depth_range = args.depth_range;
    req.params = params;
    req.inputs.extend(args.config.clone());
    req.force = args.force;
    let start = std::time::Instant::now();
    let shares = {
        let progress = super::Progress::new();
        reconstruct_image_sets(&req, &mut |line| progress.message(line))?
    };
    for set in &req.sets {
        for level in &req.levels {
            let Some(s) = shares.get(&set.id).and_then(|m| m.get(level)) else {
                continue;
            };
            let mean = s.iter().sum::<f64>() / s.len().max(1) as f64;
            writeln!(
                out,
                "{} level{level}: {:.1}% of pixels with a geometric depth",
                set.id,
                100.0 * mean
            )?;
        }
    }
    writeln!(out, "triplets: {} -> {}", req.sets.len(), out_dir.display())?;
    writeln!(out, "time: {:.1} s", start.elapsed().as_secs_f64())?;
    Ok(())
}
