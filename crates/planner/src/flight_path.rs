//! M4: flight order, image overlap with bridging views, and the safe path.
//!
//! Greedy nearest-neighbour order from the last captured image; every image
//! must overlap an earlier one by o_min (bridging views are inserted when
//! not); every waypoint and every straight segment between consecutive
//! waypoints keeps the safety distance, blocked segments climb, traverse and
//! descend. A triplet that no such route reaches is dropped from the path
//! (and named in [`Path::dropped`]; [`crate::plan`] then looks for a
//! replacement); [`PathContext::make_safe`] alone refuses the waypoints
//! naming the segment.

use nalgebra::{Point2, Point3};
use rayon::prelude::*;
use vp_scene::plan::{PlannedView, Role};
use vp_scene::raycast::{RayCaster, FACE_VISIBILITY_EPSILON};
use vp_scene::{Camera, Intrinsics, Mesh};

use crate::error::{PlannerError, Result};
use crate::home_way::{HomeWays, CLIMB_STEP_M};
use crate::safety::Safety;

/// Pixel-ray grid of the overlap test [vpctl] (docs/design.md#m4-flight-path).
pub const OVERLAP_GRID: (u32, u32) = (32, 24);
/// Most bridging views inserted before one image.
pub const MAX_BRIDGES: usize = 8;

/// Rays of `cam` through the centres of a `grid` (columns, rows) of
/// equal cells over the image.
pub fn grid_rays(cam: &Camera, (gx, gy): (u32, u32)) -> Vec<(Point3<f64>, nalgebra::Vector3<f64>)> {
    let k = cam.intrinsics;
    (0..gy)
        .flat_map(|j| (0..gx).map(move |i| (i, j)))
        .map(|(i, j)| {
            cam.ray(&Point2::new(
                (f64::from(i) + 0.5) * f64::from(k.width) / f64::from(gx),
                (f64::from(j) + 0.5) * f64::from(k.height) / f64::from(gy),
            ))
        })
        .collect()
}

/// Surface points seen through a regular grid of pixel rays of `cam`,
/// with the normal of the face hit.
pub fn grid_hits(cam: &Camera, caster: &RayCaster, mesh: &Mesh) -> Vec<Point3<f64>> {
    caster
        .closest_hits(&grid_rays(cam, OVERLAP_GRID), f64::INFINITY)
        .into_iter()
        .flatten()
        .map(|h| h.point + mesh.face_normal(h.face as usize) * FACE_VISIBILITY_EPSILON)
        .collect()
}

/// Share of `hits` (of image i) visible in image `j`: inside its frame and unoccluded.
pub fn overlap(hits: &[Point3<f64>], j: &Camera, caster: &RayCaster) -> f64 {
    if hits.is_empty() {
        return 0.0;
    }
    let c = j.center();
    let seen = hits
        .par_iter()
        .with_min_len(64)
        .filter(|p| j.in_frustum(p) && !caster.occluded(&c, p))
        .count();
    seen as f64 / hits.len() as f64
}

/// What the path builder needs.
pub struct PathContext<'a> {
    /// Scene mesh.
    pub mesh: &'a Mesh,
    /// Its ray caster.
    pub caster: &'a RayCaster,
    /// Safety rules.
    pub safety: &'a Safety,
    /// Intrinsics of the new views.
    pub intrinsics: Intrinsics,
    /// o_min.
    pub min_overlap: f64,
    /// Where every flight takes off and lands, when known: the path's
    /// first and last waypoints must be reachable from there
    /// ([`crate::home_way`]).
    pub home: Option<Point3<f64>>,
}

/// The path and its notes.
#[derive(Debug, Clone, Default)]
pub struct Path {
    /// Waypoints in flight order.
    pub waypoints: Vec<PlannedView>,
    /// Images that could not be bridged to o_min overlap (index into `waypoints`).
    pub unbridged: Vec<usize>,
    /// Triplets left out because one of their images is unsafe or no safe
    /// route reaches it, in the order they were dropped.
    pub dropped: Vec<Dropped>,
    /// Their ids (`dropped[i].triplet_id`).
    pub dropped_triplets: Vec<u32>,
    /// Why each was left out, naming waypoints by their index in `waypoints`
    /// ([`PathContext::describe`]), in the same order.
    pub dropped_reasons: Vec<String>,
}

