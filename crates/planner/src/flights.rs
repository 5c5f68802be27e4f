//! The plan's waypoints cut into flights of one battery each.
//!
//! Every flight takes off at home, flies a run of consecutive waypoints
//! and returns home to land (the mission ends with return-to-launch). The
//! legs from home to a flight's first waypoint and from its last one back
//! are checked as the vehicle flies them: straight up from home to the
//! waypoint's height, then level to it (and back the same way: level to
//! above home, then down). The climb starts on the ground, next to whatever
//! stands near the take-off point, so the safety distance cannot hold
//! there: the column above home must keep [`TAKEOFF_CLEARANCE_M`] from the
//! mesh from [`COLUMN_CHECK_FROM_M`] above home up (nothing overhangs the
//! take-off point). The level leg keeps the planner's safety
//! rules ([`Safety::leg_ok`](crate::safety::Safety::leg_ok), the rule of
//! the planned path's first leg). The mission takes off to at least the
//! first waypoint's height for that reason, and a vehicle whose
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
        // One flight: the legs home are checked and a blocked one is
        // reported in the plan (a split, below, refuses it instead). The
        // planned path itself starts from the vehicle's last position and
        // was checked from there; routing the legs from home around what
        // blocks them is the planner's next step.
        let last = points.len() - 1;
        let mut f = flight(params, Some(home), &points, 0, last);
        f.warning = legs
            .check(0)
            .and_then(|()| legs.check(last))
            .err()
            .map(|e| e.to_string());
        return Ok(vec![f]);
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
        warning: None,
    }
}

/// The ways between home and each waypoint (from the column's first checked point),
/// checked once each on demand.
struct Legs<'a> {
    safety: &'a Safety,
    column_base: Point3<f64>,
    points: &'a [Point3<f64>],
    clear: Vec<std::cell::OnceCell<bool>>,
}

impl<'a> Legs<'a> {
    fn new(safety: &'a Safety, home: &Point3<f64>, points: &'a [Point3<f64>]) -> Self {
        Legs {
            safety,
            column_base: home + Vector3::z() * COLUMN_CHECK_FROM_M,
            points,
            clear: vec![std::cell::OnceCell::new(); points.len()],
        }
    }

    /// The top of the climb above home for waypoint `w`: at its height.
    fn above(&self, w: &Point3<f64>) -> Point3<f64> {
        let b = self.column_base;
        Point3::new(b.x, b.y, w.z.max(b.z))
    }

    /// Straight up from home to the waypoint's height, then level to it.
    fn ok(&self, i: usize) -> bool {
        *self.clear[i].get_or_init(|| self.problem(i).is_none())
    }

    /// What blocks the way between home and waypoint `i`, in words.
    fn problem(&self, i: usize) -> Option<String> {
        let w = self.points[i];
        let above = self.above(&w);
        let clearance = self.safety.clearance();
        if !clearance.segment_is_clear(&self.column_base, &above, TAKEOFF_CLEARANCE_M) {
            return Some(format!(
                "the climb straight up from home to {:.1} m comes {:.1} m from the mesh \
                 (it must keep {TAKEOFF_CLEARANCE_M} m from {COLUMN_CHECK_FROM_M} m above home up)",
                above.z - self.column_base.z + COLUMN_CHECK_FROM_M,
                clearance.segment_distance(&self.column_base, &above)
            ));
        }
        if !self.safety.leg_ok(&above, &w) {
            let d = clearance.segment_distance(&above, &w);
            return Some(format!(
                "the level leg from above home at the waypoint's height comes {d:.1} m from the \
                 mesh (it must keep {} m), or too close to unobserved space, or leaves the \
                 flight limits",
                self.safety.distance
            ));
        }
        None
    }

