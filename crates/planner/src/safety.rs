//! Safety rules every planned position and path segment obeys: the safety
//! distance to the mesh and, with `unknown_space = "occupied"`, to space no
//! camera has observed ([`crate::free_space`]); the flight volume, the
//! geofence and the altitude band.

use nalgebra::{Point2, Point3, Vector3};
use vp_scene::clearance::Clearance;
use vp_scene::occupancy::FreeSpace;
use vp_scene::plan::AltitudeLimits;
use vp_scene::raycast::RayCaster;
use vp_scene::roi::point_in_polygon;
use vp_scene::{Aabb, Mesh};

/// Margin added to the safety distance in the `f32` clearance checks, so
/// that round-off never lets a position undershoot it (vp-scene clearance docs).
pub const CLEARANCE_MARGIN_M: f64 = 1e-3;

/// "Straight down", tilted by a milliradian: the vp-scene ray caster (obvhs)
/// misses every hit of an exactly axis-aligned ray (seen here on procedural
/// sites), so the free-space test never casts one.
const DOWN: Vector3<f64> = Vector3::new(1e-3, 2e-3, -1.0);

/// The safety constraints of one planning call.
pub struct Safety {
    clearance: Clearance,
    /// Observed-free space; `None`: unknown space counts as free.
    free_space: Option<FreeSpace>,
    /// Minimum distance to the mesh, metres.
    pub distance: f64,
    /// Flight volume.
    pub volume: Aabb,
    /// Inclusion polygon in x/y, if any.
    pub geofence: Option<Vec<[f64; 2]>>,
    /// Altitude band (z).
    pub altitude: AltitudeLimits,
}

impl Safety {
    /// Builds the clearance structure of `mesh`.
    pub fn new(
        mesh: &Mesh,
        distance: f64,
        volume: Aabb,
        geofence: Option<Vec<[f64; 2]>>,
        altitude: AltitudeLimits,
    ) -> Self {
        Safety {
            clearance: Clearance::new(mesh),
            free_space: None,
            distance,
            volume,
            geofence,
            altitude,
        }
    }

    /// These rules, and also the safety distance to unknown space.
    pub fn with_free_space(mut self, free_space: FreeSpace) -> Self {
        self.free_space = Some(free_space);
        self
    }

    /// The clearance queries of the mesh.
    pub fn clearance(&self) -> &Clearance {
        &self.clearance
    }

    /// The observed-free space, when unknown space counts as an obstacle.
    pub fn free_space(&self) -> Option<&FreeSpace> {
        self.free_space.as_ref()
    }

    /// What the rules say about `p`, for an error message ("is ...", with
    /// the config key to change): `None` when [`Safety::point_ok`].
    pub fn point_problem(&self, p: &Point3<f64>) -> Option<String> {
        let (lo, hi, d) = (self.volume.min, self.volume.max, self.distance);
        if !self.volume.contains(p) {
            Some(format!(
                "is outside the flight volume [{:.2}, {:.2}, {:.2}] .. [{:.2}, {:.2}, {:.2}] \
                 (`flight_volume` in the planner config; for a grid: a smaller region of interest \
                 or another height)",
                lo.x, lo.y, lo.z, hi.x, hi.y, hi.z
            ))
        } else if p.z < self.altitude.min_m || p.z > self.altitude.max_m {
            Some(format!(
                "is outside the altitude limits {:.2} .. {:.2} m (`altitude_limits` in the planner \
                 config; for a grid: another --height)",
                self.altitude.min_m, self.altitude.max_m
            ))
        } else if !self.within_limits(p) {
            Some("is outside the geofence (`geofence` in the planner config)".into())
        } else if !self.clearance.point_is_clear(p, d + CLEARANCE_MARGIN_M) {
            Some(format!(
                "is {:.2} m from the mesh, closer than the clearance {d:.2} m (the safety distance \
                 `safety_distance_m` + `geometry_margin_m` + the position margin of `[safety] \
                 gnss` in the planner config, which `vpctl plan` prints; for a grid: a larger \
                 --height)",
                self.clearance.distance(p)
            ))
        } else if !self
            .free_space
            .as_ref()
            .is_none_or(|f| f.point_is_clear(p, d))
        {
            Some(format!(
                "is closer than the clearance {d:.2} m to space no camera has observed \
                 (`unknown_space = \"occupied\"` in the planner config: fly where the cameras \
                 have looked, or \"free\" to accept the risk)"
            ))
        } else {
            None
        }
    }

    /// Inside the flight volume, the altitude band and the geofence.
    pub fn within_limits(&self, p: &Point3<f64>) -> bool {
        self.volume.contains(p)
            && p.z >= self.altitude.min_m
            && p.z <= self.altitude.max_m
            && self
                .geofence
                .as_ref()
                .is_none_or(|g| point_in_polygon(&Point2::new(p.x, p.y), g))
    }

    /// Within the limits and at least the safety distance from the mesh
    /// and from unknown space (when it counts).
    pub fn point_ok(&self, p: &Point3<f64>) -> bool {
        self.within_limits(p)
            && self
                .clearance
                .point_is_clear(p, self.distance + CLEARANCE_MARGIN_M)
            && self
                .free_space
                .as_ref()
                .is_none_or(|f| f.point_is_clear(p, self.distance))
    }

    /// [`Safety::point_ok`] and in free air: straight down there is a
    /// surface seen from above (not under the terrain, not inside an object
    /// open at the bottom).
    pub fn in_free_space(&self, p: &Point3<f64>, caster: &RayCaster, mesh: &Mesh) -> bool {
        self.point_ok(p)
            && caster
                .closest_hit(p, &DOWN.normalize(), f64::INFINITY)
                .is_some_and(|h| mesh.face_normal(h.face as usize).z > 0.0)
    }