/// A triplet the path left out, and the view and rule that made it go.
#[derive(Debug, Clone)]
pub struct Dropped {
    /// Its id.
    pub triplet_id: u32,
    /// Its unsafe or unreachable view.
    pub view: PlannedView,
    /// What is wrong.
    pub block: Block,
}

/// Why a view cannot be flown.
#[derive(Debug, Clone)]
pub enum Block {
    /// The view itself breaks a rule (the words of [`Safety::point_problem`]).
    Point(String),
    /// The straight segment to it breaks a rule and no climb-traverse-descend
    /// route is clear.
    Segment {
        /// Where the segment starts.
        start: [f64; 3],
        /// The view there, or `None` for the vehicle's position (the start
        /// of the path).
        from: Option<PlannedView>,
    },
    /// It is the first or the last waypoint of the mission, and no way
    /// between home and it is clear ([`HomeWays::blocked`]'s words).
    Home {
        /// Home.
        home: [f64; 3],
        /// What blocks the way.
        problem: String,
    },
}

/// Where a route starts: the vehicle's position, or (with the view) a
/// waypoint of a path already flown.
type Start<'a> = (&'a Point3<f64>, Option<&'a PlannedView>);

/// An unsafe waypoint, or a segment no climb-traverse-descend route makes safe.
struct Blocked {
    /// Index of the unsafe waypoint, or of the one the segment leads to.
    to: usize,
    /// What is wrong.
    block: Block,
}

fn cam_of(v: &PlannedView, k: Intrinsics) -> Camera {
    v.to_camera(k)
}

