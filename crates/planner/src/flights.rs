//! The plan's waypoints cut into flights of one battery each.
//!
//! Every flight takes off at home, flies a run of consecutive waypoints
//! and returns home to land (the mission ends with return-to-launch). The
//! legs from home to a flight's first waypoint and from its last one back
//! are checked by the same rule as the first leg of the planned path
//! ([`Safety::leg_ok`](crate::safety::Safety::leg_ok)) as the vehicle flies
//! them: straight up from home to the waypoint's height, then level to it
//! (and back the same way: level to above home, then down). The check
//! starts [`takeoff_column_m`] above home: the vehicle starts on the
//! ground, inside any safety distance. The mission takes off to at least
//! the first waypoint's height for that reason, and a vehicle whose
//! return-to-launch altitude (PX4 `RTL_RETURN_ALT`, ArduPilot `RTL_ALT`) is
//! above the last waypoint's height climbs there first, off the checked path.
//!
//! With a flight-time limit the split is greedy: each flight takes the
//! longest run of waypoints that fits the limit and that can end there
//! (the leg home is clear, and the next flight's leg out is clear). Greedy
//! cutting is optimal for the number of flights when every cut point is
//! allowed (a later cut never forces more flights), which the leg rule only
//! restricts.

use nalgebra::{Point3, Vector3};
use vp_scene::flight_time::FlightParams;
use vp_scene::plan::{Flight, PlannedView};

use crate::error::{PlannerError, Result};
use crate::safety::Safety;

/// Height of the take-off column above home: the safety distance plus one
/// metre, where the checked legs begin.
pub fn takeoff_column_m(safety: &Safety) -> f64 {
    safety.distance + 1.0
}

/// The flights of `waypoints` (see the module doc). Without a home the plan
/// is one flight whose figures leave out take-off, landing and the legs to
/// and from home; a flight-time limit then is refused (a split needs a home).
pub fn assign_flights(
    safety: &Safety,
    home: Option<&Point3<f64>>,
    waypoints: &[PlannedView],
    params: &FlightParams,
) -> Result<Vec<Flight>> {
    params
        .validate()
        .map_err(|e| PlannerError::Input(e.to_string()))?;
    if waypoints.is_empty() {
        return Ok(Vec::new());
    }
    let points: Vec<Point3<f64>> = waypoints.iter().map(|v| Point3::from(v.position)).collect();
    let Some(home) = home else {
        if params.max_flight_time_s.is_some() {
            return Err(PlannerError::Input(
                "a flight-time limit (--max-flight-time, [mission] max_flight_time_s) splits \
                 the plan into flights from and back to home, and the plan has no home: give \
                 --home LAT,LON,ALT (or --home-from-first-image)"
                    .into(),
            ));
        }
        return Ok(vec![flight(params, None, &points, 0, points.len() - 1)]);
    };
    let legs = Legs::new(safety, home, &points);
    let Some(usable) = params.usable_s() else {
        let last = points.len() - 1;
        legs.check(0)?;
        legs.check(last)?;
        return Ok(vec![flight(params, Some(home), &points, 0, last)]);
    };
    let mut flights = Vec::new();
    let mut start = 0;
    while start < points.len() {
        legs.check(start)?;
        let mut end = None;
        let mut alone_s = None;
        for e in start..points.len() {
            let f = flight(params, Some(home), &points, start, e);
            alone_s.get_or_insert(f.duration_s);
            // Without the way back the run alone already takes too long:
            // no later waypoint can end this flight.
            let out_and_run = f.duration_s - params.leg_s(&points[e], home);
            if out_and_run > usable {
                break;
            }
            let can_end = legs.ok(e) && (e + 1 == points.len() || legs.ok(e + 1));
            if f.duration_s <= usable && can_end {
                end = Some((e, f));
            }
        }
        let Some((e, f)) = end else {
            return Err(PlannerError::Input(match alone_s {
                Some(t) if t > usable => format!(
                    "waypoint {start} alone cannot be flown in one flight: from home and back \
                     it takes {t:.0} s, more than the {usable:.0} s a flight may take (max \
                     flight time less the reserve); raise --max-flight-time or take off \
                     closer to it (--home)"
                ),
                _ => format!(
                    "no flight starting at waypoint {start} can end within {usable:.0} s at a \
                     waypoint whose leg back to home is clear: take off elsewhere (--home) or \
                     raise --max-flight-time"
                ),
            }));
        };
        flights.push(f);
        start = e + 1;
    }
    Ok(flights)
}

/// The flight through waypoints `first..=last`.
fn flight(
    params: &FlightParams,
    home: Option<&Point3<f64>>,
    points: &[Point3<f64>],
    first: usize,
    last: usize,
) -> Flight {
    let e = params.estimate(home, &points[first..=last], last + 1 - first);
    Flight {
        waypoints: (first..=last).collect(),
        distance_m: e.distance_m,
        duration_s: e.duration_s,
        from_home: home.is_some(),
    }
}

/// The legs between the top of the take-off column and each waypoint,
/// checked once each on demand.
struct Legs<'a> {
    safety: &'a Safety,
    top: Point3<f64>,
    points: &'a [Point3<f64>],
    clear: Vec<std::cell::OnceCell<bool>>,
}

impl<'a> Legs<'a> {
    fn new(safety: &'a Safety, home: &Point3<f64>, points: &'a [Point3<f64>]) -> Self {
        Legs {
            safety,
            top: home + Vector3::z() * takeoff_column_m(safety),
            points,
            clear: vec![std::cell::OnceCell::new(); points.len()],
        }
    }

    /// Straight up from the column top to the waypoint's height, then level to it.
    fn ok(&self, i: usize) -> bool {
        *self.clear[i].get_or_init(|| {
            let w = self.points[i];
            let above = Point3::new(self.top.x, self.top.y, w.z.max(self.top.z));
            self.safety.leg_ok(&self.top, &above) && self.safety.leg_ok(&above, &w)
        })
    }

    /// Refuses a waypoint the vehicle cannot fly to from home (or back).
    fn check(&self, i: usize) -> Result<()> {
        if self.ok(i) {
            return Ok(());
        }
        let (t, p) = (self.top, self.points[i]);
        Err(PlannerError::Input(format!(
            "the leg between home (straight up from {:.1}, {:.1}, {:.1}, then level) and \
             waypoint {i} at ({:.1}, {:.1}, {:.1}) comes closer than {} m to the mesh (or to \
             unobserved space) or leaves the limits: take off from a clearer place (--home)",
            t.x, t.y, t.z, p.x, p.y, p.z, self.safety.distance
        )))
    }
}
