//! Normals of samples: given, or PCA over neighbours oriented by visibility.

use nalgebra::{Matrix3, Vector3};
use rayon::prelude::*;

use super::grid::PointGrid;
use super::SurfaceSample;
use crate::error::{Result, SceneError};

/// One unit normal per sample, and how many were estimated. A given normal
/// is kept (normalised); otherwise the least-variance axis of the `k`
/// nearest samples, signed so that it points to the mean unit direction
/// from the sample to its observing cameras.
pub(super) fn orient(
    samples: &[SurfaceSample],
    grid: &PointGrid,
    k: usize,
) -> Result<(Vec<Vector3<f64>>, usize)> {
    let normals: Vec<Option<Vector3<f64>>> = samples
        .par_iter()
        .map(|s| match s.normal {
            Some(n) => Some(n.normalize()),
            None => estimate(s, grid, k),
        })
        .collect();
    let mut out = Vec::with_capacity(samples.len());
    for (i, n) in normals.into_iter().enumerate() {
        match n {
            Some(n) => out.push(n),
            None => {
                return Err(SceneError::Surface(format!(
                    "sample {i} at {:?}: no normal could be estimated (its {k} nearest \
                     samples lie on a line or a point, or its cameras see it edge-on)",
                    samples[i].position.coords.as_slice()
                )))
            }
        }
    }
    let estimated = samples.iter().filter(|s| s.normal.is_none()).count();
    Ok((out, estimated))
}

fn estimate(s: &SurfaceSample, grid: &PointGrid, k: usize) -> Option<Vector3<f64>> {
    let pts = grid.points();
    let ids = grid.k_nearest(&s.position, k);
    let n = ids.len() as f64;
    let mean = ids
        .iter()
        .fold(Vector3::zeros(), |a, &i| a + pts[i as usize].coords)
        / n;
    let cov = ids.iter().fold(Matrix3::zeros(), |a, &i| {
        let d = pts[i as usize].coords - mean;
        a + d * d.transpose()
    }) / n;
    let eig = cov.symmetric_eigen();
    let mut order = [0usize, 1, 2];
    order.sort_by(|&a, &b| eig.eigenvalues[a].total_cmp(&eig.eigenvalues[b]));
    // A line of neighbours has no plane: the two smallest variances vanish.
    if !(eig.eigenvalues[order[1]] > 1e-12 * eig.eigenvalues[order[2]].max(1e-300)) {
        return None;
    }
    let normal: Vector3<f64> = eig.eigenvectors.column(order[0]).into_owned();
    let view = s
        .seen_from
        .iter()
        .filter_map(|c| (c - s.position).try_normalize(1e-12))
        .fold(Vector3::zeros(), |a, d| a + d);
    let side = normal.dot(&view);
    if side == 0.0 || !side.is_finite() {
        return None;
    }
    Some(if side > 0.0 { normal } else { -normal }.normalize())
}
