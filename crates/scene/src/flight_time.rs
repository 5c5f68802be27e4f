//! How long a multirotor takes to fly a plan, and how long it may fly on
//! one battery: the `[mission]` section of the planner's configuration.
//!
//! A survey mission stops at every photo waypoint (hover, shoot, go on), so
//! each leg starts and ends at rest. A leg's time is the longer of its
//! horizontal and its vertical motion, each a trapezoidal speed profile
//! (accelerate at `acceleration_m_s2` to the cruise speed, or to the climb or
//! descent rate, cruise, brake at the same rate; a short leg never reaches
//! the cruise speed). Multirotors move both axes at once, each under its own
//! speed limit, which is why the longer of the two sets the time. A flight
//! from home adds the take-off and landing overhead, the climb straight up
//! from home to the first waypoint's height and the level leg to it, and on
//! the way back the level leg at the last waypoint's height to above home
//! and the descent: the path the planner checks (`vp_planner::flights`).
//!
//! The defaults are a conservative survey setting for a DJI Phantom 4 Pro
//! class aircraft, well below its rated limits (DJI: 14 m/s in P-mode, 6 m/s
//! ascent, 4 m/s descent, 30 min flight time); docs/formats.md lists figures
//! for other common aircraft. The model ignores wind, which a real flight
//! pays for out of the reserve.

use nalgebra::Point3;
use serde::{Deserialize, Serialize};

use crate::error::{Result, SceneError};

/// The flight-time model and the battery budget of one flight.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct FlightParams {
    /// Horizontal speed between waypoints, m/s.
    pub cruise_speed_m_s: f64,
    /// Vertical speed going up, m/s.
    pub climb_rate_m_s: f64,
    /// Vertical speed going down, m/s.
    pub descent_rate_m_s: f64,
    /// Acceleration and braking, m/s^2 (both axes).
    pub acceleration_m_s2: f64,
    /// Time spent at each photo waypoint: settle, turn the gimbal, shoot, s.
    pub hover_per_photo_s: f64,
    /// Fixed time of one take-off and one landing (motors, lift-off, touch-down), s.
    pub takeoff_landing_s: f64,
    /// Longest flight on one battery, s; `None`: one flight, however long.
    pub max_flight_time_s: Option<f64>,
    /// Kept back from `max_flight_time_s` (wind, a missed landing), s.
    pub reserve_s: f64,
}

impl Default for FlightParams {
    fn default() -> Self {
        FlightParams {
            cruise_speed_m_s: 5.0,
            climb_rate_m_s: 3.0,
            descent_rate_m_s: 2.0,
            acceleration_m_s2: 2.0,
            hover_per_photo_s: 2.0,
            takeoff_landing_s: 10.0,
            max_flight_time_s: None,
            reserve_s: 120.0,
        }
    }
}

/// Distance and duration of a flight.
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct FlightEstimate {
    /// Length of the path flown, metres.
    pub distance_m: f64,
    /// Estimated time in the air plus take-off and landing, seconds.
    pub duration_s: f64,
}

/// Time to cover `d` metres from rest to rest at top speed `v` and
/// acceleration `a`: a trapezoidal profile, or a triangular one when the
/// leg is too short to reach `v`.
fn rest_to_rest_s(d: f64, v: f64, a: f64) -> f64 {
    if d <= 0.0 {
        return 0.0;
    }
    if d >= v * v / a {
        d / v + v / a
    } else {
        2.0 * (d / a).sqrt()
    }
}

impl FlightParams {
    /// Checks every value is finite and positive (the reserve may be 0),
    /// naming the key and its allowed range.
    pub fn validate(&self) -> Result<()> {
        let positive = [
            ("cruise_speed_m_s", self.cruise_speed_m_s, 0.5, 30.0),
            ("climb_rate_m_s", self.climb_rate_m_s, 0.2, 15.0),
            ("descent_rate_m_s", self.descent_rate_m_s, 0.2, 15.0),
            ("acceleration_m_s2", self.acceleration_m_s2, 0.1, 20.0),
        ];
        let non_negative = [
            ("hover_per_photo_s", self.hover_per_photo_s, 0.0, 600.0),
            ("takeoff_landing_s", self.takeoff_landing_s, 0.0, 600.0),
            ("reserve_s", self.reserve_s, 0.0, 7200.0),
        ];
        for (key, v, lo, hi) in positive.into_iter().chain(non_negative) {
            if !(v >= lo && v <= hi) {
                return Err(SceneError::InvalidArgument(format!(
                    "[mission] {key} = {v}: allowed range is {lo} to {hi}"
                )));
            }
        }
        if let Some(m) = self.max_flight_time_s {
            if !(m.is_finite() && m > self.reserve_s + self.takeoff_landing_s) {
                return Err(SceneError::InvalidArgument(format!(
                    "max flight time {m} s leaves no time to fly after the reserve of {} s and \
                     take-off and landing ({} s): give a longer max_flight_time_s \
                     (--max-flight-time) or a smaller [mission] reserve_s",
                    self.reserve_s, self.takeoff_landing_s
                )));
            }
        }
        Ok(())
    }

