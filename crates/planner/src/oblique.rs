//! The industry's oblique pattern, as a baseline for the planned triplets:
//! one nadir grid and four oblique grids with the camera pitched down
//! (45 deg by default) toward the four headings, as DJI's "oblique
//! capture" (five routes) and most photogrammetry planners fly it. Every
//! route is a [`grid_views`] lawnmower over the same footprint; an oblique
//! route's camera is moved back so that its optical axis meets the ground
//! station the nadir route photographs.
//!
//! A fair comparison with a planned flight gives both the same number of
//! images: [`oblique_views`] chooses the one overlap (front = side) shared
//! by the five routes that gives the most images within a budget. The
//! count moves in steps (a whole line or station at a time), so the
//! flight may hold fewer images than the budget; the caller reports the
//! count it got.

use vp_scene::plan::{PlannedView, Role};
use vp_scene::{Aabb, Intrinsics};

use crate::error::{PlannerError, Result};
use crate::grid::{grid_views, GridParams};

/// Headings of the four oblique routes, degrees counter-clockwise from
/// east: the camera looks east, north, west and south in turn.
pub const OBLIQUE_HEADINGS_DEG: [f64; 4] = [0.0, 90.0, 180.0, 270.0];

/// Highest overlap tried: beyond it a route's stations crowd without
/// adding views of anything new.
const MAX_OVERLAP: f64 = 0.95;

/// The five routes of an oblique capture over `footprint` at `height_m`
/// above its lowest point, oblique routes at `pitch_deg` (e.g. -45), with
/// the most images not above `max_images` at one overlap shared by every
/// route; nadir route first, then the obliques in [`OBLIQUE_HEADINGS_DEG`]
/// order. Errors when even zero overlap needs more than `max_images`.
pub fn oblique_views(
    footprint: &Aabb,
    height_m: f64,
    pitch_deg: f64,
    k: Intrinsics,
    max_images: usize,
) -> Result<Vec<PlannedView>> {
    if !(-89.0..=-5.0).contains(&pitch_deg) {
        return Err(PlannerError::Input(format!(
            "oblique capture: pitch {pitch_deg} deg must be in [-89, -5] (nadir is the fifth route)"
        )));
    }
    let routes = |overlap: f64| -> Result<Vec<PlannedView>> {
        let nadir = GridParams {
            height_m,
            gsd_m: None,
            front_overlap: overlap,
            side_overlap: overlap,
            pitch_deg: -90.0,
            yaw_deg: 0.0,
            role: Role::Grid,
        };
        let mut views = grid_views(footprint, &nadir, k)?;
        for yaw_deg in OBLIQUE_HEADINGS_DEG {
            let oblique = GridParams {
                pitch_deg,
                yaw_deg,
                ..nadir
            };
            views.extend(grid_views(footprint, &oblique, k)?);
        }
        Ok(views)
    };
    let fewest = routes(0.0)?;
    if fewest.len() > max_images {
        return Err(PlannerError::Input(format!(
            "oblique capture: {} images at zero overlap, more than the budget of {max_images}; \
             fly higher or over a smaller region",
            fewest.len()
        )));
    }
    // The image count never falls as the overlap grows (each route's
    // spacings shrink), so bisection finds the highest overlap within the
    // budget; 40 halvings pin it far below any spacing that matters.
    let (mut lo, mut hi) = (0.0, MAX_OVERLAP);
    if routes(hi)?.len() <= max_images {
        return routes(hi);
    }
    for _ in 0..40 {
        let mid = 0.5 * (lo + hi);
        if routes(mid)?.len() <= max_images {
            lo = mid;
        } else {
            hi = mid;
        }
    }
    routes(lo)
}

#[cfg(test)]
mod tests {
    use super::*;
    use nalgebra::Point3;

    fn k() -> Intrinsics {
        Intrinsics {
            width: 400,
            height: 300,
            fx: 400.0,
            fy: 400.0,
            cx: 200.0,
            cy: 150.0,
        }
    }

    fn footprint() -> Aabb {
        Aabb {
            min: Point3::new(0.0, 0.0, 0.0),
            max: Point3::new(15.0, 15.0, 0.0),
        }
    }

    #[test]
    fn five_routes_within_the_budget_each_looking_its_way() {
        for budget in [5, 12, 30, 60, 61, 200] {
            let views = oblique_views(&footprint(), 25.0, -45.0, k(), budget).unwrap();
            assert!(views.len() <= budget, "{} > {budget}", views.len());
            // The next overlap step would exceed the budget: the count is
            // the largest reachable (checked against a fine scan).
            let best = (0..=950)
                .map(|i| {
                    let o = f64::from(i) / 1000.0;
                    let p = |pitch_deg, yaw_deg| GridParams {
                        height_m: 25.0,
                        gsd_m: None,
                        front_overlap: o,
                        side_overlap: o,
                        pitch_deg,
                        yaw_deg,
                        role: Role::Grid,
                    };
                    let mut n = grid_views(&footprint(), &p(-90.0, 0.0), k()).unwrap().len();
                    for y in OBLIQUE_HEADINGS_DEG {
                        n += grid_views(&footprint(), &p(-45.0, y), k()).unwrap().len();
                    }
                    n
                })
                .filter(|&n| n <= budget)
                .max()
                .unwrap();
            assert!(
                views.len() >= best,
                "budget {budget}: {} < {best}",
                views.len()
            );
            // Every view looks at the footprint's ground: its optical axis
            // meets z = 0 inside the footprint (grown by a station's reach).
            for v in &views {
                let cam = v.to_camera(k());
                let c = cam.center();
                let d = cam.axis();
                assert!(d.z < 0.0, "looks down");
                let t = -c.z / d.z;
                let hit = c + d * t;
                assert!(
                    (-15.0..=35.0).contains(&hit.x) && (-15.0..=30.0).contains(&hit.y),
                    "{hit:?}"
                );
            }
        }
    }

    #[test]
    fn obliques_look_toward_the_four_headings() {
        let views = oblique_views(&footprint(), 25.0, -45.0, k(), 5).unwrap();
        assert_eq!(views.len(), 5, "one station per route at zero overlap");
        let axes: Vec<_> = views.iter().map(|v| v.to_camera(k()).axis()).collect();
        assert!(axes[0].z < -0.999, "nadir first: {:?}", axes[0]);
        let expected = [(1.0, 0.0), (0.0, 1.0), (-1.0, 0.0), (0.0, -1.0)];
        for (a, (ex, ey)) in axes[1..].iter().zip(expected) {
            let h = a.xy().normalize();
            assert!((h.x - ex).abs() < 1e-9 && (h.y - ey).abs() < 1e-9, "{a:?}");
            assert!(
                (a.z + std::f64::consts::FRAC_1_SQRT_2).abs() < 1e-9,
                "45 deg down: {a:?}"
            );
        }
    }

    #[test]
    fn a_budget_below_five_routes_or_a_nadir_pitch_is_refused() {
        let e = oblique_views(&footprint(), 25.0, -45.0, k(), 4).unwrap_err();
        assert!(e.to_string().contains("budget of 4"), "{e}");
        let e = oblique_views(&footprint(), 25.0, -90.0, k(), 60).unwrap_err();
        assert!(e.to_string().contains("pitch"), "{e}");
    }
}
