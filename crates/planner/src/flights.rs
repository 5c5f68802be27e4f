//! The plan's waypoints cut into flights of one battery each.
//!
//! Every flight takes off at home, flies a run of consecutive waypoints
//! and returns home to land (the mission ends with return-to-launch). The
//! ways from home to a flight's first waypoint and from its last one back
//! are those of [`crate::home_way`]: a direct climb and level leg, or a
//! climb-traverse-descend over what blocks it, flown through a transit view
//! (one above the first waypoint makes the mission climb there at home,
//! cross level and descend; one above the last makes it climb before
//! return-to-launch flies home level). The mission takes off to at least the
//! first waypoint's height for that reason, and a vehicle whose
//! return-to-launch altitude (PX4 `RTL_RETURN_ALT`, ArduPilot `RTL_ALT`) is
//! above the last waypoint's height climbs there first, off the checked path.
//! A way no climb below the altitude limit clears refuses the plan: a
//! mission flying it would hit what blocks it (the planned path has already
//! dropped the triplets it cannot reach from home, [`crate::flight_path`]).
//!
//! With a flight-time limit the split is greedy: each flight takes the
//! longest run of waypoints that fits the limit and that can end there
//! (the leg home is clear, and the next flight's leg out is clear). Greedy
//! cutting is optimal for the number of flights when every cut point is
//! allowed (a later cut never forces more flights), which the leg rule only
//! restricts.

use nalgebra::Point3;
use vp_scene::flight_time::FlightParams;
use vp_scene::plan::{Flight, PlannedView};

use crate::error::{PlannerError, Result};
use crate::flight_path::bridge_view;
use crate::home_way::{HomeWays, Way};
use crate::safety::Safety;

/// The plan's waypoints with the transit views of each flight inserted,
/// and its flights (indices into those waypoints).
#[derive(Debug, Clone, PartialEq)]
pub struct Flights {
    /// The planned views, with a [`Role::Bridge`] view at the transit height
    /// before or after a flight whose way from or to home needs one.
    pub waypoints: Vec<PlannedView>,
    /// The flights, in order; each lists its waypoints (transit views included).
    pub flights: Vec<Flight>,
    /// Where each input waypoint stands in [`Self::waypoints`].
    pub index: Vec<usize>,
}

/// The flights of `waypoints` (see the module doc). Without a home the plan
/// is one flight whose figures leave out take-off, landing and the legs to
/// and from home; a flight-time limit then is refused (a split needs a home).
/// A way from or to home that neither the direct climb nor a transit
/// height clears refuses the plan: a mission flying it would hit what
/// blocks it.
pub fn assign_flights(
    safety: &Safety,
    home: Option<&Point3<f64>>,
    waypoints: &[PlannedView],
    params: &FlightParams,
) -> Result<Flights> {
    params
        .validate()
        .map_err(|e| PlannerError::Input(e.to_string()))?;
    let mut out = Flights {
        waypoints: Vec::with_capacity(waypoints.len() + 2),
        flights: Vec::new(),
        index: Vec::with_capacity(waypoints.len()),
    };
    if waypoints.is_empty() {
        return Ok(out);
    }
    let Some(home) = home else {
        if params.max_flight_time_s.is_some() {
            return Err(PlannerError::Input(
                "a flight-time limit (--max-flight-time, [mission] max_flight_time_s) splits \
                 the plan into flights from and back to home, and the plan has no home: give \
                 --home LAT,LON,ALT (or --home-from-first-image)"
                    .into(),
            ));
        }
        let points: Vec<Point3<f64>> = waypoints.iter().map(|v| Point3::from(v.position)).collect();
        let e = params.estimate(None, &points, points.len());
        out.waypoints = waypoints.to_vec();
        out.index = (0..points.len()).collect();
        out.flights.push(Flight {
            waypoints: (0..points.len()).collect(),
            distance_m: e.distance_m,
            duration_s: e.duration_s,
            from_home: false,
        });
        return Ok(out);
    };
    let legs = Legs::new(safety, home, waypoints);
    let n = waypoints.len();
    let Some(usable) = params.usable_s() else {
        // One flight, out to the first waypoint and back from the last.
        legs.check(0)?;
        legs.check(n - 1)?;
        out.push(&legs, params, home, 0, n - 1);
        return Ok(out);
    };
    let mut start = 0;
    while start < n {
        legs.check(start)?;
        let mut end = None;
        let mut alone_s = None;
        for e in start..n {
            let run = legs.run(start, e);
            let t = params.estimate(Some(home), &run, run.len()).duration_s;
            alone_s.get_or_insert(t);
            // Without the way back the run alone already takes too long:
            // no later waypoint can end this flight.
            if t - params.leg_s(&run[run.len() - 1], home) > usable {
                break;
            }
            let can_end = legs.way(e).is_some() && (e + 1 == n || legs.way(e + 1).is_some());
            if t <= usable && can_end {
                end = Some(e);
            }
        }
        let Some(e) = end else {
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
        out.push(&legs, params, home, start, e);
        start = e + 1;
    }
    Ok(out)
}

impl Flights {
    /// Appends the flight through planned waypoints `first..=last` from and
    /// back to `home`, with its transit views.
    fn push(
        &mut self,
        legs: &Legs<'_>,
        params: &FlightParams,
        home: &Point3<f64>,
        first: usize,
        last: usize,
    ) {
        let views = legs.views(first, last);
        let lead = usize::from(matches!(legs.way(first), Some(Way::Transit(_))));
        let from = self.waypoints.len();
        self.index
            .extend((0..=last - first).map(|i| from + lead + i));
        let run: Vec<Point3<f64>> = views.iter().map(|v| Point3::from(v.position)).collect();
        let e = params.estimate(Some(home), &run, run.len());
        self.waypoints.extend(views);
        self.flights.push(Flight {
            waypoints: (from..self.waypoints.len()).collect(),
            distance_m: e.distance_m,
            duration_s: e.duration_s,
            from_home: true,
        });
    }
}

/// The ways between home and each waypoint, found once each on demand.
/// The way back is the way out reversed.
struct Legs<'a> {
    home: HomeWays<'a>,
    views: &'a [PlannedView],
    ways: Vec<std::cell::OnceCell<Option<Way>>>,
}

