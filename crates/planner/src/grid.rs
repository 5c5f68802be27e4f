//! Grid baseline: a lawnmower flight over the footprint of the region of
//! interest at a given height or ground sampling distance, with front and
//! side overlap, nadir or oblique. The paper flies one as the initial
//! flight (19 images at 50 m above the lowest point) and one as its Grid
//! baseline (80 % overlap).

use nalgebra::Point3;
use serde::{Deserialize, Serialize};
use vp_scene::plan::{GeodeticOrigin, Plan, PlannedView, Role};
use vp_scene::raycast::RayCaster;
use vp_scene::{Aabb, Camera, Intrinsics, Mesh};

use crate::config::PlannerConfig;
use crate::error::{PlannerError, Result};
use crate::flight_path::PathContext;
use crate::flights::assign_flights;
use crate::inputs::{safety_for, RoiSpec};

/// Parameters of a grid flight.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct GridParams {
    /// Flight height above the lowest point of the footprint, metres.
    /// Used when `gsd_m` is `None`.
    pub height_m: f64,
    /// Ground sampling distance at nadir, metres per pixel; sets the height
    /// to `gsd * focal` when given.
    pub gsd_m: Option<f64>,
    /// Overlap of consecutive images along a line, in [0, 1).
    pub front_overlap: f64,
    /// Overlap of neighbouring lines, in [0, 1).
    pub side_overlap: f64,
    /// Camera pitch, degrees: -90 nadir, e.g. -45 oblique.
    pub pitch_deg: f64,
    /// Direction of the flight lines and of the camera heading, degrees
    /// counter-clockwise from east.
    pub yaw_deg: f64,
    /// Role written into the views (`Grid` for a baseline, `Initial` for a first flight).
    pub role: Role,
}

impl Default for GridParams {
    /// The paper's Grid baseline: 80 % overlap at 50 m, nadir.
    fn default() -> Self {
        GridParams {
            height_m: 50.0,
            gsd_m: None,
            front_overlap: 0.8,
            side_overlap: 0.8,
            pitch_deg: -90.0,
            yaw_deg: 0.0,
            role: Role::Grid,
        }
    }
}

/// What a grid flies at: its height, ground resolution and spacings.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct GridFigures {
    /// Height above the lowest point of the footprint, metres.
    pub height_m: f64,
    /// Ground sampling distance at nadir at that height, metres per pixel.
    pub gsd_m: f64,
    /// Distance between neighbouring lines, metres.
    pub line_spacing_m: f64,
    /// Distance between consecutive photos along a line (the trigger distance), metres.
    pub trigger_distance_m: f64,
}

impl GridParams {
    /// The height, GSD and spacings of this grid with camera `k`: the image
    /// width lies across the lines, its height along them.
    pub fn figures(&self, k: Intrinsics) -> GridFigures {
        let height = self.gsd_m.map_or(self.height_m, |g| g * k.focal());
        let across = height * f64::from(k.width) / k.fx;
        let along = height * f64::from(k.height) / k.fy;
        GridFigures {
            height_m: height,
            gsd_m: height / k.focal(),
            line_spacing_m: across * (1.0 - self.side_overlap),
            trigger_distance_m: along * (1.0 - self.front_overlap),
        }
    }
}

/// Positions along one axis: `n` centres spaced `step` apart, centred on the
/// extent `[lo, hi]`, the fewest whose footprints of length `size` cover it.
fn stations(lo: f64, hi: f64, size: f64, step: f64) -> Vec<f64> {
    let extent = hi - lo;
    let n = if extent <= size {
        1
    } else {
        // Tolerance: an extent that is a whole number of steps (up to
        // round-off) must not get an extra station.
        ((extent - size) / step - 1e-9).ceil() as usize + 1
    };
    let span = (n - 1) as f64 * step;
    let start = 0.5 * (lo + hi) - 0.5 * span;
    (0..n).map(|i| start + i as f64 * step).collect()
}

