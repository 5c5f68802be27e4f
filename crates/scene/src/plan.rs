//! The versioned plan file: ordered waypoints written by the planner, read by the mission crate.
//!
//! A plan is JSON (serde). Positions are in the local ENU world frame of the
//! scene (metres, z up); the optional [`GeodeticOrigin`] ties that frame to
//! WGS84 so the mission crate can turn waypoints into latitude, longitude and
//! altitude.
//!
//! Angles are in degrees, with the conventions of
//! [`Camera::from_yaw_pitch`](crate::Camera::from_yaw_pitch):
//! - `yaw_deg`: heading of the optical axis in the ENU frame,
//!   **counter-clockwise from +x (east)**. 0 = looking east, 90 = north.
//!   This is *not* a compass heading (clockwise from north); the mission
//!   crate converts (compass = 90 - yaw, corrected for meridian convergence).
//! - `pitch_deg`: elevation of the optical axis, 0 horizontal, -90 nadir.
//! - `roll_deg`: rotation about the optical axis, 0 for a levelled gimbal.
//!
//! The file carries `format_version`; a reader refuses a version it does not
//! know with a clear message instead of misreading it.

use std::collections::BTreeMap;
use std::io::Write;
use std::path::Path;

use nalgebra::Point3;
use serde::{Deserialize, Serialize};

use crate::camera::{Camera, Intrinsics};
pub use crate::datum::{Home, VerticalDatum};
use crate::error::{Location, Result, SceneError};
use crate::fsio;

/// The plan format this build writes and reads.
pub const PLAN_FORMAT_VERSION: u32 = 1;

/// WGS84 position of the local ENU origin.
///
/// `alt_m` is the altitude of the origin in metres. Only differences of
/// altitude are used downstream (waypoint altitude relative to home), so it
/// may be ellipsoidal or above mean sea level as long as the home position
/// uses the same datum; the QGC export labels it AMSL, as QGC does.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct GeodeticOrigin {
    /// Latitude in degrees, north positive, in [-90, 90].
    pub lat_deg: f64,
    /// Longitude in degrees, east positive, in [-180, 180].
    pub lon_deg: f64,
    /// Altitude in metres.
    pub alt_m: f64,
}

impl Default for GeodeticOrigin {
    /// Near the Seradina rock-art sites in Val Camonica (Capo di Ponte, Italy),
    /// where the paper's experiments were flown.
    fn default() -> Self {
        GeodeticOrigin {
            lat_deg: 46.03,
            lon_deg: 10.35,
            alt_m: 400.0,
        }
    }
}

impl GeodeticOrigin {
    /// A validated origin (see [`GeodeticOrigin::validate`]): what `--origin
    /// LAT,LON,ALT` and the Python `origin=` both build.
    pub fn new(lat_deg: f64, lon_deg: f64, alt_m: f64) -> Result<Self> {
        let g = GeodeticOrigin {
            lat_deg,
            lon_deg,
            alt_m,
        };
        g.validate()?;
        Ok(g)
    }

    /// Checks that the coordinates are finite and in range.
    pub fn validate(&self) -> Result<()> {
        let ok = self.lat_deg.is_finite()
            && self.lon_deg.is_finite()
            && self.alt_m.is_finite()
            && self.lat_deg.abs() <= 90.0
            && self.lon_deg.abs() <= 180.0;
        if ok {
            Ok(())
        } else {
            Err(SceneError::InvalidArgument(format!(
                "geodetic origin lat {} lon {} alt {}: latitude must be in [-90, 90], \
                 longitude in [-180, 180], all finite",
                self.lat_deg, self.lon_deg, self.alt_m
            )))
        }
    }
}

/// Why a view is in the plan.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum Role {
    /// One of the three cameras of a planned triplet (M3).
    TripletMember,
    /// A bridging view inserted to keep image overlap along the path (M4).
    Bridge,
    /// A view of a regular grid flight (baseline).
    Grid,
    /// A view of the initial flight that bootstraps the geometry.
    Initial,
}