impl PathContext<'_> {
    fn overlaps_any(&self, hits: &[Point3<f64>], earlier: &[Camera]) -> bool {
        earlier
            .iter()
            .rev()
            .any(|c| overlap(hits, c, self.caster) >= self.min_overlap)
    }

    /// Fewest bridging views from `from` to `to` so that each step overlaps
    /// its predecessor; positions lerp, orientations slerp (roll dropped).
    fn bridge(&self, from: &Camera, to: &Camera) -> Option<Vec<Camera>> {
        let (q0, q1) = (from.world_from_cam.rotation, to.world_from_cam.rotation);
        let (p0, p1) = (from.center(), to.center());
        for n in 1..=MAX_BRIDGES {
            let mut chain = vec![*from];
            let mut ok = true;
            for i in 1..=n {
                let s = i as f64 / (n + 1) as f64;
                let p = p0 + (p1 - p0) * s;
                let axis = q0.slerp(&q1, s) * nalgebra::Vector3::z();
                let cam = Camera::from_yaw_pitch(
                    self.intrinsics,
                    p,
                    axis.y.atan2(axis.x),
                    axis.z.clamp(-1.0, 1.0).asin(),
                );
                let prev = chain[chain.len() - 1];
                if !self.safety.point_ok(&p)
                    || overlap(&grid_hits(&cam, self.caster, self.mesh), &prev, self.caster)
                        < self.min_overlap
                {
                    ok = false;
                    break;
                }
                chain.push(cam);
            }
            let last = chain[chain.len() - 1];
            if ok
                && overlap(&grid_hits(to, self.caster, self.mesh), &last, self.caster)
                    >= self.min_overlap
            {
                return Some(chain.split_off(1));
            }
        }
        None
    }

    /// Orders `views` greedily from where the mission begins, inserts
    /// bridging views, then makes every segment safe.
    ///
    /// With a home the mission begins there: the vehicle landed after the
    /// flight that took the acquired images and takes off again, so the
    /// views are ordered from home and the way out to the first is a way
    /// from home ([`crate::home_way`]). Without one, the mission begins at
    /// `start`, the last acquired camera, the only position known.
    pub fn build(&self, start: &Camera, captured: &[Camera], views: Vec<PlannedView>) -> Path {
        self.build_from(start, None, captured, views)
    }

    /// [`PathContext::build`] for views flown after `last`, a waypoint of a
    /// safe path already built (with its cameras among `captured`): the
    /// segment from `last` keeps the rules of every other segment, and a
    /// reason names `last` as the waypoint it starts at.
    pub fn build_after(
        &self,
        last: &PlannedView,
        captured: &[Camera],
        views: Vec<PlannedView>,
    ) -> Path {
        let start = last.to_camera(self.intrinsics);
        self.build_from(&start, Some(last), captured, views)
    }

    fn build_from(
        &self,
        start: &Camera,
        after: Option<&PlannedView>,
        captured: &[Camera],
        views: Vec<PlannedView>,
    ) -> Path {
        let k = self.intrinsics;
        let mut remaining = views;
        let mut earlier: Vec<Camera> = captured.to_vec();
        let mut ordered: Vec<PlannedView> = Vec::new();
        // Per ordered view: could it not be bridged to o_min overlap?
        let mut unbridged: Vec<bool> = Vec::new();
        let mut unbridged_next = false;
        // With a home, a new mission leaves from home, not from `start`.
        let from_home = self.home.filter(|_| after.is_none());
        let mut here = from_home.unwrap_or_else(|| start.center());
        while !remaining.is_empty() {
            let next = remaining
                .iter()
                .enumerate()
                .min_by(|a, b| {
                    let da = (Point3::from(a.1.position) - here).norm_squared();
                    let db = (Point3::from(b.1.position) - here).norm_squared();
                    da.total_cmp(&db).then(a.0.cmp(&b.0))
                })
                .map_or(0, |x| x.0);
            let view = remaining.remove(next);
            let cam = cam_of(&view, k);
            let hits = grid_hits(&cam, self.caster, self.mesh);
            if !earlier.is_empty() && !self.overlaps_any(&hits, &earlier) {
                let closest = *earlier
                    .iter()
                    .min_by(|a, b| {
                        let c = cam.center();
                        (a.center() - c)
                            .norm_squared()
                            .total_cmp(&(b.center() - c).norm_squared())
                    })
                    .unwrap_or(start);
                match self.bridge(&closest, &cam) {
                    Some(bridges) => {
                        for b in bridges {
                            ordered.push(PlannedView::from_camera(&b, Role::Bridge));
                            unbridged.push(false);
                            earlier.push(b);
                        }
                    }
                    None => unbridged_next = true,
                }
            }
            here = cam.center();
            earlier.push(cam);
            ordered.push(view);
            unbridged.push(std::mem::take(&mut unbridged_next));
        }
        let vehicle = start.center();
        let route_start = from_home.is_none().then_some((&vehicle, after));
        let (waypoints, unbridged, dropped) = self.route_dropping(route_start, ordered, unbridged);
        let dropped_reasons = dropped
            .iter()
            .map(|d| self.describe(d, &waypoints))
            .collect();
        Path {
            dropped_triplets: dropped.iter().map(|d| d.triplet_id).collect(),
            dropped_reasons,
            waypoints,
            unbridged,
            dropped,
        }
    }

    /// Why `d` was dropped, for an operator: the view, the rule, and the
    /// view the blocked segment starts at by its index in `waypoints` (the
    /// flown waypoints, where the operator can find it), or by its position
    /// when it is not among them.
    pub fn describe(&self, d: &Dropped, waypoints: &[PlannedView]) -> String {
        let at = |[x, y, z]: [f64; 3]| format!("({x:.2}, {y:.2}, {z:.2})");
        match &d.block {
            Block::Point(problem) => format!("its view at {} {problem}", at(d.view.position)),
            Block::Segment { start, from } => {
                let from = match from {
                    None => format!(
                        "the start of the path (the last acquired image) at {}",
                        at(*start)
                    ),
                    Some(v) if v.triplet_id.is_some() && v.triplet_id == d.view.triplet_id => {
                        format!("its own view at {}", at(*start))
                    }
                    Some(v) => match waypoints.iter().position(|w| w == v) {
                        Some(i) => format!("waypoint {i}{} at {}", role_note(v), at(*start)),
                        None => format!(
                            "the view at {}{}, which is not flown either",
                            at(*start),
                            role_note(v)
                        ),
                    },
                };
                let s = self.safety;
                format!(
                    "no safe route reaches its view at {} from {from}: the straight segment \
                     comes closer than {:.2} m to the mesh (or to unobserved space, with \
                     unknown_space = \"occupied\") or leaves the geofence, and no \
                     climb-traverse-descend route below the altitude limit {:.1} m is clear",
                    at(d.view.position),
                    s.distance,
                    s.altitude.max_m
                )
            }
            Block::Home { home, problem } => format!(
                "no safe way between home at {} and its view at {}, the path's first or last \
                 waypoint: {problem}",
                at(*home),
                at(d.view.position)
            ),
        }
    }

    /// Routes `views` safely from `start` (where the vehicle is; `None`
    /// when the mission leaves from home, whose way out is checked
    /// instead), leaving out what a blocked segment leads to, and what
    /// ends the path where no way from home reaches it
    /// ([`Self::reachable_from_home`]): its whole triplet (two images of
    /// it are of no use), or the one bridging view. Returns the routed waypoints, the routed indices of the
    /// views flagged in `unbridged`, and the dropped triplets with the
    /// reason each was dropped. Terminates:
    /// every round removes a view.
    fn route_dropping(
        &self,
        start: Option<Start<'_>>,
        mut views: Vec<PlannedView>,
        mut unbridged: Vec<bool>,
    ) -> (Vec<PlannedView>, Vec<usize>, Vec<Dropped>) {
        let mut dropped = Vec::new();
        loop {
            let routed = self
                .route(start, &views)
                .and_then(|r| self.reachable_from_home(start, &views, r));
            match routed {
                Ok((safe, at)) => {
                    let unbridged_at = unbridged
                        .iter()
                        .zip(at)
                        .filter_map(|(&u, i)| u.then_some(i))
                        .collect();
                    return (safe, unbridged_at, dropped);
                }
                Err(blocked) => {
                    let gone: Vec<bool> = match views[blocked.to].triplet_id {
                        Some(t) => {
                            dropped.push(Dropped {
                                triplet_id: t,
                                view: views[blocked.to].clone(),
                                block: blocked.block,
                            });
                            views.iter().map(|v| v.triplet_id == Some(t)).collect()
                        }
                        None => (0..views.len()).map(|i| i == blocked.to).collect(),
                    };
                    (views, unbridged) = views
                        .into_iter()
                        .zip(unbridged)
                        .zip(gone)
                        .filter(|(_, g)| !g)
                        .map(|(kept, _)| kept)
                        .unzip();
                }
            }
        }
    }

    /// `routed` (the route of `views` from `start`), or the end of it that
    /// no way from home reaches: its first waypoint when the path starts
    /// the mission (not after a path already built), and its last. Any
    /// other waypoint may end a flight only where a way is clear
    /// ([`crate::flights`] cuts there).
    fn reachable_from_home(
        &self,
        start: Option<Start<'_>>,
        views: &[PlannedView],
        routed: (Vec<PlannedView>, Vec<usize>),
    ) -> std::result::Result<(Vec<PlannedView>, Vec<usize>), Box<Blocked>> {
        let (Some(home), Some(first), Some(last)) = (&self.home, routed.0.first(), routed.0.last())
        else {
            return Ok(routed);
        };
        let ways = HomeWays::new(self.safety, home);
        // A detour before the first view belongs to the segment to it:
        // the first view goes with it.
        let starts_mission = start.is_none_or(|(_, after)| after.is_none());
        let first = starts_mission.then_some((0, first));
        for (to, w) in first.into_iter().chain([(views.len() - 1, last)]) {
            if let Some(problem) = ways.blocked(&Point3::from(w.position)) {
                return Err(Box::new(Blocked {
                    to,
                    block: Block::Home {
                        home: (*home).into(),
                        problem,
                    },
                }));
            }
        }
        Ok(routed)
    }

    /// Re-routes every blocked segment by climb-traverse-descend within the
    /// altitude limit; refuses the waypoints when that fails.
    pub fn make_safe(&self, waypoints: &[PlannedView]) -> Result<Vec<PlannedView>> {
        self.route(None, waypoints)
            .map(|(safe, _)| safe)
            .map_err(|b| PlannerError::Refused(self.refusal(&b, waypoints)))
    }

    /// [`PathContext::make_safe`]'s refusal, naming waypoints by their
    /// index in the caller's `waypoints`.
    fn refusal(&self, b: &Blocked, waypoints: &[PlannedView]) -> String {
        let [x, y, z] = waypoints[b.to].position;
        let i = b.to;
        match &b.block {
            Block::Point(problem) => {
                format!("waypoint {i} at ({x:.2}, {y:.2}, {z:.2}) {problem}")
            }
            // `make_safe` routes without home; the words, should it not.
            Block::Home { problem, .. } => format!(
                "no safe way between home and waypoint {i} at ({x:.2}, {y:.2}, {z:.2}): {problem}"
            ),
            Block::Segment {
                start: [ax, ay, az],
                ..
            } => {
                let s = self.safety;
                format!(
                    "segment {} -> {i} from ({ax:.2}, {ay:.2}, {az:.2}) to ({x:.2}, {y:.2}, {z:.2}) \
                     comes closer than {:.2} m to the mesh (or to unobserved space, with \
                     unknown_space = \"occupied\") or leaves the geofence, and no \
                     climb-traverse-descend route below the altitude limit {:.1} m is clear",
                    i.saturating_sub(1),
                    s.distance,
                    s.altitude.max_m
                )
            }
        }
    }

    /// The waypoints with a detour inserted before every blocked segment
    /// (the first segment leads from `start`, when given), and where each
    /// input waypoint now stands; or the first unsafe waypoint or segment
    /// without a detour.
    fn route(
        &self,
        start: Option<Start<'_>>,
        waypoints: &[PlannedView],
    ) -> std::result::Result<(Vec<PlannedView>, Vec<usize>), Box<Blocked>> {
        let s = self.safety;
        let mut out: Vec<PlannedView> = Vec::with_capacity(waypoints.len());
        let mut at = Vec::with_capacity(waypoints.len());
        for (i, w) in waypoints.iter().enumerate() {
            let p = Point3::from(w.position);
            if let Some(problem) = s.point_problem(&p) {
                return Err(Box::new(Blocked {
                    to: i,
                    block: Block::Point(problem),
                }));
            }
            let prev = match out.last() {
                Some(v) => Some((Point3::from(v.position), v.clone(), Some(v.clone()))),
                None => start.map(|(a, after)| (*a, after.unwrap_or(w).clone(), after.cloned())),
            };
            if let Some((a, prev, from)) = prev {
                let b = Point3::from(w.position);
                let from_vehicle =
                    out.is_empty() && start.is_some_and(|(_, after)| after.is_none());
                let ok = if from_vehicle {
                    s.leg_ok(&a, &b)
                } else {
                    s.segment_ok(&a, &b)
                };
                if !ok {
                    let detour = self.climb(&a, &b, from_vehicle).ok_or_else(|| {
                        Box::new(Blocked {
                            to: i,
                            block: Block::Segment {
                                start: a.into(),
                                from,
                            },
                        })
                    })?;
                    for (p, from) in detour.into_iter().zip([&prev, w]) {
                        out.push(bridge_view(from, p));
                    }
                }
            }
            at.push(out.len());
            out.push(w.clone());
        }
        Ok((out, at))
    }

    /// Climb over `a`, traverse, descend to `b`; `from_vehicle`: `a` is the
    /// vehicle's position ([`Safety::leg_ok`] for the climb).
    fn climb(
        &self,
        a: &Point3<f64>,
        b: &Point3<f64>,
        from_vehicle: bool,
    ) -> Option<[Point3<f64>; 2]> {
        let s = self.safety;
        let top = s.altitude.max_m.min(s.volume.max.z);
        let mut h = a.z.max(b.z) + CLIMB_STEP_M;
        while h <= top {
            let (a2, b2) = (Point3::new(a.x, a.y, h), Point3::new(b.x, b.y, h));
            let up = if from_vehicle {
                s.leg_ok(a, &a2)
            } else {
                s.segment_ok(a, &a2)
            };
            if up && s.segment_ok(&a2, &b2) && s.segment_ok(&b2, b) {
                return Some([a2, b2]);
            }
            h += CLIMB_STEP_M;
        }
        None
    }
}

/// What a waypoint is, for a drop reason: " (triplet 3)", " (a bridging view)".
fn role_note(v: &PlannedView) -> String {
    match (v.role, v.triplet_id) {
        (_, Some(t)) => format!(" (triplet {t})"),
        (Role::Bridge, None) => " (a bridging view)".into(),
        _ => String::new(),
    }
}

/// A bridging view at `p` that looks where `from` looks: a waypoint of a
/// climb-traverse-descend route (it keeps the photo a bridging view takes).
pub(crate) fn bridge_view(from: &PlannedView, p: Point3<f64>) -> PlannedView {
    PlannedView {
        position: p.into(),
        role: Role::Bridge,
        triplet_id: None,
        expected_gain: None,
        angle_bin_deg: None,
        ..from.clone()
    }
}
