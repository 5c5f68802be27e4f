//! Plan -> mission items (MISSION_ITEM_INT content), and back for comparison.
//!
//! Each planned view becomes three items, in this order:
//! 1. the gimbal command (`MAV_CMD_DO_GIMBAL_MANAGER_PITCHYAW`, or
//!    `MAV_CMD_DO_MOUNT_CONTROL` as a fallback): placed *before* the
//!    waypoint, so that it runs when the previous waypoint is done and the
//!    gimbal slews during the transit;
//! 2. `MAV_CMD_NAV_WAYPOINT` with hold time (param1), acceptance radius
//!    (param2) and the vehicle's compass heading (param4, degrees clockwise
//!    from true north), frame `MAV_FRAME_GLOBAL_RELATIVE_ALT_INT` (lat/lon
//!    deg * 1e7, altitude relative to home);
//! 3. the photo (`MAV_CMD_IMAGE_START_CAPTURE` with total 1 and an
//!    increasing capture sequence number, or `MAV_CMD_DO_DIGICAM_CONTROL`
//!    with an increasing command identity): DO items after a waypoint run
//!    once the waypoint and its hold time are done, on PX4 and ArduPilot alike.
//!
//! The gimbal yaw is 0 in the vehicle frame: the vehicle itself turns to the
//! view heading, which also works with 2-axis gimbals. Gimbal pitch is
//! relative to the horizon (pitch lock). ArduCopter keeps neither the
//! waypoint's yaw nor its acceptance radius, so for ArduPilot each view
//! also carries a `MAV_CMD_CONDITION_YAW` to the heading, between the gimbal
//! command and the waypoint ([`heading`] says why there).
//!
//! ArduPilot keeps the home position at seq 0: with [`Autopilot::ArduPilot`]
//! the mission starts with a home placeholder that the vehicle overwrites.

use mavlink::dialects::common::{MavCmd, MavFrame};
use vp_scene::plan::{GeodeticOrigin, Plan, PlannedView};

use crate::error::{MissionError, Result};
use crate::geodesy::{deg_to_e7, LocalFrame};

/// Autopilot family: decides mission conventions.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Autopilot {
    /// PX4: the mission starts at seq 0 with the first real item.
    Px4,
    /// ArduPilot: seq 0 is the home position, written by the vehicle.
    ArduPilot,
}

impl std::str::FromStr for Autopilot {
    type Err = MissionError;
    fn from_str(s: &str) -> Result<Self> {
        match s.to_ascii_lowercase().as_str() {
            "px4" => Ok(Autopilot::Px4),
            "ardupilot" | "apm" | "ardupilotmega" => Ok(Autopilot::ArduPilot),
            _ => Err(MissionError::InvalidInput(format!(
                "unknown autopilot {s:?} (expected px4 or ardupilot)"
            ))),
        }
    }
}

/// How the gimbal is pointed.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum GimbalCommand {
    /// `MAV_CMD_DO_GIMBAL_MANAGER_PITCHYAW` (gimbal protocol v2).
    GimbalManager,
    /// `MAV_CMD_DO_MOUNT_CONTROL` (legacy mounts).
    MountControl,
}

/// How the photo is triggered.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum CameraTrigger {
    /// `MAV_CMD_IMAGE_START_CAPTURE`, total 1, increasing sequence number.
    ImageStartCapture,
    /// `MAV_CMD_DO_DIGICAM_CONTROL`, shoot, increasing command identity.
    DigicamControl,
}

/// How a plan becomes a mission.
#[derive(Debug, Clone, PartialEq)]
pub struct MissionOptions {
    /// Mission conventions (home at seq 0 for ArduPilot).
    pub autopilot: Autopilot,
    /// Gimbal command kind.
    pub gimbal: GimbalCommand,
    /// Camera trigger kind.
    pub trigger: CameraTrigger,
    /// Seconds to hold at each waypoint before the photo (ArduPilot stores whole seconds).
    pub hold_time_s: f32,
    /// Waypoint acceptance radius, metres.
    pub acceptance_radius_m: f32,
    /// Ground speed set at the mission start (`MAV_CMD_DO_CHANGE_SPEED`), m/s.
    pub speed_m_s: Option<f32>,
    /// Take off to this altitude above home first (`MAV_CMD_NAV_TAKEOFF`), metres.
    pub takeoff_alt_m: Option<f32>,
    /// End with `MAV_CMD_NAV_RETURN_TO_LAUNCH`.
    pub return_to_launch: bool,
    /// Home (launch) position, in the plan's datum; relative altitudes
    /// refer to it. `None`: the plan's home; a plan without one is refused
    /// (see [`heights::mission_home`]).
    pub home: Option<GeodeticOrigin>,
    /// The band every waypoint must stay in above home.
    pub limits: HeightLimits,
    /// Capture sequence number of the first photo (>= 1).
    pub first_capture_seq: u32,
}