/// One planned camera pose: where the vehicle goes and where the camera looks.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct PlannedView {
    /// Projection centre in the local ENU frame, metres.
    pub position: [f64; 3],
    /// Heading of the optical axis, degrees counter-clockwise from east (ENU).
    pub yaw_deg: f64,
    /// Elevation of the optical axis, degrees: 0 horizontal, -90 nadir.
    pub pitch_deg: f64,
    /// Roll about the optical axis, degrees (0 for a levelled gimbal).
    #[serde(default)]
    pub roll_deg: f64,
    /// Why the view is planned.
    pub role: Role,
    /// Triplet this view belongs to, for `Role::TripletMember`.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub triplet_id: Option<u32>,
    /// Fulfillment gain the planner expected from the view's triplet.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub expected_gain: Option<f64>,
    /// Triangulation-angle bin centre (deg) the triplet was planned for.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub angle_bin_deg: Option<f64>,
}

impl PlannedView {
    /// The view of a posed camera (roll is taken as 0, as `Camera::yaw_pitch` assumes).
    pub fn from_camera(camera: &Camera, role: Role) -> Self {
        let (yaw, pitch) = camera.yaw_pitch();
        let c = camera.center();
        PlannedView {
            position: [c.x, c.y, c.z],
            yaw_deg: yaw.to_degrees(),
            pitch_deg: pitch.to_degrees(),
            roll_deg: 0.0,
            role,
            triplet_id: None,
            expected_gain: None,
            angle_bin_deg: None,
        }
    }

    /// The camera of this view with the given intrinsics (roll ignored).
    pub fn to_camera(&self, intrinsics: Intrinsics) -> Camera {
        let [x, y, z] = self.position;
        Camera::from_yaw_pitch(
            intrinsics,
            Point3::new(x, y, z),
            self.yaw_deg.to_radians(),
            self.pitch_deg.to_radians(),
        )
    }
}

/// Altitude band the vehicle must stay in, as ENU z (metres above the origin).
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct AltitudeLimits {
    /// Lowest allowed z, metres.
    pub min_m: f64,
    /// Highest allowed z, metres.
    pub max_m: f64,
}

/// Figures of one planning iteration: one triplet that is flown.
#[derive(Debug, Clone, PartialEq, Default, Serialize, Deserialize)]
pub struct IterationStatistics {
    /// The `triplet_id` of the iteration's views: the 0-based M3 iteration
    /// that chose it (a triplet chosen to replace a dropped one gets the
    /// next unused number, so the list may skip the dropped ones).
    pub iteration: u32,
    /// Mean fulfillment f(t) over the sampled triangles before the iteration.
    pub f_before: f64,
    /// Mean fulfillment after adding the iteration's views.
    pub f_after: f64,
    /// Share of sampled triangles covered (f_cov = 1) after the iteration.
    pub coverage: f64,
    /// Wall time per module ("m1", "m2", "m3", "m4", ...), seconds.
    #[serde(default)]
    pub time_s: BTreeMap<String, f64>,
}

/// Summary figures of a planning run.
#[derive(Debug, Clone, PartialEq, Default, Serialize, Deserialize)]
pub struct PlanStatistics {
    /// One entry per planning iteration, in order.
    #[serde(default)]
    pub iterations: Vec<IterationStatistics>,
    /// Total planning wall time, seconds.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub total_time_s: Option<f64>,
}

/// A triplet the planner chose and then left out of the flight: one of its
/// views is unsafe or no safe route reaches it.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct DroppedTriplet {
    /// Its id (the M3 iteration that chose it; no waypoint carries it).
    pub triplet_id: u32,
    /// Which view and which rule, naming waypoints by their index in
    /// [`Plan::waypoints`].
    pub reason: String,
    /// The triplet flown in its place, when the planner found one that
    /// passes the safety rules.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub replaced_by: Option<u32>,
}