    /// Refuses a waypoint the vehicle cannot fly to from home (or back).
    fn check(&self, i: usize) -> Result<()> {
        let Some(why) = self.problem(i) else {
            return Ok(());
        };
        let (h, p) = (self.column_base, self.points[i]);
        Err(PlannerError::Input(format!(
            "the way between home ({:.1}, {:.1}, {:.1}) and waypoint {i} at ({:.1}, {:.1}, \
             {:.1}) is not clear: {why}; take off from a clearer place (--home)",
            h.x,
            h.y,
            h.z - COLUMN_CHECK_FROM_M,
            p.x,
            p.y,
            p.z
        )))
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::config::PlannerConfig;
    use crate::inputs::safety_for;
    use vp_scene::plan::Role;
    use vp_scene::Mesh;

    /// A 100 m ground square at z = 0, a quad per `(x0, y0, x1, y1, z0, z1)`
    /// box side: walls (x0 = x1) and roofs (z0 = z1).
    fn scene(quads: &[[f64; 6]]) -> Mesh {
        let mut v = vec![
            Point3::new(-50.0, -50.0, 0.0),
            Point3::new(50.0, -50.0, 0.0),
            Point3::new(50.0, 50.0, 0.0),
            Point3::new(-50.0, 50.0, 0.0),
        ];
        let mut f = vec![[0, 1, 2], [0, 2, 3]];
        for q in quads {
            let n = v.len() as u32;
            let [x0, y0, x1, y1, z0, z1] = *q;
            if (z0 - z1).abs() < 1e-9 {
                v.extend([
                    Point3::new(x0, y0, z0),
                    Point3::new(x1, y0, z0),
                    Point3::new(x1, y1, z0),
                    Point3::new(x0, y1, z0),
                ]);
            } else {
                v.extend([
                    Point3::new(x0, y0, z0),
                    Point3::new(x1, y1, z0),
                    Point3::new(x1, y1, z1),
                    Point3::new(x0, y0, z1),
                ]);
            }
            f.extend([[n, n + 1, n + 2], [n, n + 2, n + 3]]);
        }
        Mesh::new(v, f, None).unwrap()
    }

    fn views(points: &[[f64; 3]]) -> Vec<PlannedView> {
        points
            .iter()
            .map(|&position| PlannedView {
                position,
                yaw_deg: 0.0,
                pitch_deg: -90.0,
                roll_deg: 0.0,
                role: Role::Grid,
                triplet_id: None,
                expected_gain: None,
                angle_bin_deg: None,
            })
            .collect()
    }

    fn cfg() -> PlannerConfig {
        PlannerConfig {
            flight_volume: Some([[-50.0, -50.0, 0.0], [50.0, 50.0, 60.0]]),
            // Exact geometry: the safety distance alone.
            safety: crate::SafetyConfig::exact(),
            ..PlannerConfig::default()
        }
    }

    #[test]
    fn a_wall_on_the_level_leg_or_a_roof_over_home_is_refused() {
        let w = views(&[[20.0, 0.0, 15.0], [25.0, 0.0, 15.0]]);
        let home = Point3::new(0.0, 0.0, 0.0);
        let p = FlightParams::default();
        let open = scene(&[]);
        let s = safety_for(&open, &cfg());
        assert_eq!(assign_flights(&s, Some(&home), &w, &p).unwrap().len(), 1);
        // A 30 m wall at x = 10 between home and the waypoints.
        // A split refuses a blocked way; one flight carries the warning.
        let split = FlightParams {
            max_flight_time_s: Some(1000.0),
            ..p
        };
        let wall = scene(&[[10.0, -40.0, 10.0, 40.0, 0.0, 30.0]]);
        let s = safety_for(&wall, &cfg());
        let e = assign_flights(&s, Some(&home), &w, &split).unwrap_err();
        assert!(
            e.to_string().contains("waypoint 0") && e.is_input_error(),
            "{e}"
        );
        let one = assign_flights(&s, Some(&home), &w, &p).unwrap();
        let warning = one[0].warning.as_deref().unwrap_or("");
        assert!(warning.contains("level leg"), "{warning}");
        // A roof 8 m over home: the climb hits it.
        let roof = scene(&[[-3.0, -3.0, 3.0, 3.0, 8.0, 8.0]]);
        let s = safety_for(&roof, &cfg());
        let e = assign_flights(&s, Some(&home), &w, &split).unwrap_err();
        assert!(e.to_string().contains("climb straight up"), "{e}");
        // Next to a 1.5 m bush 3 m from home: taking off is fine.
        let bush = scene(&[[3.0, -1.0, 3.0, 1.0, 0.0, 1.5]]);
        let s = safety_for(&bush, &cfg());
        assert!(assign_flights(&s, Some(&home), &w, &p).is_ok());
    }

    #[test]
    fn every_split_covers_each_waypoint_once_within_the_limit() {
        let s = safety_for(&scene(&[]), &cfg());
        let home = Point3::new(-40.0, -40.0, 0.0);
        for seed in 0..40u64 {
            // A seeded zig-zag of 5-60 waypoints at 10-40 m.
            let mut x = seed.wrapping_mul(0x9E37_79B9_7F4A_7C15) | 1;
            let mut next = || {
                x ^= x << 13;
                x ^= x >> 7;
                x ^= x << 17;
                (x % 10_000) as f64 / 10_000.0
            };
            let n = 5 + (next() * 55.0) as usize;
            let pts: Vec<[f64; 3]> = (0..n)
                .map(|_| {
                    [
                        next() * 80.0 - 40.0,
                        next() * 80.0 - 40.0,
                        10.0 + next() * 30.0,
                    ]
                })
                .collect();
            let w = views(&pts);
            let max = 200.0 + next() * 600.0;
            let p = FlightParams {
                max_flight_time_s: Some(max),
                ..FlightParams::default()
            };
            let Ok(flights) = assign_flights(&s, Some(&home), &w, &p) else {
                // Only a waypoint too far to reach alone may refuse.
                let alone = (0..n).any(|i| {
                    p.estimate(Some(&home), &[Point3::from(pts[i])], 1)
                        .duration_s
                        > max - p.reserve_s
                });
                assert!(
                    alone,
                    "seed {seed}: refused though every waypoint fits alone"
                );
                continue;
            };
            let flown: Vec<usize> = flights.iter().flat_map(|f| f.waypoints.clone()).collect();
            assert_eq!(flown, (0..n).collect::<Vec<_>>(), "seed {seed}");
            for f in &flights {
                assert!(f.duration_s <= max - p.reserve_s + 1e-9, "seed {seed}");
                let run: Vec<Point3<f64>> =
                    f.waypoints.iter().map(|&i| Point3::from(pts[i])).collect();
                let e = p.estimate(Some(&home), &run, run.len());
                assert!((e.duration_s - f.duration_s).abs() < 1e-9);
            }
        }
    }
}
