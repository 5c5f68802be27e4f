//! `vpctl sim ...`: the simulated world (rendering of procedural sites;
//! `run` and `config` of closed-loop campaigns live in [`super::demo`]).

use std::io::Write;
use std::path::PathBuf;

use anyhow::Result;
use clap::Subcommand;
use vp_sim::flight::{FlightRequest, FlyOptions};

mod flight;
mod render;

pub use render::RenderArgs;

/// Simulation subcommands.
#[derive(Debug, Subcommand)]
pub enum SimCommand {
    /// Render an image of a procedural site (textured per material, sun-lit)
    /// from a pinhole camera; optionally write its exact depth as a COLMAP
    /// depth map. The same arguments give a byte-identical image.
    Render(RenderArgs),
    /// Run a full closed-loop campaign from a TOML config (training sites,
    /// held-out sites, strategies, evaluation): prints the paper's Table 1
    /// and writes the report directory. `sim config --defaults` prints a
    /// complete config to start from.
    Run {
        /// Campaign configuration (TOML); missing keys take the demo's values.
        #[arg(long)]
        config: PathBuf,
        #[command(flatten)]
        common: super::demo::CampaignArgs,
    },
    /// Fly plans in the simulated world: render each waypoint's image over
    /// the site of a campaign config and write the images with the COLMAP
    /// model SfM would give (PINHOLE cameras, poses with the config's SfM
    /// noise or exact, sparse points: surface points seen by at least
    /// `sfm.min_views` images, with their tracks) and its `frame.json`
    /// (the site's geodetic origin), ready for `vpctl predict` and `vpctl
    /// plan --colmap DIR/sparse`. Several plans fly one after the other
    /// into one model (the acquired images so far).
    ///
    /// Writes DIR/images/<plan stem>_<index>.png and DIR/sparse/.
    #[command(after_help = "Example: vpctl sim fly grid.json --site site.toml --out flight1")]
    Fly {
        /// Plan files (JSON from `vpctl plan` or `vpctl plan grid`), flown in order.
        #[arg(required = true)]
        plans: Vec<PathBuf>,
        /// Campaign config (TOML) whose `[site]`, `[render]`, `[sfm]` and
        /// `[planner.camera]` sections describe the world and the camera
        /// (`vpctl sim config > site.toml`); missing `[site]` keys take the
        /// site's defaults (the mesh `scene generate --config` writes), other
        /// missing keys the demo's values.
        #[arg(long, visible_alias = "config")]
        site: PathBuf,
        /// Output directory (images/, sparse/).
        #[arg(long)]
        out: PathBuf,
        /// Exact poses and points (no SfM noise).
        #[arg(long)]
        exact: bool,
        /// Model encoding, as COLMAP's `--output_type`: txt or bin.
        #[arg(long, default_value = "txt", value_parser = ["txt", "bin"])]
        output_type: String,
        /// Largest number of sparse points.
        #[arg(long, default_value_t = 20_000)]
        max_points: usize,
        /// Replace an earlier `sim fly` output in --out (only the files
        /// vpctl wrote there; other files stay).
        #[arg(long)]
        force: bool,
    },
    /// Run only the training campaign of a config (training sites, random
    /// triplets reconstructed by vp-mvs, labelgen labels) and save the
    /// trained confidence forest, for `vpctl predict --forest`.
    Train {
        /// Campaign configuration (TOML); missing keys take the demo's values.
        #[arg(long)]
        config: PathBuf,
        /// The forest file to write (.vpforest).
        #[arg(long)]
        out: PathBuf,
        /// Overwrite the output if it exists.
        #[arg(long)]
        force: bool,
    },
    /// Leave-one-site-out evaluation of the confidence forest: flies and
    /// labels every training site of the config as `sim train` does, then
    /// for each site trains on the others and scores the site's labelled
    /// pixels at their own angle. Writes DIR/forest_eval.csv (one row per
    /// fold, material and angle bin: accuracy against the labels and the
    /// truth, Brier score and the angle-only baseline's) and
    /// DIR/summary.txt, and prints the summary.
    #[command(after_help = "Example: vpctl sim config --preset quick > q.toml && \
                            vpctl sim evaluate --config q.toml --out eval")]
    Evaluate {
        /// Campaign configuration (TOML); `[training] site_seeds` are the folds.
        #[arg(long)]
        config: PathBuf,
        /// Forest sizes to compare on the same labels and folds, TREESxDEPTH
        /// (e.g. 20x20,10x16,4x14); default: the config's `[training.forest]`.
        #[arg(long, value_delimiter = ',', value_parser = parse_size)]
        sizes: Vec<(usize, usize)>,
        /// A second config, the other matcher on the same training sites:
        /// evaluated too (DIR/versus/), and each matcher's fold forests
        /// score the other's labels (DIR/cross.csv; issue 35's H2).
        #[arg(long)]
        versus: Option<PathBuf>,
        /// Output directory.
        #[arg(long)]
        out: PathBuf,
        /// Replace an earlier `sim evaluate` output in --out (only the
        /// files vpctl wrote there).
        #[arg(long)]
        force: bool,
    },
    /// The two-matcher experiment's hypotheses H3-H6 (issue 35) from two
    /// `sim run` report folders of the same held-out sites, one flown with
    /// `mvs = "sgm"`, one with `mvs = "patchmatch"`: prints a per-site
    /// table and each hypothesis as holding or not, with its figures. With
    /// several forest draws per matcher (the flag once per draw), prints
    /// H3 and H4 over the draws, the bootstrap resampling sites and draws.
    #[command(
        after_help = "Examples:\n  vpctl sim compare --sgm camp-sgm --patchmatch camp-pm\n  \
                            vpctl sim compare --sgm fly-sgm-s2 --sgm fly-sgm-s3 \
                            --patchmatch fly-pm-s2 --patchmatch fly-pm-s3"
    )]
    Compare {
        /// Report folder of an SGM campaign; several, comma-separated, for
        /// batches of held-out sites flown with one saved forest (`sim
        /// train`, then `sim run --forest` per batch). Repeat the flag for
        /// each forest draw (another training of the same sites, flown on
        /// the same held-out sites).
        #[arg(long, required = true)]
        sgm: Vec<String>,
        /// Report folder(s) of a PatchMatch campaign, as --sgm.
        #[arg(long, required = true)]
        patchmatch: Vec<String>,
        /// The F strategy compared with its NP twin.
        #[arg(long, default_value = "F5x4")]
        strategy: String,
        /// Seed of the bootstrap interval.
        #[arg(long, default_value_t = 0)]
        seed: u64,
    },
    /// Print a complete campaign configuration (TOML, every key written out).
    Config {
        /// Which preset: demo (what `vpctl demo` runs), quick (seconds) or
        /// paper (three held-out sites, F5x4, F1x20, NP5x4).
        #[arg(long, default_value = "demo")]
        preset: String,
        /// The paper preset (same as `--preset paper`).
        #[arg(long, conflicts_with = "preset")]
        paper: bool,
    },
}

