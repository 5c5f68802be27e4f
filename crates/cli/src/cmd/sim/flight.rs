//! `vpctl sim fly` and `vpctl sim train`: a simulated flight written as
//! images and a COLMAP model, and the training campaign's forest.

use std::io::Write;
use std::path::Path;

use anyhow::{Context, Result};
use vp_scene::fsio;
use vp_sim::flight::{write_flight, FlightRequest};

/// `vpctl sim fly`.
pub(super) fn fly(req: &FlightRequest, out: &mut dyn Write) -> Result<()> {
    let progress = crate::cmd::Progress::new();
    let s = write_flight(req, &mut |m| progress.message(m))?;
    progress.finish();
    writeln!(
        out,
        "wrote {} images to {}",
        s.images,
        s.images_dir.display()
    )?;
    writeln!(
        out,
        "wrote {} ({} images, {} sparse points seen by >= {} images, {} poses)",
        s.sparse_dir.display(),
        s.images,
        s.points,
        s.min_views,
        if req.options.exact { "exact" } else { "noisy" }
    )?;
    if s.points == 0 {
        eprintln!(
            "warning: no surface point is seen by two images: `vpctl plan` will have nothing \
             to plan on; fly with more overlap (plan grid --overlap)"
        );
    }
    Ok(())
}

/// `vpctl sim train`.
pub(super) fn train(config: &Path, path: &Path, force: bool, out: &mut dyn Write) -> Result<()> {
    fsio::check_output_file(path, force)?;
    let cfg = vp_sim::campaign::CampaignConfig::load(config)?;
    let mut curves =
        vp_sim::campaign::curves::CurveAccumulator::new(cfg.training.forest.bins.clone());
    let progress = crate::cmd::Progress::new();
    let (forest, stats) = vp_sim::campaign::train_forest_with_stats(&cfg, &mut curves, &mut |m| {
        progress.message(m);
    })?;
    progress.finish();
    forest
        .save(path)
        .with_context(|| format!("saving the forest to {}", path.display()))?;
    writeln!(
        out,
        "wrote {} (forest fingerprint {:016x})",
        path.display(),
        forest.fingerprint()
    )?;
    writeln!(
        out,
        "training: {} sites, {} triplets ({} with output), {} positive and {} negative \
                 pixels",
        stats.sites, stats.triplets, stats.successful_triplets, stats.positives, stats.negatives
    )?;
    if stats.positives == 0 || stats.negatives == 0 {
        eprintln!(
            "warning: the training labels hold only one class: the forest predicts a \
                     constant; add training sites or triplets ([training] in the config)"
        );
    }
    Ok(())
}
