//! Crash check: every flown path against the TRUE mesh.
//!
//! The planner keeps the safety distance to the planning mesh, which holds
//! only what was seen. The simulator knows the truth, so it can tell whether
//! a path would have hit (or come closer than the safety distance to) a
//! surface nobody had seen: every waypoint and every straight segment,
//! including the leg from where the vehicle was, measured with parry's
//! exact distances.

use nalgebra::Point3;
use vp_scene::clearance::Clearance;

/// What the check found on one or more paths.
#[derive(Debug, Clone, PartialEq)]
pub struct PathCheck {
    /// Smallest distance of a waypoint or segment to the true surface, metres
    /// (infinite when nothing was flown).
    pub min_clearance_m: f64,
    /// One line per waypoint or segment closer than the safety distance.
    pub violations: Vec<String>,
}

impl Default for PathCheck {
    fn default() -> Self {
        PathCheck {
            min_clearance_m: f64::INFINITY,
            violations: Vec::new(),
        }
    }
}

impl PathCheck {
    /// Checks the path `start` (the vehicle's position, if known) then
    /// `waypoints` against `truth`; `label` names the path in violations.
    pub fn add(
        &mut self,
        truth: &Clearance,
        safety_m: f64,
        start: Option<Point3<f64>>,
        waypoints: &[Point3<f64>],
        label: &str,
    ) {
        for (i, p) in waypoints.iter().enumerate() {
            let d = truth.distance(p);
            self.min_clearance_m = self.min_clearance_m.min(d);
            if d < safety_m {
                self.violations.push(format!(
                    "{label}: waypoint {i} at ({:.2}, {:.2}, {:.2}) is {d:.2} m from the true surface (safety distance {safety_m} m)",
                    p.x, p.y, p.z
                ));
            }
        }
        let legs = start.iter().chain(waypoints.iter());
        for (i, (a, b)) in legs.clone().zip(legs.skip(1)).enumerate() {
            let d = truth.segment_distance(a, b);
            self.min_clearance_m = self.min_clearance_m.min(d);
            // The distance may read up to 0.11 % long (GJK); the capsule test
            // errs towards contact, so a leg just inside is never missed.
            if d < safety_m || !truth.segment_is_clear(a, b, safety_m) {
                let from = match (start.is_some(), i) {
                    (true, 0) => "the vehicle's position".to_string(),
                    (true, i) => format!("waypoint {}", i - 1),
                    (false, i) => format!("waypoint {i}"),
                };
                self.violations.push(format!(
                    "{label}: segment from {from} to ({:.2}, {:.2}, {:.2}) comes {d:.2} m from the true surface (safety distance {safety_m} m)",
                    b.x, b.y, b.z
                ));
            }
        }
    }

    /// Both checks together.
    pub fn merged(&self, other: &PathCheck) -> PathCheck {
        PathCheck {
            min_clearance_m: self.min_clearance_m.min(other.min_clearance_m),
            violations: self
                .violations
                .iter()
                .chain(&other.violations)
                .cloned()
                .collect(),
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use vp_scene::procedural::shapes;

    #[test]
    fn a_segment_through_a_wall_is_a_violation_and_a_clear_path_is_not() {
        // A 100 m plane at z = 0.
        let truth = Clearance::new(&shapes::plane(100.0, 100.0, 4, 4));
        let mut c = PathCheck::default();
        let high = [Point3::new(0.0, 0.0, 20.0), Point3::new(10.0, 0.0, 20.0)];
        c.add(
            &truth,
            5.0,
            Some(Point3::new(-10.0, 0.0, 20.0)),
            &high,
            "high",
        );
        assert!(c.violations.is_empty(), "{:?}", c.violations);
        assert!(
            (c.min_clearance_m - 20.0).abs() < 0.01,
            "{}",
            c.min_clearance_m
        );
        // The leg from the vehicle dips below the safety distance.
        c.add(&truth, 5.0, Some(Point3::new(0.0, 0.0, 3.0)), &high, "low");
        assert_eq!(c.violations.len(), 1, "{:?}", c.violations);
        assert!(c.violations[0].contains("from the vehicle's position"));
        assert!((c.min_clearance_m - 3.0).abs() < 0.01);
    }
}
