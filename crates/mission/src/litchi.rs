//! Litchi waypoint missions (CSV, the layout Litchi Mission Hub imports and
//! exports) for consumer DJI drones.
//!
//! One row per planned photo: latitude, longitude, altitude above the
//! take-off point (`altitudemode` 0: Litchi's "above ground" switched off),
//! the vehicle's heading, the gimbal pitch (`gimbalmode` 2, interpolate,
//! so the camera is at the planned pitch on arrival), then actions: "stay
//! for" the hold time (milliseconds) and "take photo". Curve size 0: the
//! drone stops at every waypoint. No point of interest, no interval photos.
//!
//! Litchi takes at most [`MAX_WAYPOINTS`] waypoints per mission: a longer
//! plan is refused unless splitting is asked for; then it becomes several
//! missions `NAME-1.csv`, `NAME-2.csv`, ... flown one after another, each
//! from a take-off at the same home.

use std::fmt::Write as _;

use crate::error::{MissionError, Result};
use crate::fly::Flight;

/// Waypoints Litchi takes in one mission.
pub const MAX_WAYPOINTS: usize = 99;

/// Gimbal pitch Litchi accepts, degrees.
pub const GIMBAL_PITCH_RANGE_DEG: (f64, f64) = (-90.0, 30.0);

/// The header row of Litchi Mission Hub's CSV.
pub fn header() -> String {
    let mut h = String::from(
        "latitude,longitude,altitude(m),heading(deg),curvesize(m),rotationdir,gimbalmode,\
         gimbalpitchangle",
    );
    for i in 1..=15 {
        let _ = write!(h, ",actiontype{i},actionparam{i}");
    }
    h.push_str(
        ",altitudemode,speed(m/s),poi_latitude,poi_longitude,poi_altitude(m),poi_altitudemode,\
         photo_timeinterval,photo_distinterval",
    );
    h
}

/// Litchi action types used here.
const STAY_FOR: i32 = 0;
const TAKE_PHOTO: i32 = 1;
const NO_ACTION: i32 = -1;
/// Longest "stay for" Litchi accepts, milliseconds.
const MAX_STAY_MS: f64 = 32_000.0;

/// The CSV texts of a flight: one when it has at most [`MAX_WAYPOINTS`]
/// points; with `split`, one per [`MAX_WAYPOINTS`] points; without, a
/// longer flight is refused.
pub fn litchi_csvs(flight: &Flight, split: bool) -> Result<Vec<String>> {
    let n = flight.points.len();
    if n == 0 {
        return Err(MissionError::InvalidInput(
            "the plan has no waypoint: nothing for Litchi to fly".into(),
        ));
    }
    if n > MAX_WAYPOINTS && !split {
        return Err(MissionError::InvalidInput(format!(
            "{n} waypoints: a Litchi mission holds at most {MAX_WAYPOINTS}; export with \
             --split to write {} missions NAME-1.csv ... NAME-{}.csv, flown one after another",
            n.div_ceil(MAX_WAYPOINTS),
            n.div_ceil(MAX_WAYPOINTS)
        )));
    }
    let (lo, hi) = GIMBAL_PITCH_RANGE_DEG;
    let hold_ms = (flight.hold_s * 1000.0).round();
    let mut files = Vec::new();
    for (part, chunk) in flight.points.chunks(MAX_WAYPOINTS).enumerate() {
        let mut csv = header();
        csv.push('\n');
        for (k, p) in chunk.iter().enumerate() {
            let i = part * MAX_WAYPOINTS + k;
            if !(lo..=hi).contains(&p.gimbal_pitch_deg) {
                return Err(MissionError::InvalidInput(format!(
                    "waypoint {i}: gimbal pitch {:.1} deg is outside the {lo} to {hi} deg \
                     Litchi accepts",
                    p.gimbal_pitch_deg
                )));
            }
            let _ = write!(
                csv,
                "{:.8},{:.8},{:.2},{:.2},0,0,2,{:.2}",
                p.lat_deg,
                p.lon_deg,
                p.height_above_home_m.max(0.0),
                p.heading_deg.rem_euclid(360.0),
                p.gimbal_pitch_deg
            );
            // Litchi's "stay for" takes at most 32 s: a longer hold is
            // several of them.
            let mut actions = Vec::new();
            let mut left = hold_ms;
            while left > 0.0 {
                actions.push((STAY_FOR, left.min(MAX_STAY_MS)));
                left -= MAX_STAY_MS;
            }
            actions.push((TAKE_PHOTO, 0.0));
            for slot in 0..15 {
                let (t, param) = actions.get(slot).copied().unwrap_or((NO_ACTION, 0.0));
                let _ = write!(csv, ",{t},{param:.0}");
            }
            let _ = writeln!(csv, ",0,{:.2},0,0,0,0,-1,-1", flight.speed_m_s);
        }
        files.push(csv);
    }
    Ok(files)
}