/// The views of a grid flight over the x/y extent of `footprint`, in flight
/// order (serpentine). Heights are relative to `footprint.min.z`.
///
/// Line spacing uses the nadir footprint (image height along the line,
/// width across it); for oblique pitches the camera is moved back so its
/// optical axis meets the ground point at the reference height.
pub fn grid_views(
    footprint: &Aabb,
    params: &GridParams,
    k: Intrinsics,
) -> Result<Vec<PlannedView>> {
    let p = params;
    let bad = |m: String| Err(PlannerError::Input(format!("grid: {m}")));
    if !(0.0..1.0).contains(&p.front_overlap) || !(0.0..1.0).contains(&p.side_overlap) {
        return bad(format!(
            "overlaps {} / {} must be in [0, 1)",
            p.front_overlap, p.side_overlap
        ));
    }
    if !(-90.0..-5.0).contains(&p.pitch_deg) || !p.yaw_deg.is_finite() {
        return bad(format!(
            "pitch {} deg must be in [-90, -5) and yaw finite",
            p.pitch_deg
        ));
    }
    let fig = p.figures(k);
    let height = fig.height_m;
    if !(height.is_finite() && height > 0.0) {
        return bad(format!("height {height} m must be positive"));
    }
    if footprint.min.x > footprint.max.x
        || footprint.min.y > footprint.max.y
        || !footprint
            .min
            .iter()
            .chain(footprint.max.iter())
            .all(|c| c.is_finite())
    {
        return bad("the region of interest is empty".into());
    }
    let across = height * f64::from(k.width) / k.fx;
    let along = height * f64::from(k.height) / k.fy;
    let (sy, cy) = p.yaw_deg.to_radians().sin_cos();
    // Track frame: u along the lines, v across (to the left).
    let corners = [
        (footprint.min.x, footprint.min.y),
        (footprint.max.x, footprint.min.y),
        (footprint.max.x, footprint.max.y),
        (footprint.min.x, footprint.max.y),
    ];
    let uv: Vec<(f64, f64)> = corners
        .iter()
        .map(|&(x, y)| (x * cy + y * sy, -x * sy + y * cy))
        .collect();
    let range = |f: fn(&(f64, f64)) -> f64| {
        uv.iter()
            .map(f)
            .fold((f64::INFINITY, f64::NEG_INFINITY), |(a, b), v| {
                (a.min(v), b.max(v))
            })
    };
    let (u0, u1) = range(|q| q.0);
    let (v0, v1) = range(|q| q.1);
    let us = stations(u0, u1, along, fig.trigger_distance_m);
    let vs = stations(v0, v1, across, fig.line_spacing_m);
    let pitch = p.pitch_deg.to_radians();
    let back = if p.pitch_deg <= -89.999 {
        0.0
    } else {
        height / (-pitch).tan()
    };
    let z = footprint.min.z + height;
    let mut views = Vec::with_capacity(us.len() * vs.len());
    for (line, v) in vs.iter().enumerate() {
        let forward: Vec<f64> = if line % 2 == 0 {
            us.clone()
        } else {
            us.iter().rev().copied().collect()
        };
        for u in forward {
            let (x, y) = (u * cy - v * sy, u * sy + v * cy);
            let c = Point3::new(x - back * cy, y - back * sy, z);
            let cam = Camera::from_yaw_pitch(k, c, p.yaw_deg.to_radians(), pitch);
            views.push(PlannedView::from_camera(&cam, p.role));
        }
    }
    Ok(views)
}

/// A grid flight over the region of interest's footprint, checked against
/// the safety rules of `cfg` (every waypoint and segment), as a plan.
pub fn plan_grid(
    mesh: &Mesh,
    roi: &RoiSpec,
    params: &GridParams,
    cfg: &PlannerConfig,
    origin: Option<GeodeticOrigin>,
    home: Option<&Point3<f64>>,
) -> Result<Plan> {
    cfg.validate()?;
    if mesh.n_faces() == 0 {
        return Err(PlannerError::Input("the mesh has no faces".into()));
    }
    let caster = RayCaster::new(mesh);
    let faces = roi.faces(mesh, &caster, origin)?;
    let mut fp = Aabb::empty();
    for &f in &faces {
        for p in mesh.triangle(f as usize) {
            fp.grow(&p);
        }
    }
    let k = cfg.camera.intrinsics();
    let views = grid_views(&fp, params, k)?;
    let safety = safety_for(mesh, cfg);
    let ctx = PathContext {
        mesh,
        caster: &caster,
        safety: &safety,
        intrinsics: k,
        min_overlap: cfg.min_overlap,
        home: home.copied(),
    };
    let mut plan = Plan::new(origin);
    let flights = assign_flights(&safety, home, &ctx.make_safe(&views)?, &cfg.mission)?;
    (plan.waypoints, plan.flights) = (flights.waypoints, flights.flights);
    plan.geofence.clone_from(&safety.geofence);
    plan.altitude_limits = Some(safety.altitude);
    plan.safety_distance_m = Some(cfg.safety_distance_m);
    Ok(plan)
}

#[cfg(test)]
mod tests {
    use super::*;

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

    #[test]
    fn counts_and_overlap_match_hand_computation() {
        // At 40 m: footprint 40 m across, 30 m along. 80 % overlap: steps 8 m
        // across and 6 m along. Extent 60 x 50 m: along x (60 m) needs
        // ceil((60-30)/6)+1 = 6, across y (50 m) ceil((50-40)/8)+1 = 3.
        let fp = Aabb {
            min: Point3::new(0.0, 0.0, 10.0),
            max: Point3::new(60.0, 50.0, 20.0),
        };
        let params = GridParams {
            height_m: 40.0,
            ..GridParams::default()
        };
        let views = grid_views(&fp, &params, k()).unwrap();
        assert_eq!(views.len(), 18);
        assert!(views.iter().all(|v| (v.position[2] - 50.0).abs() < 1e-9));
        let d = Point3::from(views[1].position) - Point3::from(views[0].position);
        assert!((d.norm() - 6.0).abs() < 1e-9, "front step {d:?}");
        // Serpentine: the second line starts where the first ended.
        let d = Point3::from(views[6].position) - Point3::from(views[5].position);
        assert!((d.norm() - 8.0).abs() < 1e-9, "side step {d:?}");
        // Same inputs, same views.
        assert_eq!(views, grid_views(&fp, &params, k()).unwrap());
    }

    #[test]
    fn oblique_views_aim_at_the_ground_stations() {
        let fp = Aabb {
            min: Point3::new(0.0, 0.0, 0.0),
            max: Point3::new(10.0, 10.0, 0.0),
        };
        let params = GridParams {
            height_m: 20.0,
            pitch_deg: -45.0,
            ..GridParams::default()
        };
        let views = grid_views(&fp, &params, k()).unwrap();
        assert_eq!(views.len(), 1);
        let cam = views[0].to_camera(k());
        let px = cam.project(&Point3::new(5.0, 5.0, 0.0)).unwrap();
        assert!((px.x - 200.0).abs() < 1e-6 && (px.y - 150.0).abs() < 1e-6);
    }
}
