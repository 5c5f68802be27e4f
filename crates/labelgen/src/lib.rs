//! `vp-labelgen`: training labels for MVS confidence prediction without
//! ground truth, after Section 2.1 of Mostegel et al. (and Mostegel et al.
//! 2016), as made precise in DESIGN.md "Training labels (labelgen)".
//!
//! - [`triplets`]: sample image triplets from triangulation-angle bins
//!   (edges 4, 8, 16, 32, 64, 128 deg) with enough overlap, near-equilateral;
//!   write the triplet list and COLMAP image lists.
//! - [`measurement`]: per depthmap pixel a 3D point, its triangulation angle
//!   and its first-order 3D uncertainty under the triplet's cameras.
//! - [`support`] (stage 1), [`voting`] (stage 2), [`missing`] (stage 3):
//!   consistency voting between independent reconstructions.
//! - [`io`]: the depth-map directory layout, label and summary files.
//!
//! The entry point is [`generate_labels`]: reconstructions in, one
//! [`LabelImage`](vp_scene::raster::LabelImage) per view out. Every triplet at
//! every pyramid level is an independent [`TripletReconstruction`].
#![warn(missing_docs)]

pub mod error;
pub mod io;
pub mod measurement;
pub mod missing;
pub mod params;
pub mod summary;
pub mod support;
pub mod synthetic;
pub mod triplets;
pub mod voting;

use std::collections::BTreeSet;

use rayon::prelude::*;
use vp_scene::raster::LabelImage;

pub use error::{LabelgenError, Result};
pub use measurement::{TripletReconstruction, View};
pub use missing::MissingPartMeshes;
pub use params::LabelParams;
pub use summary::LabelSummary;
pub use voting::ViewCounts;

use measurement::Prepared;

/// The labels of one reconstruction: one image per view.
#[derive(Debug, Clone)]
pub struct ReconLabels {
    /// The reconstruction's id.
    pub id: String,
    /// Image names of the three views.
    pub names: [String; 3],
    /// Label image per view (at the depthmap's resolution).
    pub labels: [LabelImage; 3],
    /// Counts per view.
    pub counts: [ViewCounts; 3],
}

/// Runs the three stages over `recs` and returns the labels of every view,
/// in id order. `meshes` enables stage 3 (missing parts); without them holes
/// stay unlabelled.
///
/// References of a query are the reconstructions that share no image with
/// it and whose measurements can overlap it in space; they are visited in id
/// order, so the output does not depend on the order of `recs`.
///
/// # Performance
/// Per query view and reference: one z-buffer splat of the reference's
/// measurements (O(reference pixels)) and one pass over the query pixels with
/// three projections each; parallel over views with rayon. Time grows with
/// the number of overlapping references per triplet. Memory: every depthmap
/// is held (4 bytes per pixel) plus 10 bytes per pixel of derived data
/// (uncertainty, angle, support); depthmaps are not streamed from disk.
pub fn generate_labels(
    recs: &[TripletReconstruction],
    meshes: Option<&MissingPartMeshes>,
    params: &LabelParams,
) -> Result<Vec<ReconLabels>> {
    let (sorted, prepared, refs) = prepare(recs, params)?;
    let tasks: Vec<(usize, usize)> = (0..prepared.len())
        .flat_map(|q| (0..3).map(move |v| (q, v)))
        .collect();
    let flat: Vec<Vec<u16>> = tasks
        .par_iter()
        .map(|&(q, v)| support::view_support(&prepared, q, v, &refs[q], params))
        .collect();
    let supports = regroup(flat);
    let flat: Vec<(LabelImage, ViewCounts)> = tasks
        .par_iter()
        .map(|&(q, v)| voting::label_view(&prepared, &supports, q, v, &refs[q], meshes, params))
        .collect();
    Ok(regroup(flat)
        .into_iter()
        .zip(&sorted)
        .map(|(views, rec)| {
            let [(l0, c0), (l1, c1), (l2, c2)] = views;
            ReconLabels {
                id: rec.id.clone(),
                names: rec.views.clone().map(|v| v.name),
                labels: [l0, l1, l2],
                counts: [c0, c1, c2],
            }
        })
        .collect())
}

/// Stage 1 alone: the support of every measurement of every view (0 where
/// there is no measurement), per reconstruction id, in id order. Useful to
/// inspect why a pixel got no label.
pub fn support_maps(
    recs: &[TripletReconstruction],
    params: &LabelParams,
) -> Result<Vec<(String, [Vec<u16>; 3])>> {
    let (sorted, prepared, refs) = prepare(recs, params)?;
    let flat: Vec<Vec<u16>> = (0..prepared.len() * 3)
        .into_par_iter()
        .map(|t| support::view_support(&prepared, t / 3, t % 3, &refs[t / 3], params))
        .collect();
    Ok(sorted
        .iter()
        .map(|r| r.id.clone())
        .zip(regroup(flat))
        .collect())
}

type PreparedSet<'a> = (
    Vec<&'a TripletReconstruction>,
    Vec<Prepared<'a>>,
    Vec<Vec<usize>>,
);

/// Validates, sorts by id, derives the per-measurement data and lists the
/// references of each reconstruction.
fn prepare<'a>(recs: &'a [TripletReconstruction], params: &LabelParams) -> Result<PreparedSet<'a>> {
    params.validate()?;
    let mut ids = BTreeSet::new();
    for r in recs {
        r.validate()?;
        if !ids.insert(r.id.as_str()) {
            return Err(LabelgenError::InvalidArgument(format!(
                "reconstruction id {} given twice",
                r.id
            )));
        }
    }
    let mut sorted: Vec<&TripletReconstruction> = recs.iter().collect();
    sorted.sort_by(|a, b| a.id.cmp(&b.id));
    let prepared: Vec<Prepared<'_>> = sorted
        .par_iter()
        .map(|r| Prepared::new(r, params))
        .collect();
    let refs: Vec<Vec<usize>> = (0..prepared.len())
        .map(|q| references(&prepared, q))
        .collect();
    Ok((sorted, prepared, refs))
}

/// Independent reconstructions that may overlap `q`, in id order.
fn references(prepared: &[Prepared<'_>], q: usize) -> Vec<usize> {
    let qp = &prepared[q];
    let margin = 0.01 * qp.bounds.extent().norm();
    (0..prepared.len())
        .filter(|&r| {
            r != q && qp.rec.independent_of(prepared[r].rec) && qp.may_overlap(&prepared[r], margin)
        })
        .collect()
}

/// Groups a flat per-view list (three per reconstruction) into triples.
fn regroup<T>(flat: Vec<T>) -> Vec<[T; 3]> {
    let mut out = Vec::with_capacity(flat.len() / 3);
    let mut it = flat.into_iter();
    while let (Some(a), Some(b), Some(c)) = (it.next(), it.next(), it.next()) {
        out.push([a, b, c]);
    }
    out
}
