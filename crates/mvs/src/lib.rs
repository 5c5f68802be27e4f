//! `vp-mvs`: PatchMatch multi-view stereo on the CPU.
//!
//! Per reference image, PatchMatch ([`patch_match`]) estimates a depth and a
//! normal per pixel: random planes inside the depth range, red-black
//! checkerboard propagation of the neighbours' planes and random refinement,
//! scored by bilaterally weighted NCC through the plane-induced homography
//! into each source image with a best-k view selection. The geometric filter
//! ([`geometric_filter`]) keeps depths that the sources' depth maps confirm
//! by forward-backward reprojection under a minimum triangulation angle;
//! [`fuse`] merges the filtered maps into a point cloud with normals and
//! colours.
//!
//! [`sgm`] is the other matcher: semi-global matching on rectified pairs
//! with a multi-baseline fusion per reference ([`semi_global`]), chosen
//! with [`MvsParams::algorithm`]; its maps go through the same geometric
//! filter and fusion.
//!
//! [`reconstruct`] runs the three on views in memory; [`run_workspace`]
//! reads a COLMAP dense workspace and writes COLMAP's layout and formats
//! (`stereo/depth_maps`, `stereo/normal_maps`, `fused.ply`), so that vpctl,
//! COLMAP and OpenMVS users read the same files. [`MvsParams`] holds every
//! parameter with documented defaults. [`job`] holds the front doors the CLI
//! and Python both call: [`reconstruct_workspace`] and
//! [`reconstruct_image_sets`] (labelgen's triplets at pyramid levels).
//!
//! Every random choice comes from a hash of (seed, view, pixel, step): the
//! same inputs and seed give the same bytes whatever the thread count.
#![warn(missing_docs, unreachable_pub)]
// A library tells its caller (returned warnings, reports, progress callbacks);
// only the CLI and the Python bindings print (docs/design.md).
#![deny(clippy::print_stderr, clippy::print_stdout)]

mod cost;
pub mod error;
mod fast_exp;
pub mod fusion;
mod geom_term;
pub mod geometric;
pub mod job;
mod maps;
pub mod params;
pub mod patchmatch;
mod pyramid;
mod rng;
// Left to the SGM work under way in sgm/ (its visibility is tightened there).
#[allow(unreachable_pub)]
pub mod sgm;
mod simd;
mod sources;
pub mod view;
mod warp;
pub mod workspace;

pub use error::{MvsError, Result};
pub use fusion::{fuse, fuse_releasing, FusedPly, FusedPoint};
pub use geometric::{apply_keep, geometric_filter, geometric_keep};
pub use job::{
    reconstruct_image_sets, reconstruct_workspace, ImageSet, ImageSetsRequest, SetShares,
    WorkspaceRequest,
};
pub use params::MvsParams;
pub use patchmatch::{patch_match, DepthNormalMap};
pub use sgm::{semi_global, Algorithm, LeftRight, PairAgreement, SgmParams};
pub use sources::frustum_sources;
pub use view::{GreyImage, View};
pub use workspace::{run_image_set, run_workspace, RunOptions, RunSummary, Workspace};

/// The result of [`reconstruct`], indexed like the views.
#[derive(Debug, Clone)]
pub struct Output {
    /// PatchMatch's photometric maps (photometric filter applied); `None`
    /// for a view without sources.
    pub photometric: Vec<Option<DepthNormalMap>>,
    /// The maps after the geometric pass (when enabled) and the geometric
    /// filter.
    pub geometric: Vec<Option<DepthNormalMap>>,
    /// The fused cloud.
    pub fused: Vec<FusedPoint>,
}

/// Reconstructs `views`: view `i` is a reference against the views
/// `sources[i]` (a view without sources is only used as a source). Runs
/// the matcher of `params.algorithm` (PatchMatch or SGM) for each reference, then the geometric filter, then fusion.
/// `progress` receives one line per step.
pub fn reconstruct(
    views: &[View],
    sources: &[Vec<usize>],
    params: &MvsParams,
    progress: &mut dyn FnMut(&str),
) -> Result<Output> {
    let mut photometric: Maps = vec![None; views.len()];
    let geometric = reconstruct_maps(views, sources, params, true, progress, &mut |r, map| {
        photometric[r] = Some(map);
        Ok(())
    })?;
    progress("fusion");
    let fused = fuse(views, &geometric, sources, params);
    Ok(Output {
        photometric,
        geometric,
        fused,
    })
}

/// Where [`reconstruct_maps`] hands each view's photometric map (view
/// index, map) as soon as it is final: [`reconstruct`] keeps them,
/// [`run_workspace`] writes them and lets them go, so they are not held
/// beside the others' passes and the fused cloud.
pub(crate) type PhotometricSink<'a> = &'a mut dyn FnMut(usize, DepthNormalMap) -> Result<()>;