impl<'a> Legs<'a> {
    fn new(safety: &'a Safety, home: &Point3<f64>, views: &'a [PlannedView]) -> Self {
        Legs {
            home: HomeWays::new(safety, home),
            views,
            ways: vec![std::cell::OnceCell::new(); views.len()],
        }
    }

    fn point(&self, i: usize) -> Point3<f64> {
        Point3::from(self.views[i].position)
    }

    /// The way between home and waypoint `i`, if one is clear.
    fn way(&self, i: usize) -> Option<Way> {
        *self.ways[i].get_or_init(|| self.home.way(&self.point(i)))
    }

    /// Waypoints `first..=last` with the transit views their ways from and
    /// to home need.
    fn views(&self, first: usize, last: usize) -> Vec<PlannedView> {
        let transit = |i: usize| match self.way(i) {
            Some(Way::Transit(h)) => {
                let p = self.point(i);
                Some(bridge_view(&self.views[i], Point3::new(p.x, p.y, h)))
            }
            _ => None,
        };
        let mut out = Vec::with_capacity(last + 3 - first);
        out.extend(transit(first));
        out.extend_from_slice(&self.views[first..=last]);
        out.extend(transit(last));
        out
    }

    /// The positions of [`Self::views`].
    fn run(&self, first: usize, last: usize) -> Vec<Point3<f64>> {
        self.views(first, last)
            .iter()
            .map(|v| Point3::from(v.position))
            .collect()
    }

    /// Refuses a waypoint the vehicle cannot fly to from home (or back).
    fn check(&self, i: usize) -> Result<()> {
        if self.way(i).is_some() {
            return Ok(());
        }
        let p = self.point(i);
        let why = self.home.blocked(&p).unwrap_or_default();
        let h = self.home.home();
        Err(PlannerError::Input(format!(
            "the way between home ({:.1}, {:.1}, {:.1}) and waypoint {i} at ({:.1}, {:.1}, \
             {:.1}) is not clear: {why}; take off from a clearer place (--home)",
            h.x, h.y, h.z, p.x, p.y, p.z
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
    fn a_wall_is_crossed_at_a_transit_height_and_a_roof_over_home_is_refused() {
        let w = views(&[[20.0, 0.0, 15.0], [25.0, 0.0, 15.0]]);
        let home = Point3::new(0.0, 0.0, 0.0);
        let p = FlightParams::default();
        let split = FlightParams {
            max_flight_time_s: Some(1000.0),
            ..p
        };
        let open = scene(&[]);
        let s = safety_for(&open, &cfg());
        let direct = assign_flights(&s, Some(&home), &w, &p).unwrap();
        assert_eq!(direct.waypoints, w, "nothing to cross: no transit view");
        // A 30 m wall at x = 10 between home and the waypoints: out and
        // back over it, one transit view above the first and the last
        // waypoint, at least the safety distance above the wall's top.
        let wall = scene(&[[10.0, -40.0, 10.0, 40.0, 0.0, 30.0]]);
        let s = safety_for(&wall, &cfg());
        for params in [&p, &split] {
            let f = assign_flights(&s, Some(&home), &w, params).unwrap();
            assert_eq!(f.waypoints.len(), 4);
            assert_eq!(f.index, vec![1, 2]);
            assert_eq!(f.flights[0].waypoints, vec![0, 1, 2, 3]);
            for t in [&f.waypoints[0], &f.waypoints[3]] {
                assert_eq!(t.role, Role::Bridge);
                assert!(t.position[2] >= 30.0 + s.distance, "{:?}", t.position);
            }
            assert_eq!(f.waypoints[0].position[..2], w[0].position[..2]);
            assert_eq!(f.waypoints[3].position[..2], w[1].position[..2]);
            // The estimate flies over the wall: longer than the direct way.
            assert!(f.flights[0].duration_s > direct.flights[0].duration_s);
        }
        // A wall up to the ceiling cannot be crossed: refused, naming it.
        let high = scene(&[[10.0, -40.0, 10.0, 40.0, 0.0, 60.0]]);
        let s = safety_for(&high, &cfg());
        for params in [&p, &split] {
            let e = assign_flights(&s, Some(&home), &w, params).unwrap_err();
            let m = e.to_string();
            assert!(m.contains("waypoint 0") && m.contains("level leg"), "{m}");
            assert!(e.is_input_error());
        }
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
            let Ok(Flights { flights, .. }) = assign_flights(&s, Some(&home), &w, &p) else {
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