impl MissionOptions {
    /// Defaults for an autopilot: PX4 gets the gimbal manager and
    /// IMAGE_START_CAPTURE; ArduPilot the longer-supported MOUNT_CONTROL and
    /// DIGICAM_CONTROL. 2 s hold, 1 m acceptance, takeoff to 20 m, RTL at the end.
    pub fn for_autopilot(autopilot: Autopilot) -> Self {
        let (gimbal, trigger) = match autopilot {
            Autopilot::Px4 => (
                GimbalCommand::GimbalManager,
                CameraTrigger::ImageStartCapture,
            ),
            Autopilot::ArduPilot => (GimbalCommand::MountControl, CameraTrigger::DigicamControl),
        };
        MissionOptions {
            autopilot,
            gimbal,
            trigger,
            hold_time_s: 2.0,
            acceptance_radius_m: 1.0,
            speed_m_s: None,
            takeoff_alt_m: Some(20.0),
            return_to_launch: true,
            home: None,
            limits: HeightLimits::default(),
            first_capture_seq: 1,
        }
    }

    /// The options a user sets (`vpctl mission` flags, the Python keywords)
    /// over [`MissionOptions::for_autopilot`]: hold time and speed within
    /// [`heights::HOLD_RANGE_S`] and [`heights::SPEED_RANGE_M_S`]; `takeoff_m`
    /// 0 means no takeoff item, else it must be finite and > 0 (the height
    /// band is checked when the mission is built).
    pub fn from_user(
        autopilot: Autopilot,
        hold_s: f32,
        speed_m_s: Option<f32>,
        takeoff_m: f32,
        return_to_launch: bool,
    ) -> crate::Result<Self> {
        heights::check_range("hold time", hold_s, heights::HOLD_RANGE_S, "s")?;
        if let Some(s) = speed_m_s {
            heights::check_range("speed", s, heights::SPEED_RANGE_M_S, "m/s")?;
        }
        if !(takeoff_m.is_finite() && takeoff_m >= 0.0) {
            return Err(MissionError::InvalidInput(format!(
                "take-off height {takeoff_m} m is out of range: 0 (no take-off item) or a height \
                 above home between the minimum height and the ceiling"
            )));
        }
        let mut o = Self::for_autopilot(autopilot);
        o.hold_time_s = hold_s;
        o.speed_m_s = speed_m_s;
        o.takeoff_alt_m = (takeoff_m > 0.0).then_some(takeoff_m);
        o.return_to_launch = return_to_launch;
        Ok(o)
    }
}

impl MissionOptions {
    /// Checks the values a mission is built from, naming the one at fault:
    /// capture numbers from 1, hold time and acceptance radius finite and
    /// >= 0, the take-off height inside the height band, the speed > 0.
    pub fn validate(&self) -> Result<()> {
        if self.first_capture_seq == 0 {
            return Err(MissionError::InvalidInput(
                "first capture sequence number must be >= 1".into(),
            ));
        }
        for (name, v) in [
            ("hold time", self.hold_time_s),
            ("acceptance radius", self.acceptance_radius_m),
        ] {
            if !(v.is_finite() && v >= 0.0) {
                return Err(MissionError::InvalidInput(format!(
                    "{name} {v} must be finite and >= 0"
                )));
            }
        }
        if let Some(alt) = self.takeoff_alt_m {
            let l = self.limits;
            heights::check_range(
                "take-off height",
                alt,
                (l.min_height_m as f32, l.ceiling_m as f32),
                "m above home",
            )?;
        }
        match self.speed_m_s {
            Some(speed) if !(speed.is_finite() && speed > 0.0) => Err(MissionError::InvalidInput(
                format!("speed {speed} m/s must be > 0"),
            )),
            _ => Ok(()),
        }
    }
}

mod capacity;
mod heading;
pub mod heights;
mod verify;
mod wire;