/// A plan: ordered views plus the constraints they were planned under.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct Plan {
    /// File format version; [`PLAN_FORMAT_VERSION`] for this build.
    pub format_version: u32,
    /// WGS84 position of the ENU origin; needed to fly or export the plan.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub origin: Option<GeodeticOrigin>,
    /// The datum of `origin.alt_m` and `home`'s altitude; absent in plans
    /// written before datums were recorded (then only a home in the same,
    /// unstated datum can be used with it).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub vertical_datum: Option<VerticalDatum>,
    /// Where the vehicle takes off: the relative altitudes of a mission are
    /// heights above it. Without it a mission cannot be exported (the origin
    /// may be in the air: `vpctl colmap align` puts it at the first photo).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub home: Option<Home>,
    /// Views in flight order.
    pub waypoints: Vec<PlannedView>,
    /// Inclusion polygon in the ENU x/y plane, metres, not closed (the last
    /// vertex connects back to the first).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub geofence: Option<Vec<[f64; 2]>>,
    /// Altitude band the views respect.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub altitude_limits: Option<AltitudeLimits>,
    /// Minimum distance from every view and path segment to the mesh, metres.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub safety_distance_m: Option<f64>,
    /// Planning figures (fulfillment, coverage, timings).
    #[serde(default)]
    pub statistics: PlanStatistics,
    /// True when planning stopped early (time budget, no positive gain).
    #[serde(default)]
    pub cut_short: bool,
    /// Why planning stopped early, in words.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub cut_short_reason: Option<String>,
    /// Waypoints (indices into `waypoints`) that could not be bridged from
    /// the previous one with the required image overlap: the MVS may not
    /// link them to the rest of the flight.
    #[serde(default, skip_serializing_if = "Vec::is_empty")]
    pub unbridged: Vec<usize>,
    /// The flights the waypoints are flown in, one battery each, in order;
    /// every waypoint in exactly one. Empty in plans written before flights
    /// were recorded (then the plan is one flight).
    #[serde(default, skip_serializing_if = "Vec::is_empty")]
    pub flights: Vec<Flight>,
    /// Triplets chosen and then left out as unsafe or unreachable (their
    /// views are not in `waypoints`, nor in `statistics`), with the
    /// replacement flown instead, if any.
    #[serde(default, skip_serializing_if = "Vec::is_empty")]
    pub dropped_triplets: Vec<DroppedTriplet>,
}

/// One flight of a plan: from home (when the plan has one) through a run
/// of consecutive waypoints and back, estimated with
/// [`FlightParams`](crate::flight_time::FlightParams).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Flight {
    /// Indices into [`Plan::waypoints`], consecutive, in flight order.
    pub waypoints: Vec<usize>,
    /// Length of the path, metres (with the legs from and to home when `from_home`).
    pub distance_m: f64,
    /// Estimated duration, seconds (with take-off, landing and the home legs when `from_home`).
    pub duration_s: f64,
    /// Whether the figures include taking off from home and returning to it
    /// (false when the plan has no home).
    pub from_home: bool,
}

impl Plan {
    /// An empty plan of the current format version.
    pub fn new(origin: Option<GeodeticOrigin>) -> Self {
        Plan {
            format_version: PLAN_FORMAT_VERSION,
            origin,
            vertical_datum: None,
            home: None,
            waypoints: Vec::new(),
            geofence: None,
            altitude_limits: None,
            safety_distance_m: None,
            statistics: PlanStatistics::default(),
            cut_short: false,
            cut_short_reason: None,
            unbridged: Vec::new(),
            flights: Vec::new(),
            dropped_triplets: Vec::new(),
        }
    }