    /// Time one flight may take: the maximum less the reserve.
    pub fn usable_s(&self) -> Option<f64> {
        self.max_flight_time_s.map(|m| m - self.reserve_s)
    }

    /// Time of the straight leg `a -> b`, from rest to rest, seconds.
    pub fn leg_s(&self, a: &Point3<f64>, b: &Point3<f64>) -> f64 {
        let d = b - a;
        let horizontal = rest_to_rest_s(
            d.x.hypot(d.y),
            self.cruise_speed_m_s,
            self.acceleration_m_s2,
        );
        let rate = if d.z >= 0.0 {
            self.climb_rate_m_s
        } else {
            self.descent_rate_m_s
        };
        let vertical = rest_to_rest_s(d.z.abs(), rate, self.acceleration_m_s2);
        horizontal.max(vertical)
    }

    /// Distance and time of a flight through `waypoints`, `photos` of them
    /// photo stops; from and back to `home` (on the ground) when given,
    /// with take-off and landing.
    pub fn estimate(
        &self,
        home: Option<&Point3<f64>>,
        waypoints: &[Point3<f64>],
        photos: usize,
    ) -> FlightEstimate {
        let mut path: Vec<Point3<f64>> = Vec::with_capacity(waypoints.len() + 4);
        let above = |h: &Point3<f64>, w: Option<&Point3<f64>>| {
            w.map(|w| Point3::new(h.x, h.y, w.z.max(h.z)))
        };
        if let Some(h) = home {
            path.push(*h);
            path.extend(above(h, waypoints.first()));
        }
        path.extend_from_slice(waypoints);
        if let Some(h) = home {
            path.extend(above(h, waypoints.last()));
            path.push(*h);
        }
        let mut e = FlightEstimate::default();
        for w in path.windows(2) {
            e.distance_m += (w[1] - w[0]).norm();
            e.duration_s += self.leg_s(&w[0], &w[1]);
        }
        e.duration_s += self.hover_per_photo_s * photos as f64;
        if home.is_some() {
            e.duration_s += self.takeoff_landing_s;
        }
        e
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_square_survey_matches_the_hand_calculation() {
        let p = FlightParams::default();
        // Home at the origin; four photo waypoints on a 50 m square at 30 m.
        let home = Point3::origin();
        let w = [
            Point3::new(0.0, 0.0, 30.0),
            Point3::new(50.0, 0.0, 30.0),
            Point3::new(50.0, 50.0, 30.0),
            Point3::new(0.0, 50.0, 30.0),
        ];
        let e = p.estimate(Some(&home), &w, 4);
        // By hand: the climb of 30 m at 3 m/s, a = 2 m/s^2 (ramp 4.5 m):
        // 30/3 + 3/2 = 11.5 s; three 50 m sides at 5 m/s (ramp 12.5 m):
        // 50/5 + 5/2 = 12.5 s each; the way back from (0, 50, 30) is 50 m
        // level to above home (12.5 s) and 30 m down at 2 m/s (30/2 + 2/2
        // = 16 s); four photos at 2 s; take-off and landing 10 s.
        let by_hand = 11.5 + 3.0 * 12.5 + 12.5 + 16.0 + 4.0 * 2.0 + 10.0;
        assert!(
            (e.duration_s - by_hand).abs() < 1e-9,
            "{} vs {by_hand}",
            e.duration_s
        );
        let dist = 30.0 + 150.0 + 50.0 + 30.0;
        assert!((e.distance_m - dist).abs() < 1e-9);
    }

    #[test]
    fn a_short_leg_never_reaches_cruise_speed() {
        // 2 m at a = 2 m/s^2: accelerate 1 m, brake 1 m: 2 * sqrt(1) = 2 s,
        // longer than 2 m at a cruise of 5 m/s would take (0.4 s).
        let p = FlightParams::default();
        let t = p.leg_s(&Point3::origin(), &Point3::new(2.0, 0.0, 0.0));
        assert!((t - 2.0).abs() < 1e-12);
    }

    #[test]
    fn out_of_range_values_are_refused_by_name() {
        let p = FlightParams {
            cruise_speed_m_s: -1.0,
            ..FlightParams::default()
        };
        let e = p.validate().unwrap_err().to_string();
        assert!(
            e.contains("cruise_speed_m_s") && e.contains("0.5 to 30"),
            "{e}"
        );
        let p = FlightParams {
            max_flight_time_s: Some(100.0),
            ..FlightParams::default()
        };
        let e = p.validate().unwrap_err().to_string();
        assert!(e.contains("reserve"), "{e}");
    }
}