use heading::heading_item;
use heights::HeightLimits;

pub use capacity::stated_capacity;
pub use verify::{ardupilot_alt, compare_items};
pub use wire::{float_frame, MissionItem};

/// A mission ready to upload or export.
#[derive(Debug, Clone, PartialEq)]
pub struct Mission {
    /// Items in sequence order (seq = index).
    pub items: Vec<MissionItem>,
    /// Home (launch) position; altitudes of positional items are relative to it.
    pub home: GeodeticOrigin,
    /// Conventions the items follow.
    pub autopilot: Autopilot,
    /// Number of photo items.
    pub photos: usize,
}

/// Builds the mission of a plan.
#[allow(deprecated)] // MAV_FRAME_GLOBAL_RELATIVE_ALT_INT and DIGICAM_CONTROL: see module docs.
pub fn build_mission(plan: &Plan, opts: &MissionOptions) -> Result<Mission> {
    plan.validate()?;
    let origin = plan.origin.ok_or_else(|| {
        MissionError::InvalidInput(
            "the plan has no geodetic origin (\"origin\": {lat_deg, lon_deg, alt_m}); \
             it is needed to place waypoints on the earth"
                .into(),
        )
    })?;
    opts.validate()?;
    let frame = LocalFrame::new(origin)?;
    let home = heights::mission_home(plan, opts.home)?;
    let heights = heights::check_heights(plan, &frame, &home, &opts.limits)?;
    let (home_x, home_y) = (deg_to_e7(home.lat_deg)?, deg_to_e7(home.lon_deg)?);
    let rel = MavFrame::MAV_FRAME_GLOBAL_RELATIVE_ALT_INT;
    let hold = match opts.autopilot {
        // ArduPilot stores the delay in whole seconds; round here so that
        // verify compares what the vehicle can keep.
        Autopilot::ArduPilot => opts.hold_time_s.round(),
        Autopilot::Px4 => opts.hold_time_s,
    };

    let mut items = Vec::with_capacity(plan.waypoints.len() * 3 + 4);
    if opts.autopilot == Autopilot::ArduPilot {
        items.push(MissionItem {
            command: MavCmd::MAV_CMD_NAV_WAYPOINT,
            frame: MavFrame::MAV_FRAME_GLOBAL,
            params: [0.0; 4],
            x: home_x,
            y: home_y,
            z: home.alt_m as f32,
            autocontinue: true,
        });
    }
    if let Some(alt) = opts.takeoff_alt_m {
        // Climb straight up to at least the first waypoint's height, so the
        // leg to it is level: the leg the planner checked (vp_planner::flights).
        let alt = heights.first().map_or(alt, |&h| alt.max(h as f32));
        items.push(MissionItem {
            command: MavCmd::MAV_CMD_NAV_TAKEOFF,
            frame: rel,
            params: [0.0, 0.0, 0.0, f32::NAN],
            x: home_x,
            y: home_y,
            z: alt,
            autocontinue: true,
        });
    }
    if let Some(speed) = opts.speed_m_s {
        // Speed type 1 = ground speed; throttle -1 = unchanged.
        items.push(MissionItem::command(
            MavCmd::MAV_CMD_DO_CHANGE_SPEED,
            [1.0, speed, -1.0, 0.0],
            0,
            0,
            0.0,
        ));
    }
    for (capture_seq, view) in (opts.first_capture_seq..).zip(&plan.waypoints) {
        items.extend(view_items(&frame, &home, view, opts, hold, capture_seq)?);
    }
    if opts.return_to_launch {
        items.push(MissionItem::command(
            MavCmd::MAV_CMD_NAV_RETURN_TO_LAUNCH,
            [0.0; 4],
            0,
            0,
            0.0,
        ));
    }
    if items.len() > usize::from(u16::MAX) {
        return Err(MissionError::InvalidInput(format!(
            "{} items exceed the MAVLink limit of 65535",
            items.len()
        )));
    }
    Ok(Mission {
        items,
        home,
        autopilot: opts.autopilot,
        photos: plan.waypoints.len(),
    })
}