    /// Checks the invariants a reader relies on: finite numbers, angles in
    /// range, a geofence of at least three vertices, a consistent altitude band.
    /// Errors name the waypoint or vertex index.
    pub fn validate(&self) -> Result<()> {
        let bad = |kind: &str, index: usize, msg: String| {
            SceneError::InvalidArgument(format!("plan: {kind} {index}: {msg}"))
        };
        if let Some(o) = &self.origin {
            o.validate()?;
        }
        if let Some(h) = &self.home {
            if self.origin.is_none() {
                return Err(SceneError::InvalidArgument(
                    "plan: a home without a geodetic origin: the waypoints cannot be placed \
                     relative to it"
                        .into(),
                ));
            }
            h.position.validate()?;
        }
        for (i, v) in self.waypoints.iter().enumerate() {
            if !v.position.iter().all(|c| c.is_finite()) {
                return Err(bad(
                    "waypoint",
                    i,
                    format!("non-finite position {:?}", v.position),
                ));
            }
            if !(v.yaw_deg.is_finite() && v.roll_deg.is_finite()) {
                return Err(bad("waypoint", i, "non-finite yaw or roll".into()));
            }
            if !(v.pitch_deg >= -90.0 && v.pitch_deg <= 90.0) {
                return Err(bad(
                    "waypoint",
                    i,
                    format!("pitch {} deg outside [-90, 90]", v.pitch_deg),
                ));
            }
        }
        if let Some(fence) = &self.geofence {
            if fence.len() < 3 {
                return Err(SceneError::InvalidArgument(format!(
                    "plan: geofence has {} vertices, needs at least 3",
                    fence.len()
                )));
            }
            if let Some(i) = fence
                .iter()
                .position(|p| !(p[0].is_finite() && p[1].is_finite()))
            {
                return Err(bad("geofence vertex", i, "non-finite coordinate".into()));
            }
        }
        if let Some(l) = &self.altitude_limits {
            if !(l.min_m.is_finite() && l.max_m.is_finite() && l.min_m <= l.max_m) {
                return Err(SceneError::InvalidArgument(format!(
                    "plan: altitude limits [{}, {}] m are not an interval",
                    l.min_m, l.max_m
                )));
            }
        }
        if !self.flights.is_empty() {
            let flown: Vec<usize> = self
                .flights
                .iter()
                .flat_map(|f| f.waypoints.iter().copied())
                .collect();
            if !flown.iter().copied().eq(0..self.waypoints.len()) {
                return Err(SceneError::InvalidArgument(format!(
                    "plan: the flights do not list the {} waypoints once each, in order",
                    self.waypoints.len()
                )));
            }
        }
        if let Some(d) = self.safety_distance_m {
            if !(d >= 0.0 && d.is_finite()) {
                return Err(SceneError::InvalidArgument(format!(
                    "plan: safety distance {d} m must be finite and >= 0"
                )));
            }
        }
        Ok(())
    }

    /// Parses and validates a plan from JSON text; `path` only names the source in errors.
    pub fn from_json(text: &str, path: &Path) -> Result<Self> {
        // Read the version first so a future file gets "unsupported version"
        // rather than a confusing complaint about a field it renamed.
        #[derive(Deserialize)]
        struct Probe {
            format_version: Option<serde_json::Value>,
            #[serde(rename = "fileType")]
            file_type: Option<serde_json::Value>,
        }
        let json_err = |e: &serde_json::Error| {
            SceneError::parse(
                path,
                Location::Line(e.line()),
                format!("column {}: {e}", e.column()),
            )
        };
        let probe: Probe = serde_json::from_str(text).map_err(|e| {
            let head = text.trim_start();
            let first = head.lines().next().unwrap_or("");
            let kind = if head.starts_with("QGC WPL") {
                Some("a QGC WPL mission (as `vpctl mission export --out m.waypoints` writes)")
            } else if first.starts_with('[') && first.trim_end().ends_with(']')
                || first.contains(" = ")
            {
                Some("a TOML configuration")
            } else {
                None
            };
            match kind {
                Some(k) => SceneError::parse(
                    path,
                    Location::Header,
                    format!(
                        "this is {k}, not a vpctl plan: pass the plan JSON that `vpctl plan` or \
                         `vpctl plan grid` wrote (their --out)"
                    ),
                ),
                None => json_err(&e),
            }
        })?;
        match probe.format_version {
            None if probe.file_type.as_ref().and_then(|v| v.as_str()) == Some("Plan") => {
                return Err(SceneError::parse(
                    path,
                    Location::Header,
                    "this is a QGroundControl plan (.plan, as `vpctl mission export` writes), \
                     not a vpctl plan: pass the vpctl plan JSON it was exported from (the \
                     `--out` of `vpctl plan` or `vpctl plan grid`)",
                ))
            }
            None => {
                return Err(SceneError::parse(
                    path,
                    Location::Header,
                    "missing \"format_version\": not a vpctl plan file (the JSON that \
                     `vpctl plan` or `vpctl plan grid` writes)",
                ))
            }
            Some(serde_json::Value::Number(n))
                if n.as_u64() == Some(PLAN_FORMAT_VERSION.into()) => {}
            Some(v) => {
                return Err(SceneError::parse(
                    path,
                    Location::Header,
                    format!(
                        "plan format_version {v} is not supported by this build \
                         (it reads version {PLAN_FORMAT_VERSION}); use a matching vpctl"
                    ),
                ))
            }
        }
        let plan: Plan = serde_json::from_str(text).map_err(|e| json_err(&e))?;
        plan.validate().map_err(|e| match e {
            SceneError::InvalidArgument(m) => SceneError::parse(path, Location::Header, m),
            other => other,
        })?;
        Ok(plan)
    }

