//! The vertical safety of a mission, checked before any item is built:
//! relative altitudes are heights above the take-off point (home), so a
//! mission needs a home on the ground, and every waypoint must lie between
//! a minimum height above it and a ceiling (120 m above take-off in most
//! jurisdictions). A waypoint below home is a drone flown into the ground;
//! one above the ceiling is an illegal flight.
//!
//! The limits of the values an operator types (hold time, speed, take-off
//! height) live here too, so that the CLI and Python refuse the same values
//! with the same allowed ranges.

use vp_scene::plan::{GeodeticOrigin, Home, Plan, VerticalDatum};

use super::{Autopilot, MissionOptions};
use crate::error::{MissionError, Result};
use crate::geodesy::LocalFrame;

/// Default lowest height of a waypoint above home, metres: below it the
/// vehicle brushes the launch area's grass, people and the operator.
pub const DEFAULT_MIN_HEIGHT_M: f64 = 2.0;
/// Default highest height above home, metres (EU, UK, US and most other
/// rules cap open-category flights at 120 m / 400 ft above ground).
pub const DEFAULT_CEILING_M: f64 = 120.0;
/// A ceiling above this is refused: no survey rule allows it, and a typo
/// (1200 for 120) must not pass.
pub const MAX_CEILING_M: f64 = 500.0;
/// A home farther than this from every waypoint is refused: far beyond
/// visual line of sight, most likely a typo or swapped coordinates.
pub const MAX_HOME_DISTANCE_M: f64 = 2000.0;

/// Allowed hold time at a waypoint, seconds.
pub const HOLD_RANGE_S: (f32, f32) = (0.0, 60.0);
/// Allowed mission ground speed, m/s (multirotors survey at 2-15 m/s;
/// 20 m/s is the top speed of the fastest survey quadcopters).
pub const SPEED_RANGE_M_S: (f32, f32) = (0.5, 20.0);

/// The altitude band a mission must stay in, metres above home.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct HeightLimits {
    /// Lowest height of any waypoint and of the take-off above home.
    pub min_height_m: f64,
    /// Highest height of any waypoint above home.
    pub ceiling_m: f64,
}

impl Default for HeightLimits {
    fn default() -> Self {
        HeightLimits {
            min_height_m: DEFAULT_MIN_HEIGHT_M,
            ceiling_m: DEFAULT_CEILING_M,
        }
    }
}

impl HeightLimits {
    /// Checks the band itself: finite, minimum >= 0, minimum below the
    /// ceiling, ceiling at most [`MAX_CEILING_M`].
    pub fn validate(&self) -> Result<()> {
        let ok = self.min_height_m.is_finite()
            && self.ceiling_m.is_finite()
            && self.min_height_m >= 0.0
            && self.min_height_m < self.ceiling_m
            && self.ceiling_m <= MAX_CEILING_M;
        if ok {
            Ok(())
        } else {
            Err(MissionError::InvalidInput(format!(
                "height limits: minimum height {} m and ceiling {} m above home: the minimum \
                 must be in [0, ceiling) and the ceiling in (0, {MAX_CEILING_M}] m",
                self.min_height_m, self.ceiling_m
            )))
        }
    }
}

/// The take-off point of a mission: `given` (a home from the command line
/// or the Python call, already in the plan's datum) or the plan's own.
/// Without either the mission is refused: the plan's origin may be in the
/// air (`vpctl colmap align` puts it at the first photo), and heights above
/// it would put every waypoint that far too low.
pub fn mission_home(plan: &Plan, given: Option<GeodeticOrigin>) -> Result<GeodeticOrigin> {
    if let Some(h) = given.or(plan.home.as_ref().map(|h| h.position)) {
        h.validate()?;
        return Ok(h);
    }
    Err(MissionError::InvalidInput(
        "the plan has no home (take-off point), and mission altitudes are heights above it: \
         give it with --home LAT,LON,ALT (on the ground where the vehicle takes off; in the \
         plan's datum, or add ,egm96 / ,ellipsoid), or plan again with `vpctl plan ... --home` \
         or `--home-from-first-image`"
            .into(),
    ))
}

