//! `vp-labelgen`: training labels for MVS confidence prediction without
//! ground truth, after Section 2.1 of Mostegel et al. (and Mostegel et al.
//! 2016), as docs/design.md#training-labels-labelgen describes it.
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
#![warn(missing_docs, unreachable_pub)]
// A library tells its caller (returned warnings, reports, progress callbacks);
// only the CLI and the Python bindings print (docs/design.md).
#![deny(clippy::print_stderr, clippy::print_stdout)]

pub mod error;
pub mod io;
pub mod job;
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
pub use job::{
    load_label_run, run_labelling, run_labelling_with_progress, LabelOutput, LabelRun,
    LabelRunRequest,
};
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
    let all: Vec<usize> = (0..sorted.len()).collect();
    let supports = stage1(&prepared, &refs, &all, params);
    Ok(stage2(
        &sorted, &prepared, &refs, &supports, &all, meshes, params,
    ))
}

/// Stage 1 for the views of `chosen`: three support maps each, in order.
fn stage1(
    prepared: &[Prepared<'_>],
    refs: &[Vec<usize>],
    chosen: &[usize],
    params: &LabelParams,
) -> Vec<[Vec<u16>; 3]> {
    let tasks: Vec<(usize, usize)> = chosen
        .iter()
        .flat_map(|&q| (0..3).map(move |v| (q, v)))
        .collect();
    let flat: Vec<Vec<u16>> = tasks
        .par_iter()
        .map(|&(q, v)| support::view_support(prepared, q, v, &refs[q], params))
        .collect();
    regroup(flat)
}

/// Stages 2 and 3 for `chosen`, given the support of every reconstruction
/// (indexed as `prepared`; only the references' are read).
fn stage2(
    sorted: &[&TripletReconstruction],
    prepared: &[Prepared<'_>],
    refs: &[Vec<usize>],
    supports: &[[Vec<u16>; 3]],
    chosen: &[usize],
    meshes: Option<&MissingPartMeshes>,
    params: &LabelParams,
) -> Vec<ReconLabels> {
    let tasks: Vec<(usize, usize)> = chosen
        .iter()
        .flat_map(|&q| (0..3).map(move |v| (q, v)))
        .collect();
    let flat: Vec<(LabelImage, ViewCounts)> = tasks
        .par_iter()
        .map(|&(q, v)| voting::label_view(prepared, supports, q, v, &refs[q], meshes, params))
        .collect();
    regroup(flat)
        .into_iter()
        .zip(chosen.iter().map(|&q| sorted[q]))
        .map(|(views, rec)| {
            let [(l0, c0), (l1, c1), (l2, c2)] = views;
            ReconLabels {
                id: rec.id.clone(),
                names: rec.views.clone().map(|v| v.name),
                labels: [l0, l1, l2],
                counts: [c0, c1, c2],
            }
        })
        .collect()
}

/// Stage 1 for the reconstructions named in `queries` only: the support
/// maps of their views (as [`support_maps`]), in id order. With
/// [`labels_for`], label generation splits into independent tasks over
/// chunks of queries (e.g. on separate machines): every task needs every
/// reconstruction (the references), and all stage-1 tasks must finish
/// before the stage-2 tasks that read their support.
pub fn support_for(
    recs: &[TripletReconstruction],
    queries: &[String],
    params: &LabelParams,
) -> Result<Vec<(String, [Vec<u16>; 3])>> {
    let (sorted, prepared, refs) = prepare(recs, params)?;
    let chosen = select(&sorted, queries)?;
    let maps = stage1(&prepared, &refs, &chosen, params);
    Ok(chosen
        .iter()
        .map(|&q| sorted[q].id.clone())
        .zip(maps)
        .collect())
}

/// Stages 2 and 3 for the reconstructions named in `queries`, in id order,
/// given the stage-1 support ([`support_for`]) of at least every
/// reconstruction that references them; the same labels as
/// [`generate_labels`] gives those queries.
pub fn labels_for(
    recs: &[TripletReconstruction],
    supports: &[(String, [Vec<u16>; 3])],
    queries: &[String],
    meshes: Option<&MissingPartMeshes>,
    params: &LabelParams,
) -> Result<Vec<ReconLabels>> {
    let (sorted, prepared, refs) = prepare(recs, params)?;
    let chosen = select(&sorted, queries)?;
    let mut by_index: Vec<[Vec<u16>; 3]> = vec![[Vec::new(), Vec::new(), Vec::new()]; sorted.len()];
    let mut given = vec![false; sorted.len()];
    for (id, maps) in supports {
        let Ok(i) = sorted.binary_search_by(|r| r.id.as_str().cmp(id)) else {
            return Err(LabelgenError::InvalidArgument(format!(
                "support given for reconstruction {id}, which is not among the reconstructions"
            )));
        };
        for (v, m) in maps.iter().enumerate() {
            let n = sorted[i].views[v].depth.data.len();
            if m.len() != n {
                return Err(LabelgenError::InvalidArgument(format!(
                    "support of {id} view {v}: {} values for a depth map of {n} pixels",
                    m.len()
                )));
            }
        }
        by_index[i].clone_from(maps);
        given[i] = true;
    }
    for &q in &chosen {
        if let Some(&r) = refs[q].iter().find(|&&r| !given[r]) {
            return Err(LabelgenError::InvalidArgument(format!(
                "labelling {} needs the stage-1 support of its reference {}, which was not given",
                sorted[q].id, sorted[r].id
            )));
        }
    }
    Ok(stage2(
        &sorted, &prepared, &refs, &by_index, &chosen, meshes, params,
    ))
}

/// The references of every reconstruction (ids, id order): whose stage-1
/// support [`labels_for`] needs to label it.
pub fn references_of(
    recs: &[TripletReconstruction],
    params: &LabelParams,
) -> Result<Vec<(String, Vec<String>)>> {
    let (sorted, _, refs) = prepare(recs, params)?;
    Ok(sorted
        .iter()
        .zip(&refs)
        .map(|(r, q)| {
            (
                r.id.clone(),
                q.iter().map(|&i| sorted[i].id.clone()).collect(),
            )
        })
        .collect())
}

/// Indices (into the id-sorted reconstructions) of `queries`, in id order;
/// an unknown or repeated id is an error.
fn select(sorted: &[&TripletReconstruction], queries: &[String]) -> Result<Vec<usize>> {
    let mut chosen = Vec::with_capacity(queries.len());
    for id in queries {
        let i = sorted
            .binary_search_by(|r| r.id.as_str().cmp(id))
            .map_err(|_| {
                LabelgenError::InvalidArgument(format!(
                    "query {id} is not among the reconstructions"
                ))
            })?;
        chosen.push(i);
    }
    chosen.sort_unstable();
    if let Some(w) = chosen.windows(2).find(|w| w[0] == w[1]) {
        return Err(LabelgenError::InvalidArgument(format!(
            "query {} given twice",
            sorted[w[0]].id
        )));
    }
    Ok(chosen)
}

/// Stage 1 alone: the support of every measurement of every view (0 where
/// there is no measurement), per reconstruction id, in id order. Useful to
/// inspect why a pixel got no label.
pub fn support_maps(
    recs: &[TripletReconstruction],
    params: &LabelParams,
) -> Result<Vec<(String, [Vec<u16>; 3])>> {
    let ids: Vec<String> = recs.iter().map(|r| r.id.clone()).collect();
    support_for(recs, &ids, params)
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