/// Parses a forest size "TREESxDEPTH" ("20x20").
fn parse_size(s: &str) -> Result<(usize, usize), String> {
    s.split_once(['x', 'X'])
        .and_then(|(t, d)| Some((t.trim().parse().ok()?, d.trim().parse().ok()?)))
        .filter(|&(t, d)| t > 0 && d > 0)
        .ok_or_else(|| format!("{s:?}: expected TREESxDEPTH with both > 0, e.g. 20x20"))
}

/// Parses "x,y,z" into three finite numbers.
pub(super) fn parse_point(s: &str) -> Result<[f64; 3], String> {
    let parts: Vec<&str> = s.split(',').map(str::trim).collect();
    let [x, y, z] = parts.as_slice() else {
        return Err(format!(
            "'{s}' is not x,y,z (three comma-separated numbers)"
        ));
    };
    let num = |t: &str| {
        t.parse::<f64>()
            .ok()
            .filter(|v| v.is_finite())
            .ok_or_else(|| format!("'{t}' in '{s}' is not a finite number"))
    };
    Ok([num(x)?, num(y)?, num(z)?])
}

pub fn run(cmd: SimCommand, out: &mut dyn Write) -> Result<()> {
    match cmd {
        SimCommand::Fly {
            plans,
            site,
            out: dir,
            exact,
            output_type,
            max_points,
            force,
        } => {
            let mut req = FlightRequest::new(plans, site, dir);
            req.options = FlyOptions { exact, max_points };
            req.binary = output_type == "bin";
            req.force = force;
            flight::fly(&req, out)
        }
        SimCommand::Train {
            config,
            out: path,
            force,
        } => flight::train(&config, &path, force, out),
        SimCommand::Run { config, common } => {
            let cfg = vp_sim::campaign::CampaignConfig::load(&config)?;
            super::demo::run_config(&cfg, &common, "sim run", &[&config], out)
        }
        SimCommand::Evaluate {
            config,
            versus,
            sizes,
            out: dir,
            force,
        } => {
            let t0 = std::time::Instant::now();
            let mut say = |m: &str| eprintln!("[{:6.1} s] {m}", t0.elapsed().as_secs_f64());
            let summary = vp_sim::campaign::evaluate_to_dir(
                &config,
                versus.as_deref(),
                &sizes,
                (&dir, force),
                &mut say,
            )?;
            writeln!(out, "{summary}")?;
            writeln!(out, "wrote {}", dir.join("forest_eval.csv").display())?;
            Ok(())
        }
        SimCommand::Compare {
            sgm,
            patchmatch,
            strategy,
            seed,
        } => {
            // One flag per draw; a draw's batches comma-separated.
            let draws = |flags: &[String]| -> Vec<Vec<PathBuf>> {
                flags
                    .iter()
                    .map(|f| f.split(',').map(PathBuf::from).collect())
                    .collect()
            };
            let text = vp_sim::campaign::report::two_matchers::compare_dirs(
                (&draws(&sgm)[..], &draws(&patchmatch)[..]),
                &strategy,
                seed,
            )?;
            write!(out, "{text}")?;
            Ok(())
        }
        SimCommand::Config { preset, paper } => {
            let name = if paper { "paper" } else { preset.as_str() };
            let cfg = vp_sim::campaign::CampaignConfig::preset(name)?;
            write!(out, "{}", cfg.to_toml()?)?;
            Ok(())
        }
        SimCommand::Render(a) => render::render_site(&a, out),
    }
}