    /// Both ends within the limits, the straight segment inside the geofence
    /// (the volume and the altitude band are convex) and at least the safety
    /// distance from the mesh and from unknown space (when it counts)
    /// everywhere.
    pub fn segment_ok(&self, a: &Point3<f64>, b: &Point3<f64>) -> bool {
        self.within_limits(a)
            && self.within_limits(b)
            && self
                .geofence
                .as_ref()
                .is_none_or(|g| !crosses_polygon(a, b, g))
            && self
                .clearance
                .segment_is_clear(a, b, self.distance + CLEARANCE_MARGIN_M)
            && self
                .free_space
                .as_ref()
                .is_none_or(|f| f.segment_is_clear(a, b, self.distance))
    }

    /// The leg from the vehicle's position `a` (wherever it is: it may be
    /// outside the limits, e.g. before entering the geofence) to `b`: `b`
    /// within the limits and the segment [`Safety::segment_ok`] apart from
    /// the limits at `a`, and apart from unknown space near `a`: the leg
    /// may leave the vehicle's position closer to unknown space than the
    /// safety distance as long as it gets no closer (the end of a flight
    /// lies at the edge of what its cameras pictured; [`FreeSpace::leg_is_clear`]).
    pub fn leg_ok(&self, a: &Point3<f64>, b: &Point3<f64>) -> bool {
        self.within_limits(b)
            && self
                .clearance
                .segment_is_clear(a, b, self.distance + CLEARANCE_MARGIN_M)
            && self
                .free_space
                .as_ref()
                .is_none_or(|f| f.leg_is_clear(a, b, self.distance))
    }

    /// What breaks [`Safety::leg_ok`] for the leg `a` to `b`, in words
    /// ("comes ...", with what to change): `None` when it holds.
    pub fn leg_problem(&self, a: &Point3<f64>, b: &Point3<f64>) -> Option<String> {
        let d = self.distance;
        if !self.within_limits(b) {
            let why = self.point_problem(b);
            Some(format!(
                "ends at a point that {}",
                why.as_deref().unwrap_or("is outside the flight limits")
            ))
        } else if !self
            .clearance
            .segment_is_clear(a, b, d + CLEARANCE_MARGIN_M)
        {
            Some(format!(
                "comes {:.1} m from the mesh (it must keep the clearance {d:.2} m)",
                self.clearance.segment_distance(a, b)
            ))
        } else if !self
            .free_space
            .as_ref()
            .is_none_or(|f| f.leg_is_clear(a, b, d))
        {
            Some(format!(
                "comes closer than the clearance {d:.2} m to space no camera has observed \
                 (`unknown_space = \"occupied\"` in the planner config: fly the cameras over \
                 it first, or \"free\" to accept the risk)"
            ))
        } else {
            None
        }
    }

    /// The box positions are drawn from: the flight volume cut to the altitude band.
    pub fn sampling_box(&self) -> Aabb {
        let mut b = self.volume;
        b.min.z = b.min.z.max(self.altitude.min_m);
        b.max.z = b.max.z.min(self.altitude.max_m);
        b
    }
}

/// Whether the x/y projection of segment a-b properly crosses a polygon edge.
fn crosses_polygon(a: &Point3<f64>, b: &Point3<f64>, poly: &[[f64; 2]]) -> bool {
    let cross = |o: [f64; 2], p: [f64; 2], q: [f64; 2]| {
        (p[0] - o[0]) * (q[1] - o[1]) - (p[1] - o[1]) * (q[0] - o[0])
    };
    let (p, q) = ([a.x, a.y], [b.x, b.y]);
    let n = poly.len();
    (0..n).any(|i| {
        let (r, s) = (poly[i], poly[(i + 1) % n]);
        let d1 = cross(r, s, p);
        let d2 = cross(r, s, q);
        let d3 = cross(p, q, r);
        let d4 = cross(p, q, s);
        d1 * d2 < 0.0 && d3 * d4 < 0.0
    })
}

#[cfg(test)]
mod tests {
    use super::*;
    use vp_scene::procedural::shapes;

    #[test]
    fn geofence_and_altitude_bound_points_and_segments() {
        let mesh = shapes::plane(100.0, 100.0, 4, 4);
        let fence = vec![
            [-20.0, -20.0],
            [20.0, -20.0],
            [20.0, 20.0],
            [0.0, 0.0],
            [-20.0, 20.0],
        ];
        let s = Safety::new(
            &mesh,
            5.0,
            Aabb {
                min: Point3::new(-50.0, -50.0, -10.0),
                max: Point3::new(50.0, 50.0, 60.0),
            },
            Some(fence),
            AltitudeLimits {
                min_m: 0.0,
                max_m: 40.0,
            },
        );
        assert!(s.point_ok(&Point3::new(0.0, -10.0, 10.0)));
        assert!(!s.point_ok(&Point3::new(0.0, -10.0, 4.0)), "too close");
        assert!(!s.point_ok(&Point3::new(0.0, -10.0, 45.0)), "too high");
        assert!(!s.point_ok(&Point3::new(0.0, 10.0, 10.0)), "in the notch");
        // Both ends inside, but the segment crosses the notch of the fence.
        let (a, b) = (
            Point3::new(-15.0, 10.0, 10.0),
            Point3::new(15.0, 10.0, 10.0),
        );
        assert!(s.point_ok(&a) && s.point_ok(&b) && !s.segment_ok(&a, &b));
        assert!(s.segment_ok(&a, &Point3::new(-15.0, -15.0, 10.0)));
    }
}