/// The gimbal, (ArduPilot: heading,) waypoint and photo items of one view.
#[allow(deprecated)] // MAV_FRAME_GLOBAL_RELATIVE_ALT_INT and DIGICAM_CONTROL: see module docs.
fn view_items(
    frame: &LocalFrame,
    home: &GeodeticOrigin,
    view: &PlannedView,
    opts: &MissionOptions,
    hold: f32,
    capture_seq: u32,
) -> Result<Vec<MissionItem>> {
    let geo = frame.to_geodetic(view.position);
    let rel_alt = (geo.alt_m - home.alt_m) as f32;
    let heading = frame.compass_heading_deg(view.position, view.yaw_deg) as f32;
    let pitch = view.pitch_deg as f32;
    let gimbal = match opts.gimbal {
        // Flags: roll and pitch locked to the horizon (4 | 8), yaw in the
        // vehicle frame (32) with yaw 0 = straight ahead.
        // Rates 0, not NaN: the spec's NaN ("unset") is refused by
        // ArduPilot outside param4 of NAV commands (INVALID_PARAM3); with
        // an angle given, PX4 and ArduPilot steer to the angle and a zero
        // rate changes nothing.
        GimbalCommand::GimbalManager => MissionItem::command(
            MavCmd::MAV_CMD_DO_GIMBAL_MANAGER_PITCHYAW,
            [pitch, 0.0, 0.0, 0.0],
            4 | 8 | 32,
            0,
            0.0,
        ),
        // Mode 2 = MAV_MOUNT_MODE_MAVLINK_TARGETING.
        GimbalCommand::MountControl => MissionItem::command(
            MavCmd::MAV_CMD_DO_MOUNT_CONTROL,
            [pitch, view.roll_deg as f32, 0.0, 0.0],
            0,
            0,
            2.0,
        ),
    };
    let waypoint = MissionItem {
        command: MavCmd::MAV_CMD_NAV_WAYPOINT,
        frame: MavFrame::MAV_FRAME_GLOBAL_RELATIVE_ALT_INT,
        params: [hold, opts.acceptance_radius_m, 0.0, heading],
        x: deg_to_e7(geo.lat_deg)?,
        y: deg_to_e7(geo.lon_deg)?,
        z: rel_alt,
        autocontinue: true,
    };
    let photo = match opts.trigger {
        CameraTrigger::ImageStartCapture => MissionItem::command(
            MavCmd::MAV_CMD_IMAGE_START_CAPTURE,
            [0.0, 0.0, 1.0, capture_seq as f32],
            0,
            0,
            f32::NAN,
        ),
        // param5 = 1: shoot; param6: command identity, increasing so a
        // repeated command is not executed twice.
        CameraTrigger::DigicamControl => MissionItem::command(
            MavCmd::MAV_CMD_DO_DIGICAM_CONTROL,
            [0.0; 4],
            1,
            capture_seq as i32,
            0.0,
        ),
    };
    if opts.autopilot == Autopilot::ArduPilot {
        return Ok(vec![gimbal, heading_item(heading), waypoint, photo]);
    }
    Ok(vec![gimbal, waypoint, photo])
}

#[cfg(test)]
mod tests {
    use super::*;
    use vp_scene::plan::{PlannedView, Role};

    fn plan() -> Plan {
        let origin = GeodeticOrigin {
            lat_deg: 46.0,
            lon_deg: 10.3,
            alt_m: 500.0,
        };
        let mut p = Plan::new(Some(origin));
        p.home = Some(vp_scene::plan::Home {
            position: origin,
            source: "the origin, on the ground".into(),
        });
        for (i, yaw) in [0.0, 90.0, 225.0].into_iter().enumerate() {
            p.waypoints.push(PlannedView {
                position: [i as f64 * 10.0, 5.0, 40.0],
                yaw_deg: yaw,
                pitch_deg: -30.0,
                roll_deg: 0.0,
                role: Role::TripletMember,
                triplet_id: Some(0),
                expected_gain: None,
                angle_bin_deg: None,
            });
        }
        p
    }

