//! The way between home and a waypoint, as the vehicle flies it.
//!
//! A flight takes off at home and returns there to land (the mission ends
//! with return-to-launch). The way out to a waypoint is straight up from
//! home to the waypoint's height, then level to it; the way back is the
//! same reversed (level to above home, then down). The climb starts on the
//! ground, next to whatever stands near the take-off point, so the safety
//! distance cannot hold there: the column above home must keep
//! [`TAKEOFF_CLEARANCE_M`] from the mesh from [`COLUMN_CHECK_FROM_M`] above
//! home up (nothing overhangs the take-off point). The level leg keeps the
//! planner's safety rules ([`Safety::leg_ok`], the rule of the planned
//! path's first leg).
//!
//! When something blocks that level leg (a tree line or a building between
//! home and the survey), the vehicle goes over it the way the planner's own
//! detours do (climb-traverse-descend): up at home to the lowest clear
//! transit height, level to above the waypoint, down to it. Without a clear
//! height below the altitude limit there is no way: the planner drops the
//! waypoint's triplet ([`crate::flight_path`]) or, for waypoints it was
//! given, refuses them ([`crate::flights`]).

use nalgebra::{Point3, Vector3};

use crate::safety::Safety;

/// Clearance of the take-off column from the mesh, metres: about the
/// half-span of a survey multirotor. The check is for what overhangs the
/// take-off point (a canopy, a roof, an overhanging rock); what stands
/// beside it the operator sees and chooses the spot by, and the safety
/// distance applies from the level legs on.
pub const TAKEOFF_CLEARANCE_M: f64 = 0.5;
/// Height above home where the column check starts, metres: 3 m above
/// the clearance, as a home altitude from standard GNSS (or read off a
/// map) may lie that far below the real ground.
pub const COLUMN_CHECK_FROM_M: f64 = TAKEOFF_CLEARANCE_M + 3.0;
/// Height step of the climb-traverse-descend searches, metres (the ways
/// from home here, the path's detours in [`crate::flight_path`]).
pub(crate) const CLIMB_STEP_M: f64 = 2.0;

/// How the vehicle gets between home and a waypoint.
#[derive(Debug, Clone, Copy, PartialEq)]
pub(crate) enum Way {
    /// Straight up from home to the waypoint's height, then level to it.
    Direct,
    /// Straight up from home to this height (z), level to above the
    /// waypoint, then straight down to it: a climb-traverse-descend route
    /// over what blocks the direct way.
    Transit(f64),
}

/// The ways from one home (see the module doc).
pub(crate) struct HomeWays<'a> {
    safety: &'a Safety,
    /// The column's first checked point, [`COLUMN_CHECK_FROM_M`] above home.
    column_base: Point3<f64>,
}

impl<'a> HomeWays<'a> {
    /// The ways from `home` under the rules of `safety`.
    pub(crate) fn new(safety: &'a Safety, home: &Point3<f64>) -> Self {
        HomeWays {
            safety,
            column_base: home + Vector3::z() * COLUMN_CHECK_FROM_M,
        }
    }

    /// The way between home and `w`, if one is clear.
    pub(crate) fn way(&self, w: &Point3<f64>) -> Option<Way> {
        if self.direct_ok(w) {
            return Some(Way::Direct);
        }
        self.transit(w).map(Way::Transit)
    }

    /// Whether the direct way to `w` is clear ([`Self::problem`]'s rules,
    /// without its words and exact distances).
    fn direct_ok(&self, w: &Point3<f64>) -> bool {
        let above = self.above_home(w.z);
        self.column_ok(&above) && self.safety.leg_ok(&above, w)
    }

    /// `None` when a way between home and `w` is clear; otherwise why not,
    /// in words, ending with the altitude limit that stopped the climb.
    pub(crate) fn blocked(&self, w: &Point3<f64>) -> Option<String> {
        if self.way(w).is_some() {
            return None;
        }
        let why = self.problem(w).unwrap_or_default();
        Some(format!(
            "{why}, and no climb over it below the altitude limit {:.1} m is clear either",
            self.ceiling()
        ))
    }

    /// Home, as given.
    pub(crate) fn home(&self) -> Point3<f64> {
        self.column_base - Vector3::z() * COLUMN_CHECK_FROM_M
    }

    /// The highest a transit may climb.
    fn ceiling(&self) -> f64 {
        let s = self.safety;
        s.altitude.max_m.min(s.volume.max.z)
    }

    /// The top of the climb above home to height `z`.
    fn above_home(&self, z: f64) -> Point3<f64> {
        let b = self.column_base;
        Point3::new(b.x, b.y, z.max(b.z))
    }

    /// Whether the column above home is clear up to `top`.
    fn column_ok(&self, top: &Point3<f64>) -> bool {
        self.safety
            .clearance()
            .segment_is_clear(&self.column_base, top, TAKEOFF_CLEARANCE_M)
    }

    /// The lowest transit height (every [`CLIMB_STEP_M`] up to the altitude
    /// limit) whose climb, level leg and descent to `w` are all clear.
    fn transit(&self, w: &Point3<f64>) -> Option<f64> {
        let s = self.safety;
        let top = self.ceiling();
        let mut h = w.z.max(self.column_base.z) + CLIMB_STEP_M;
        while h <= top {
            let (up, over) = (self.above_home(h), Point3::new(w.x, w.y, h));
            if self.column_ok(&up) && s.leg_ok(&up, &over) && s.segment_ok(&over, w) {
                return Some(h);
            }
            h += CLIMB_STEP_M;
        }
        None
    }

    /// What blocks the direct way between home and `w`, in words.
    fn problem(&self, w: &Point3<f64>) -> Option<String> {
        let above = self.above_home(w.z);
        let clearance = self.safety.clearance();
        if !self.column_ok(&above) {
            return Some(format!(
                "the climb straight up from home to {:.1} m comes {:.1} m from the mesh \
                 (it must keep {TAKEOFF_CLEARANCE_M} m from {COLUMN_CHECK_FROM_M} m above home up)",
                above.z - self.column_base.z + COLUMN_CHECK_FROM_M,
                clearance.segment_distance(&self.column_base, &above)
            ));
        }
        self.safety
            .leg_problem(&above, w)
            .map(|p| format!("the level leg from above home at the waypoint's height {p}"))
    }
}
