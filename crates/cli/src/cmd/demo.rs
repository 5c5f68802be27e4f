//! `vpctl demo` and `vpctl sim run|config`: closed-loop campaigns in the
//! simulated world (vp-sim's `campaign`), printing the paper's Table 1.

use std::io::Write;
use std::path::{Path, PathBuf};
use std::time::Instant;

use anyhow::{Context, Result};
use clap::Args;
use vp_forest::Forest;
use vp_scene::outdir::OutDir;
use vp_sim::campaign::{
    run_campaign_with_forest, train_campaign_forest, write_report, CampaignConfig,
};

/// Arguments shared by `demo` and `sim run`.
#[derive(Debug, Args)]
pub struct CampaignArgs {
    /// Report directory (table.md, table.csv, report.json, plots, plans, .plan missions).
    #[arg(long, default_value = "vpctl-report")]
    pub out: PathBuf,
    /// Replace an earlier report in --out (only the files vpctl wrote there;
    /// other files stay) and overwrite --save-forest.
    #[arg(long)]
    pub force: bool,
    /// Use this trained forest instead of running the training campaign.
    #[arg(long = "forest", alias = "model", value_name = "FILE")]
    pub model: Option<PathBuf>,
    /// Save the trained forest here (for a later --forest).
    #[arg(long = "save-forest", alias = "save-model", value_name = "FILE")]
    pub save_model: Option<PathBuf>,
}

/// `vpctl demo`: trains on small procedural sites, flies a held-out site
/// with F, NP and Grid strategies, prints the table and writes the report.
#[derive(Debug, Args)]
pub struct DemoArgs {
    #[command(flatten)]
    pub common: CampaignArgs,
    /// A much smaller campaign (seconds, for smoke tests): tiny sites, one
    /// strategy iteration, coarse evaluation.
    #[arg(long)]
    pub quick: bool,
}

/// Runs `cfg`: trains (or loads `--forest`), flies, prints the table, writes
/// the report. `command` ("demo", "sim run") and `inputs` (the files it
/// read) are for the output folder's checks.
pub fn run_config(
    cfg: &CampaignConfig,
    args: &CampaignArgs,
    command: &str,
    inputs: &[&Path],
    out: &mut dyn Write,
) -> Result<()> {
    // Refuse before hours of work, not after.
    let mut inputs = inputs.to_vec();
    inputs.extend(args.model.as_deref());
    let report_dir = OutDir::check(&args.out, command, &inputs, args.force)?;
    if let Some(p) = &args.save_model {
        vp_scene::fsio::check_output_file(p, args.force)?;
    }
    let t0 = Instant::now();
    let progress = super::Progress::new();
    let mut say = |m: &str| progress.message(m);
    let (forest, training) = if let Some(p) = &args.model {
        say(&format!("loading the forest {}", p.display()));
        (load_model(p)?, None)
    } else {
        let (forest, stats) = train_campaign_forest(cfg, &mut say)?;
        (forest, Some(stats))
    };
    // Saved before the flights: a campaign that fails hours later keeps
    // its trained forest for a rerun with --forest.
    if let Some(p) = &args.save_model {
        forest
            .save(p)
            .with_context(|| format!("saving the forest to {}", p.display()))?;
        say(&format!(
            "forest saved to {} (fingerprint {:016x})",
            p.display(),
            forest.fingerprint()
        ));
    }
    let mut report = run_campaign_with_forest(cfg, &forest, &mut say)?;
    report.training = training;
    write_report(&report, &report_dir)?;
    progress.finish();
    if cfg.held_out_seeds.len() == 1 {
        writeln!(
            out,
            "Table 1 (percent; held-out site {}):\n",
            cfg.held_out_seeds[0]
        )?;
    } else {
        writeln!(
            out,
            "Table 1 (percent; mean ± std over held-out sites {:?}):\n",
            cfg.held_out_seeds
        )?;
    }
    write!(out, "{}", report.table_markdown())?;
    for c in vp_sim::campaign::f_vs_np::comparisons(&report) {
        writeln!(out, "\n{}", c.line())?;
    }
    writeln!(
        out,
        "\nLearned confidence vs vp-mvs's measured success (rank correlation over angle bins):"
    )?;
    write!(out, "{}", report.curves_summary())?;
    if let Some(t) = &report.training {
        writeln!(
            out,
            "\nLabel quality (labelgen on the MVS output against the renderer's truth):\n"
        )?;
        write!(out, "{}", t.label_quality.markdown())?;
    }
    writeln!(
        out,
        "\nReport written to {} in {:.0} s.",
        args.out.display(),
        t0.elapsed().as_secs_f64()
    )?;
    Ok(())
}

fn load_model(p: &Path) -> Result<Forest> {
    Ok(Forest::load(p)?)
}

/// `vpctl demo`.
pub fn run_demo(args: &DemoArgs, out: &mut dyn Write) -> Result<()> {
    let cfg = if args.quick {
        CampaignConfig::quick()
    } else {
        CampaignConfig::demo()
    };
    run_config(&cfg, &args.common, "demo", &[], out)
}