/// [`reconstruct`] up to fusion: the geometric maps, returned, and the
/// photometric ones, handed to `photometric` one by one. Without `costs`
/// the geometric maps' costs are let go as each map is made (4 bytes a
/// pixel of every view held to the end: a workspace run writes none, and
/// fusion does not read them).
pub(crate) fn reconstruct_maps(
    views: &[View],
    sources: &[Vec<usize>],
    params: &MvsParams,
    costs: bool,
    progress: &mut dyn FnMut(&str),
    photometric: PhotometricSink<'_>,
) -> Result<Maps> {
    params.validate()?;
    if views.len() < 2 {
        return Err(MvsError::InvalidArgument(format!(
            "{} view(s): multi-view stereo needs at least two",
            views.len()
        )));
    }
    if sources.len() != views.len() {
        return Err(MvsError::InvalidArgument(format!(
            "{} source lists for {} views",
            sources.len(),
            views.len()
        )));
    }
    if sources.iter().all(Vec::is_empty) {
        return Err(MvsError::InvalidArgument(
            "no image has a source image (too little overlap or triangulation angle)".into(),
        ));
    }
    let refined = match params.algorithm {
        Algorithm::PatchMatch => {
            patch_match_all(views, sources, (params, costs), progress, photometric)?
        }
        Algorithm::Sgm => {
            let mut maps = Vec::with_capacity(views.len());
            for (r, src) in sources.iter().enumerate() {
                if src.is_empty() {
                    progress(&format!(
                        "[{}/{}] {}: no source images, skipped",
                        r + 1,
                        views.len(),
                        views[r].name
                    ));
                    maps.push(None);
                    continue;
                }
                progress(&format!(
                    "[{}/{}] semi-global matching {} against {} source(s)",
                    r + 1,
                    views.len(),
                    views[r].name,
                    src.len().min(params.max_sources)
                ));
                maps.push(Some(semi_global(views, r, src, params)?));
            }
            // SGM has no geometric pass: the filter below takes its maps.
            for (r, map) in maps.iter_mut().enumerate() {
                if let Some(map) = map {
                    photometric(r, map.clone())?;
                    if !costs {
                        map.cost = Vec::new();
                    }
                }
            }
            maps
        }
    };
    progress("geometric consistency filter");
    // Every mask from the unfiltered maps first, then each map filtered in
    // place: the refined maps become the geometric ones without a copy.
    let keep: Vec<Option<Vec<bool>>> = (0..views.len())
        .map(|r| geometric_keep(views, &refined, r, &sources[r], params))
        .collect();
    let mut geometric = refined;
    for (map, keep) in geometric.iter_mut().zip(&keep) {
        if let (Some(map), Some(keep)) = (map, keep) {
            apply_keep(map, keep);
        }
    }
    Ok(geometric)
}

/// One optional map per view.
type Maps = Vec<Option<DepthNormalMap>>;

/// The refined maps of PatchMatch (photometric pass, then the geometric
/// pass when `geom_consistency` is on); each photometric map goes to
/// `photometric` once no pass needs its planes.
///
/// # Memory
/// Between the passes each view keeps its unfiltered photometric map (20
/// bytes a pixel: the planes its geometric pass starts from, the depths
/// the others' passes read, the costs of the photometric filter). Once its
/// own geometric pass is done, the view's photometric map is filtered out
/// of it and handed on, and only its depths (4 bytes a pixel) stay for the
/// later views' passes: at the end 4 bytes a pixel are held beside the
/// refined maps, not 20.
fn patch_match_all(
    views: &[View],
    sources: &[Vec<usize>],
    (params, costs): (&MvsParams, bool),
    progress: &mut dyn FnMut(&str),
    photometric: PhotometricSink<'_>,
) -> Result<Maps> {
    let mut unfiltered: Maps = Vec::with_capacity(views.len());
    for (r, src) in sources.iter().enumerate() {
        if src.is_empty() {
            progress(&format!(
                "[{}/{}] {}: no source images, skipped",
                r + 1,
                views.len(),
                views[r].name
            ));
            unfiltered.push(None);
            continue;
        }
        progress(&format!(
            "[{}/{}] patch match {} against {} source(s)",
            r + 1,
            views.len(),
            views[r].name,
            src.len()
        ));
        let raw = patchmatch::patch_match_raw(views, r, src, params, None)?;
        unfiltered.push(Some(raw.unfiltered()));
    }
    // A refined map, without its costs unless they are kept.
    let finish = |mut map: DepthNormalMap| {
        if !costs {
            map.cost = Vec::new();
        }
        map
    };
    let filtered = |map: &DepthNormalMap| finish(map.clone().photometric(params));
    if !params.geom_consistency {
        let refined = unfiltered
            .iter()
            .map(|m| m.as_ref().map(filtered))
            .collect();
        for (r, map) in unfiltered.into_iter().enumerate() {
            if let Some(map) = map {
                photometric(r, map.photometric(params))?;
            }
        }
        return Ok(refined);
    }
    // A source without a photometric pass of its own cannot inform the
    // geometric term: such references keep their photometric result.
    let mut refined = Vec::with_capacity(views.len());
    for (r, src) in sources.iter().enumerate() {
        let usable: Vec<usize> = src
            .iter()
            .copied()
            .filter(|&s| unfiltered[s].is_some())
            .collect();
        if unfiltered[r].is_none() || usable.is_empty() {
            refined.push(unfiltered[r].as_ref().map(filtered));
        } else {
            progress(&format!(
                "[{}/{}] geometric pass {}",
                r + 1,
                views.len(),
                views[r].name
            ));
            let previous = geom_term::Photometric {
                maps: &unfiltered,
                same_sources: usable.len() == src.len(),
            };
            let state = patchmatch::patch_match_raw(views, r, &usable, params, Some(previous))?;
            refined.push(Some(finish(state.to_map(params))));
        }
        if let Some(map) = unfiltered[r].as_mut() {
            photometric(r, map.take_photometric(params))?;
        }
    }
    Ok(refined)
}