/// Checks every waypoint of `plan` against `limits` above `home` and the
/// home's distance from the plan, naming the first waypoint at fault.
/// Returns the waypoints' heights above home, in plan order.
pub fn check_heights(
    plan: &Plan,
    frame: &LocalFrame,
    home: &GeodeticOrigin,
    limits: &HeightLimits,
) -> Result<Vec<f64>> {
    limits.validate()?;
    let home_enu = frame.to_enu(*home);
    let mut nearest = f64::INFINITY;
    let mut heights = Vec::with_capacity(plan.waypoints.len());
    for (i, view) in plan.waypoints.iter().enumerate() {
        let h = frame.to_geodetic(view.position).alt_m - home.alt_m;
        let [x, y, _] = view.position;
        nearest = nearest.min((x - home_enu[0]).hypot(y - home_enu[1]));
        if h < limits.min_height_m {
            return Err(MissionError::InvalidInput(format!(
                "waypoint {i} is {h:.2} m above home, below the minimum of {} m{}: re-plan with \
                 a higher flight volume, or check the home (its altitude {:.2} m must be the \
                 ground where the vehicle takes off, in the plan's datum)",
                limits.min_height_m,
                if h < 0.0 {
                    " (BELOW the take-off point)"
                } else {
                    ""
                },
                home.alt_m
            )));
        }
        if h > limits.ceiling_m {
            return Err(MissionError::InvalidInput(format!(
                "waypoint {i} is {h:.2} m above home, above the ceiling of {} m: re-plan with a \
                 lower flight volume, or raise --ceiling where the rules allow",
                limits.ceiling_m
            )));
        }
        heights.push(h);
    }
    // An empty plan (every triplet dropped) has no waypoint to be far from.
    if nearest.is_finite() && nearest > MAX_HOME_DISTANCE_M {
        return Err(MissionError::InvalidInput(format!(
            "the home {:.7},{:.7} is {:.0} m from the nearest waypoint (more than {MAX_HOME_DISTANCE_M} \
             m): check --home (latitude first, then longitude)",
            home.lat_deg, home.lon_deg, nearest
        )));
    }
    Ok(heights)
}

/// What an operator sets for a mission (`vpctl mission` flags, the Python
/// keywords): the one place both turn into [`MissionOptions`].
#[derive(Debug, Clone, PartialEq)]
pub struct UserMissionOptions {
    /// Mission conventions.
    pub autopilot: Autopilot,
    /// Hold at each waypoint, seconds.
    pub hold_s: f32,
    /// Ground speed, m/s.
    pub speed_m_s: Option<f32>,
    /// Take-off height above home, metres (0: no take-off item).
    pub takeoff_m: f32,
    /// End with return-to-launch.
    pub return_to_launch: bool,
    /// A home that overrides the plan's, with its altitude's datum if said.
    pub home: Option<(GeodeticOrigin, Option<VerticalDatum>)>,
    /// The height band above home.
    pub limits: HeightLimits,
}

impl UserMissionOptions {
    /// The mission options for `plan`: values checked against their ranges,
    /// the home converted into the plan's datum (refused where the datums
    /// cannot be reconciled).
    pub fn resolve(&self, plan: &Plan) -> Result<MissionOptions> {
        let mut o = MissionOptions::from_user(
            self.autopilot,
            self.hold_s,
            self.speed_m_s,
            self.takeoff_m,
            self.return_to_launch,
        )?;
        self.limits.validate()?;
        o.limits = self.limits;
        if let Some((position, datum)) = self.home {
            let home = Home::in_datum(position, datum, plan.vertical_datum, "--home")
                .map_err(|e| MissionError::InvalidInput(format!("home: {e}")))?;
            o.home = Some(home.position);
        }
        Ok(o)
    }
}