    #[test]
    fn px4_mission_layout_and_values() {
        let m = build_mission(&plan(), &MissionOptions::for_autopilot(Autopilot::Px4)).unwrap();
        let cmds: Vec<_> = m.items.iter().map(|i| i.command).collect();
        assert_eq!(cmds.len(), 1 + 3 * 3 + 1);
        assert_eq!(cmds[0], MavCmd::MAV_CMD_NAV_TAKEOFF);
        assert_eq!(cmds[1], MavCmd::MAV_CMD_DO_GIMBAL_MANAGER_PITCHYAW);
        assert_eq!(cmds[2], MavCmd::MAV_CMD_NAV_WAYPOINT);
        assert_eq!(cmds[3], MavCmd::MAV_CMD_IMAGE_START_CAPTURE);
        assert_eq!(cmds[10], MavCmd::MAV_CMD_NAV_RETURN_TO_LAUNCH);
        // ENU yaw 0 (east) is compass 90; yaw 90 (north) is compass 0; 225 -> 225.
        let headings: Vec<f32> = m
            .items
            .iter()
            .filter(|i| i.command == MavCmd::MAV_CMD_NAV_WAYPOINT)
            .map(|i| i.params[3])
            .collect();
        assert!((headings[0] - 90.0).abs() < 0.01 && (headings[2] - 225.0).abs() < 0.01);
        assert!(headings[1] < 0.01 || headings[1] > 359.99, "{headings:?}");
        // 40 m above the origin = home: relative altitude 40 m (+ curvature, < 1 mm here).
        assert!((m.items[2].z - 40.0).abs() < 1e-3);
        // Capture sequence numbers increase from 1, total is 1.
        let seqs: Vec<f32> = m
            .items
            .iter()
            .filter(|i| i.command == MavCmd::MAV_CMD_IMAGE_START_CAPTURE)
            .map(|i| i.params[3])
            .collect();
        assert_eq!(seqs, vec![1.0, 2.0, 3.0]);
        assert_eq!(m.items[3].params[2].to_bits(), 1f32.to_bits());
        assert_eq!(m.items[1].params[0].to_bits(), (-30f32).to_bits());
    }

    #[test]
    #[allow(deprecated)] // DO_MOUNT_CONTROL is the ArduPilot fallback on purpose.
    fn ardupilot_puts_home_at_seq_0() {
        let m = build_mission(
            &plan(),
            &MissionOptions::for_autopilot(Autopilot::ArduPilot),
        )
        .unwrap();
        assert_eq!(m.items[0].command, MavCmd::MAV_CMD_NAV_WAYPOINT);
        assert_eq!(m.items[0].frame, MavFrame::MAV_FRAME_GLOBAL);
        assert_eq!((m.items[0].x, m.items[0].y), (460_000_000, 103_000_000));
        assert_eq!(m.items[1].command, MavCmd::MAV_CMD_NAV_TAKEOFF);
        assert_eq!(m.items[2].command, MavCmd::MAV_CMD_DO_MOUNT_CONTROL);
        // ArduCopter ignores a waypoint's yaw: the heading goes before it.
        assert_eq!(m.items[3].command, MavCmd::MAV_CMD_CONDITION_YAW);
        assert_eq!(m.items[4].command, MavCmd::MAV_CMD_NAV_WAYPOINT);
        assert_eq!(m.items[5].command, MavCmd::MAV_CMD_DO_DIGICAM_CONTROL);
        // Home differs after the vehicle rewrites it: verify still passes.
        let mut got = m.items.clone();
        got[0].x += 1234;
        compare_items(&m.items, &got, Autopilot::ArduPilot).unwrap();
        assert!(compare_items(&m.items, &got, Autopilot::Px4).is_err());
    }

    #[test]
    fn items_round_trip_through_mavlink_messages() {
        let m = build_mission(&plan(), &MissionOptions::for_autopilot(Autopilot::Px4)).unwrap();
        let back: Vec<MissionItem> = m
            .items
            .iter()
            .enumerate()
            .map(|(s, i)| MissionItem::from_mavlink(&i.to_mavlink(s as u16, (1, 1))))
            .collect();
        compare_items(&m.items, &back, Autopilot::Px4).unwrap();
    }

    #[test]
    fn compare_reports_the_differing_item() {
        let m = build_mission(&plan(), &MissionOptions::for_autopilot(Autopilot::Px4)).unwrap();
        let mut got = m.items.clone();
        got[5].params[3] = 12.0;
        let err = compare_items(&m.items, &got, Autopilot::Px4)
            .unwrap_err()
            .to_string();
        assert!(err.contains("item 5") && err.contains("param4"), "{err}");
    }

    #[test]
    fn missing_origin_is_a_clear_error() {
        let mut p = plan();
        p.origin = None;
        p.home = None;
        let err = build_mission(&p, &MissionOptions::for_autopilot(Autopilot::Px4)).unwrap_err();
        assert!(err.to_string().contains("no geodetic origin"));
    }
}