    /// Reads a plan file.
    pub fn load(path: &Path) -> Result<Self> {
        Plan::from_json(&fsio::read_text(path)?, path)
    }

    /// Writes the plan as pretty JSON, atomically; refuses to overwrite
    /// an existing file unless `force`.
    pub fn save(&self, path: &Path, force: bool) -> Result<()> {
        self.validate()?;
        fsio::check_overwrite(path, force)?;
        let text = serde_json::to_string_pretty(self)
            .map_err(|e| SceneError::InvalidArgument(format!("plan not serialisable: {e}")))?;
        fsio::write_atomic(path, |w| {
            w.write_all(text.as_bytes())?;
            w.write_all(b"\n")
        })
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn sample() -> Plan {
        let mut p = Plan::new(Some(GeodeticOrigin {
            lat_deg: 46.0,
            lon_deg: 10.3,
            alt_m: 400.0,
        }));
        p.waypoints.push(PlannedView {
            position: [10.0, -5.0, 40.0],
            yaw_deg: 90.0,
            pitch_deg: -45.0,
            roll_deg: 0.0,
            role: Role::TripletMember,
            triplet_id: Some(2),
            expected_gain: Some(0.25),
            angle_bin_deg: Some(12.5),
        });
        p.geofence = Some(vec![[-50.0, -50.0], [50.0, -50.0], [50.0, 50.0]]);
        p.statistics.iterations.push(IterationStatistics {
            iteration: 0,
            f_before: 0.2,
            f_after: 0.4,
            coverage: 0.9,
            time_s: [("m1".to_string(), 0.5)].into_iter().collect(),
        });
        p
    }

    #[test]
    fn save_load_round_trip() {
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("plan.json");
        let plan = sample();
        plan.save(&path, false).unwrap();
        assert_eq!(Plan::load(&path).unwrap(), plan);
        assert!(matches!(
            plan.save(&path, false),
            Err(SceneError::AlreadyExists { .. })
        ));
    }

    #[test]
    fn future_version_is_refused_by_name() {
        let text = r#"{"format_version": 2, "waypoints": []}"#;
        let err = Plan::from_json(text, Path::new("p.json"))
            .unwrap_err()
            .to_string();
        assert!(
            err.contains("p.json") && err.contains("format_version 2"),
            "{err}"
        );
    }

    #[test]
    fn syntax_error_names_line_and_column() {
        let text = "{\n  \"format_version\": 1,\n  \"waypoints\": [,]\n}";
        let err = Plan::from_json(text, Path::new("p.json"))
            .unwrap_err()
            .to_string();
        assert!(err.contains("p.json: line 3: column"), "{err}");
    }

    #[test]
    fn bad_pitch_names_the_waypoint() {
        let mut p = sample();
        p.waypoints[0].pitch_deg = -120.0;
        let text = serde_json::to_string(&p).unwrap();
        let err = Plan::from_json(&text, Path::new("p.json"))
            .unwrap_err()
            .to_string();
        assert!(err.contains("waypoint 0") && err.contains("pitch"), "{err}");
    }

    #[test]
    fn view_matches_camera_convention() {
        let k = Intrinsics::from_hfov(640, 480, 60.0).unwrap();
        let cam = Camera::from_yaw_pitch(k, Point3::new(1.0, 2.0, 3.0), 0.5, -0.3);
        let v = PlannedView::from_camera(&cam, Role::Bridge);
        assert!((v.yaw_deg - 0.5f64.to_degrees()).abs() < 1e-9);
        assert!((v.pitch_deg + 0.3f64.to_degrees()).abs() < 1e-9);
        let back = v.to_camera(k);
        assert!((back.axis() - cam.axis()).norm() < 1e-12);
    }
}
