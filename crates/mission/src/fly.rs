//! A plan as the waypoint lists of DJI WPML and Litchi need it: one point
//! per planned photo with its position, its height above the take-off point,
//! the vehicle's compass heading and the gimbal pitch.
//!
//! The points come from the same computations as the MAVLink items
//! ([`crate::build_mission`]): the same home, the same height checks, the
//! same ENU -> WGS84 conversion and the same heading, so that a `.kmz`, a
//! Litchi CSV and a `.plan` of one plan put every photo at the same place.

use nalgebra::Point3;
use vp_scene::flight_time::{FlightEstimate, FlightParams};
use vp_scene::plan::{GeodeticOrigin, Plan, VerticalDatum};

use crate::error::{MissionError, Result};
use crate::geodesy::LocalFrame;
use crate::items::{heights, MissionOptions};

/// Speed flown when the operator gives none, m/s: QGroundControl's default
/// multicopter mission speed, slow enough for a stop at every photo.
pub const DEFAULT_SPEED_M_S: f64 = 5.0;

/// Seconds a photo waypoint costs beyond its hold in [`estimate`]: turning
/// the gimbal and the photo (braking and accelerating are in the legs).
pub const STOP_AND_SHOOT_S: f64 = 1.0;

/// One photo of the flight.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct FlightPoint {
    /// WGS84 latitude, degrees.
    pub lat_deg: f64,
    /// WGS84 longitude, degrees.
    pub lon_deg: f64,
    /// Altitude in the plan's vertical datum, metres.
    pub alt_m: f64,
    /// Height above the take-off point (home), metres.
    pub height_above_home_m: f64,
    /// Vehicle heading, degrees clockwise from true north, in [0, 360).
    pub heading_deg: f64,
    /// Gimbal pitch, degrees (0 horizon, -90 straight down).
    pub gimbal_pitch_deg: f64,
    /// Local ENU position, metres (for path lengths).
    pub enu: [f64; 3],
}

/// The flight of a plan: its photo points and the operator's settings.
#[derive(Debug, Clone, PartialEq)]
pub struct Flight {
    /// Photo points in flight order.
    pub points: Vec<FlightPoint>,
    /// Take-off point, altitude in the plan's datum.
    pub home: GeodeticOrigin,
    /// Datum of `home.alt_m` and of the points' `alt_m`.
    pub datum: Option<VerticalDatum>,
    /// Mission speed, m/s.
    pub speed_m_s: f64,
    /// Hold at each point before the photo, seconds.
    pub hold_s: f64,
    /// Take-off (climb) height before the first point, metres above home.
    pub takeoff_m: Option<f64>,
    /// Return to the take-off point at the end.
    pub return_to_launch: bool,
    /// The ceiling above home the mission was checked against, metres.
    pub ceiling_m: f64,
    /// The take-off point in the plan's local ENU frame, metres.
    pub home_enu: [f64; 3],
}

impl Flight {
    /// The flight of `plan` under `opts`: refused, as the MAVLink mission
    /// is, without an origin, without a home, or with a waypoint outside
    /// the height band.
    pub fn of_plan(plan: &Plan, opts: &MissionOptions) -> Result<Flight> {
        plan.validate()?;
        let origin = plan.origin.ok_or_else(|| {
            MissionError::InvalidInput(
                "the plan has no geodetic origin; it is needed to place waypoints on the earth"
                    .into(),
            )
        })?;
        opts.validate()?;
        let frame = LocalFrame::new(origin)?;
        let home = heights::mission_home(plan, opts.home)?;
        let above = heights::check_heights(plan, &frame, &home, &opts.limits)?;
        let points = plan
            .waypoints
            .iter()
            .zip(above)
            .map(|(view, height_above_home_m)| {
                let geo = frame.to_geodetic(view.position);
                FlightPoint {
                    lat_deg: geo.lat_deg,
                    lon_deg: geo.lon_deg,
                    alt_m: geo.alt_m,
                    height_above_home_m,
                    heading_deg: frame.compass_heading_deg(view.position, view.yaw_deg),
                    gimbal_pitch_deg: view.pitch_deg,
                    enu: view.position,
                }
            })
            .collect();
        Ok(Flight {
            points,
            home,
            datum: plan.vertical_datum,
            speed_m_s: opts.speed_m_s.map_or(DEFAULT_SPEED_M_S, f64::from),
            hold_s: f64::from(opts.hold_time_s),
            takeoff_m: opts.takeoff_alt_m.map(f64::from),
            return_to_launch: opts.return_to_launch,
            ceiling_m: opts.limits.ceiling_m,
            home_enu: frame.to_enu(home),
        })
    }

    /// Length of the path from the first photo point to the last, metres
    /// (straight legs, climbs included).
    pub fn path_length_m(&self) -> f64 {
        self.points
            .windows(2)
            .map(|w| {
                let (a, b) = (w[0].enu, w[1].enu);
                ((b[0] - a[0]).powi(2) + (b[1] - a[1]).powi(2) + (b[2] - a[2]).powi(2)).sqrt()
            })
            .sum()
    }

    /// The points' ellipsoidal (WGS84) heights: the plan's altitudes
    /// converted through the EGM96 geoid where the plan's datum is EGM96.
    /// A plan that does not say its datum, or whose altitudes are relative
    /// to the take-off point, cannot give them: the error says what to do.
    pub fn ellipsoid_heights_m(&self) -> Result<Vec<f64>> {
        let datum = self.datum.ok_or_else(|| {
            MissionError::InvalidInput(
                "WGS84 (ellipsoidal) heights need the plan's vertical datum, and this plan does \
                 not say which datum its altitudes use: plan again with --datum egm96 or \
                 --datum ellipsoid, or export heights relative to the take-off point \
                 (--dji-heights relative)"
                    .into(),
            )
        })?;
        self.points
            .iter()
            .map(|p| {
                datum
                    .convert(p.alt_m, p.lat_deg, p.lon_deg, VerticalDatum::Ellipsoid)
                    .map_err(|e| {
                        MissionError::InvalidInput(format!(
                            "WGS84 heights: {e}; export heights relative to the take-off point \
                             (--dji-heights relative)"
                        ))
                    })
            })
            .collect()
    }
}

/// Estimated distance and duration of the mission, from home and back: the
/// planner's flight-time model ([`FlightParams`]) at the mission's speed,
/// with the hold plus [`STOP_AND_SHOOT_S`] at every photo. For the WPML
/// `distance` and `duration` fields (DJI Pilot 2 recomputes its own on
/// import).
pub fn estimate(flight: &Flight) -> FlightEstimate {
    let params = FlightParams {
        cruise_speed_m_s: flight.speed_m_s,
        hover_per_photo_s: flight.hold_s + STOP_AND_SHOOT_S,
        ..FlightParams::default()
    };
    let points: Vec<Point3<f64>> = flight.points.iter().map(|p| Point3::from(p.enu)).collect();
    params.estimate(
        Some(&Point3::from(flight.home_enu)),
        &points,
        flight.points.len(),
    )
}