/// Refuses `v` outside `[lo, hi]`, naming the value and the allowed range.
pub(crate) fn check_range(what: &str, v: f32, (lo, hi): (f32, f32), unit: &str) -> Result<()> {
    if v.is_finite() && (lo..=hi).contains(&v) {
        Ok(())
    } else {
        Err(MissionError::InvalidInput(format!(
            "{what} {v} {unit} is out of range: allowed {lo} to {hi} {unit}"
        )))
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use vp_scene::plan::{PlannedView, Role};

    fn plan_at(z: &[f64]) -> Plan {
        let mut p = Plan::new(Some(GeodeticOrigin::new(46.0, 10.3, 400.0).unwrap()));
        for (i, &z) in z.iter().enumerate() {
            p.waypoints.push(PlannedView {
                position: [i as f64 * 5.0, 0.0, z],
                yaw_deg: 0.0,
                pitch_deg: -90.0,
                roll_deg: 0.0,
                role: Role::Grid,
                triplet_id: None,
                expected_gain: None,
                angle_bin_deg: None,
            });
        }
        p
    }

    #[test]
    fn an_airborne_origin_without_a_home_is_refused() {
        let p = plan_at(&[30.0]);
        let e = mission_home(&p, None).unwrap_err().to_string();
        assert!(e.contains("no home") && e.contains("--home"), "{e}");
    }

    #[test]
    fn heights_are_measured_from_home_not_from_the_origin() {
        // The origin is the first photo, 40 m up; the vehicle takes off 40 m
        // below it. A waypoint at ENU z = -10 is 30 m above the ground.
        let mut p = plan_at(&[-10.0, 0.0]);
        let o = p.origin.unwrap();
        let home = GeodeticOrigin {
            alt_m: o.alt_m - 40.0,
            ..o
        };
        p.home = Some(Home {
            position: home,
            source: "test".into(),
        });
        let frame = LocalFrame::new(o).unwrap();
        let h = check_heights(
            &p,
            &frame,
            &mission_home(&p, None).unwrap(),
            &HeightLimits::default(),
        )
        .unwrap();
        assert!(
            (h[0] - 30.0).abs() < 1e-3 && (h[1] - 40.0).abs() < 1e-3,
            "{h:?}"
        );
    }

    #[test]
    fn below_home_and_above_the_ceiling_name_the_waypoint() {
        let p = plan_at(&[30.0, -5.0]);
        let o = p.origin.unwrap();
        let frame = LocalFrame::new(o).unwrap();
        let e = check_heights(&p, &frame, &o, &HeightLimits::default())
            .unwrap_err()
            .to_string();
        assert!(e.contains("waypoint 1") && e.contains("BELOW"), "{e}");
        let p = plan_at(&[30.0, 50.0, 130.0]);
        let e = check_heights(&p, &frame, &o, &HeightLimits::default())
            .unwrap_err()
            .to_string();
        assert!(
            e.contains("waypoint 2") && e.contains("ceiling of 120"),
            "{e}"
        );
        let raised = HeightLimits {
            ceiling_m: 150.0,
            ..HeightLimits::default()
        };
        assert!(check_heights(&p, &frame, &o, &raised).is_ok());
    }

    #[test]
    fn an_empty_plan_is_not_refused_for_a_far_home() {
        // Every triplet dropped: nothing to fly, nothing to be far from.
        let p = plan_at(&[]);
        let o = p.origin.unwrap();
        let frame = LocalFrame::new(o).unwrap();
        assert!(check_heights(&p, &frame, &o, &HeightLimits::default())
            .unwrap()
            .is_empty());
    }

    #[test]
    fn a_home_kilometres_away_is_refused() {
        let p = plan_at(&[30.0]);
        let o = p.origin.unwrap();
        let frame = LocalFrame::new(o).unwrap();
        // Latitude and longitude swapped: thousands of kilometres off.
        let swapped = GeodeticOrigin {
            lat_deg: o.lon_deg,
            lon_deg: o.lat_deg,
            ..o
        };
        let e = check_heights(&p, &frame, &swapped, &HeightLimits::default())
            .unwrap_err()
            .to_string();
        assert!(e.contains("from the nearest waypoint"), "{e}");
    }

    #[test]
    fn limits_refuse_nonsense() {
        for (min, ceil) in [
            (-1.0, 120.0),
            (50.0, 40.0),
            (2.0, 1200.0),
            (f64::NAN, 120.0),
        ] {
            let l = HeightLimits {
                min_height_m: min,
                ceiling_m: ceil,
            };
            assert!(l.validate().is_err(), "{min} {ceil}");
        }
        assert!(check_range("hold", -1.0, HOLD_RANGE_S, "s")
            .unwrap_err()
            .to_string()
            .contains("allowed 0 to 60 s"));
    }
}
