//! The arguments `vpctl mission` sub-commands share: the export format,
//! the autopilot, how a plan becomes items, where the vehicle is.

use std::path::{Path, PathBuf};

use anyhow::Result;
use clap::{Args, ValueEnum};
use vp_mission::heights::{HeightLimits, UserMissionOptions};
use vp_mission::{Autopilot, ConnectOptions, MissionOptions, SigningKey};
use vp_scene::plan::Plan;

/// Export formats.
#[derive(Debug, Clone, Copy, ValueEnum)]
pub enum ExportFormat {
    /// QGroundControl `.plan` JSON (SimpleItems only).
    Qgc,
    /// `QGC WPL 110` waypoint text.
    Wpl,
    /// DJI WPML mission (`.kmz`).
    Wpml,
    /// Litchi waypoint CSV.
    Litchi,
    /// KML preview of the path and photos (not a mission).
    Kml,
}

pub(super) fn drone_arg(s: &str) -> std::result::Result<vp_mission::wpml::Drone, String> {
    s.parse()
        .map_err(|e: vp_mission::MissionError| e.to_string())
}

pub(super) fn dji_heights_arg(
    s: &str,
) -> std::result::Result<vp_mission::wpml::WpmlHeights, String> {
    s.parse()
        .map_err(|e: vp_mission::MissionError| e.to_string())
}

/// Autopilot conventions.
#[derive(Debug, Clone, Copy, ValueEnum)]
pub enum AutopilotArg {
    /// PX4: the mission starts at seq 0.
    Px4,
    /// ArduPilot: seq 0 is home.
    Ardupilot,
}

impl From<AutopilotArg> for Autopilot {
    fn from(a: AutopilotArg) -> Self {
        match a {
            AutopilotArg::Px4 => Autopilot::Px4,
            AutopilotArg::Ardupilot => Autopilot::ArduPilot,
        }
    }
}

/// How the plan becomes mission items.
#[derive(Debug, Args)]
pub struct MissionArgs {
    /// Autopilot conventions: ArduPilot keeps home at seq 0 and ignores a
    /// waypoint's heading, so each photo also gets a CONDITION_YAW (4
    /// items per photo instead of 3).
    #[arg(long, value_enum, default_value_t = AutopilotArg::Px4)]
    autopilot: AutopilotArg,
    /// Seconds to hold at each waypoint before the photo (0 to 60).
    #[arg(long, default_value_t = 2.0, allow_negative_numbers = true)]
    hold: f32,
    /// Mission speed, m/s (0.5 to 20).
    #[arg(long, allow_negative_numbers = true)]
    speed: Option<f32>,
    /// Take off to this height above home first, metres (0: no takeoff
    /// item; else between --min-height and --ceiling).
    #[arg(long, default_value_t = 20.0, allow_negative_numbers = true)]
    takeoff: f32,
    /// Do not end the mission with return-to-launch.
    #[arg(long)]
    no_rtl: bool,
    /// Where the vehicle takes off: LAT,LON,ALT[,DATUM] on the ground
    /// (DATUM egm96, ellipsoid or takeoff; default the plan's). Overrides
    /// the plan's home; a plan without one needs it.
    #[arg(long, value_name = "LAT,LON,ALT[,DATUM]", allow_hyphen_values = true, value_parser = crate::cmd::plan::home_arg)]
    home: Option<crate::cmd::plan::HomeArg>,
    /// Highest waypoint allowed, metres above home (most rules: 120).
    #[arg(long, default_value_t = vp_mission::heights::DEFAULT_CEILING_M, allow_negative_numbers = true)]
    ceiling: f64,
    /// Lowest waypoint allowed, metres above home.
    #[arg(long, default_value_t = vp_mission::heights::DEFAULT_MIN_HEIGHT_M, allow_negative_numbers = true)]
    min_height: f64,
}

impl MissionArgs {
    /// The options for `plan` (vp-mission's `UserMissionOptions`, as Python's).
    pub(super) fn options(&self, plan: &Plan) -> Result<MissionOptions> {
        let user = UserMissionOptions {
            autopilot: self.autopilot.into(),
            hold_s: self.hold,
            speed_m_s: self.speed,
            takeoff_m: self.takeoff,
            return_to_launch: !self.no_rtl,
            home: self.home.map(|h| (h.position, h.datum)),
            limits: HeightLimits {
                min_height_m: self.min_height,
                ceiling_m: self.ceiling,
            },
        };
        Ok(user.resolve(plan)?)
    }
}

/// Where the vehicle is.
#[derive(Debug, Args)]
pub struct LinkArgs {
    /// MAVLink connection: `udpout:HOST:PORT`, `udpin:HOST:PORT`,
    /// `tcpout:HOST:PORT` or `serial:/dev/ttyUSB0:57600`.
    #[arg(long, default_value = "udpout:127.0.0.1:14550")]
    pub(super) url: String,
    /// Seconds to wait for the vehicle's heartbeat.
    #[arg(long, allow_negative_numbers = true, default_value_t = 5.0)]
    heartbeat_timeout: f64,
    /// MAVLink 2 signing: sign every message with the key in FILE (64
    /// hexadecimal digits; see docs/formats.md) and ignore messages from
    /// the vehicle that are not signed with it (unsigned, another key,
    /// replays).
    #[arg(long, value_name = "FILE")]
    signing_key: Option<PathBuf>,
}

impl LinkArgs {
    pub(super) fn options(&self) -> Result<ConnectOptions> {
        Ok(ConnectOptions {
            signing: load_key(self.signing_key.as_deref())?,
            ..ConnectOptions::from_user(self.heartbeat_timeout, 1.0)?
        })
    }
}

/// Reads a signing key file; its permission warning goes to standard
/// error (never the key).
pub(super) fn load_key(path: Option<&Path>) -> Result<Option<SigningKey>> {
    let Some(path) = path else { return Ok(None) };
    let loaded = SigningKey::load(path)?;
    if let Some(w) = loaded.warning {
        eprintln!("{w}");
    }
    Ok(Some(loaded.key))
}
