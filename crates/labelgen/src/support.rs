//! Stage 1, support: how many independent reconstructions from a different
//! enough viewpoint agree with each measurement.
//!
//! A reference (a reconstruction sharing no image with the query's triplet)
//! supports a query measurement at point p when its z-buffered measurement at
//! the query pixel lies within the query's uncertainty bound along the ray,
//! and its viewpoint differs enough: `angle(p->c_ref, p->c_query) > alpha_min`
//! or `res_ref / res_query > s_min` (c = mean centre of a triplet, res = mean
//! focal length / distance to p). References whose viewpoints are similar to
//! one that already counted (angle <= alpha_min and resolution ratio <= s_min
//! both ways) count once. References are visited in the order of their ids,
//! so the count does not depend on the input order.

use nalgebra::Vector3;

use crate::measurement::{ray_scale, splat, Prepared};
use crate::params::LabelParams;

/// A viewpoint that already counted for one measurement: unit direction from
/// the point to the reference's mean centre, and its resolution there.
#[derive(Clone, Copy)]
struct Viewpoint {
    dir: Vector3<f64>,
    res: f64,
}

/// Whether two viewpoints are distinct in the sense of the paper's test:
/// angle above alpha_min or resolution ratio above s_min (either way).
fn distinct(a: &Viewpoint, b: &Viewpoint, params: &LabelParams) -> bool {
    a.dir.angle(&b.dir).to_degrees() > params.alpha_min_deg
        || a.res / b.res > params.s_min
        || b.res / a.res > params.s_min
}

/// Support of every pixel of view `v` of reconstruction `q` (0 where there is
/// no measurement), from the references `refs` (indices into `prepared`, in
/// id order).
pub(crate) fn view_support(
    prepared: &[Prepared<'_>],
    q: usize,
    v: usize,
    refs: &[usize],
    params: &LabelParams,
) -> Vec<u16> {
    let qp = &prepared[q];
    let cam = &qp.cameras[v];
    let depth = &qp.rec.views[v].depth;
    let w = depth.width as usize;
    let n = depth.data.len();
    let mut support = vec![0u16; n];
    let mut counted: Vec<Vec<Viewpoint>> = vec![Vec::new(); n];
    for &r in refs {
        let rp = &prepared[r];
        let zb = splat(cam, rp, params.max_splat_radius, |_, _| Some(1.0));
        for idx in 0..n {
            let Some((dz, _)) = zb.get(idx) else { continue };
            let sigma = f64::from(qp.data[v].sigma[idx]);
            if sigma <= 0.0 {
                continue;
            }
            let dq = f64::from(depth.data[idx]);
            let along = (f64::from(dz) - dq).abs() * ray_scale(cam, idx % w, idx / w);
            if along > params.k_sigma * sigma {
                continue;
            }
            let Some(p) = qp.point(v, idx) else {
                continue;
            };
            let query = Viewpoint {
                dir: (qp.mean_centre - p).normalize(),
                res: qp.resolution_at(&p),
            };
            let reference = Viewpoint {
                dir: (rp.mean_centre - p).normalize(),
                res: rp.resolution_at(&p),
            };
            // The paper's one-sided test: a reference closer in resolution
            // but finer does not count unless its angle differs.
            let differs = query.dir.angle(&reference.dir).to_degrees() > params.alpha_min_deg
                || reference.res / query.res > params.s_min;
            if !differs {
                continue;
            }
            let list = &mut counted[idx];
            if list.iter().all(|c| distinct(c, &reference, params)) {
                list.push(reference);
                support[idx] = support[idx].saturating_add(1);
            }
        }
    }
    support
}
