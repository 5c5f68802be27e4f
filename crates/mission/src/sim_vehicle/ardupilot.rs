//! What a real ArduPilot (Copter) does with the mission items it is given,
//! so that the simulated vehicle in ArduPilot mode catches what the real
//! one would. Read from ArduPilot's `libraries/AP_Mission/AP_Mission.cpp`
//! (`sanity_check_params`, `mavlink_int_to_mission_cmd`,
//! `mission_cmd_to_mavlink_int`, the packed 15-byte storage) and
//! `libraries/GCS_MAVLink/MissionItemProtocol.cpp` (the upload state
//! machine):
//!
//! - NaN is refused in every param except param4 of NAV_WAYPOINT,
//!   NAV_LAND, NAV_TAKEOFF and NAV_VTOL_TAKEOFF (and params 3-4 of
//!   NAV_VTOL_LAND); infinity everywhere (`MAV_MISSION_INVALID_PARAMn`).
//! - NAV_WAYPOINT keeps only param1 (the hold, in whole seconds, a 16-bit
//!   integer): Copter drops the acceptance radius and the yaw (params
//!   2-4). NAV_TAKEOFF keeps param1 only.
//! - Altitudes are stored in whole centimetres, truncated toward zero
//!   (`alt = z * 100.0f` into an integer).
//! - DO_DIGICAM_CONTROL keeps every field in one byte: its command
//!   identity (param6) wraps at 256.
//! - DO_MOUNT_CONTROL keeps pitch, roll and yaw, not the mode (param7).
//! - Items are written to storage as they arrive; MISSION_COUNT first
//!   truncates the stored mission to the new count. An upload cut short
//!   leaves the new mission's first items over the old mission's rest.
//! - A MISSION_COUNT over the storage capacity gets MAV_MISSION_NO_SPACE
//!   and the STATUSTEXT "Only N items are supported".
//! - An item it did not ask for gets MAV_MISSION_INVALID_SEQUENCE, and the
//!   transfer goes on; MISSION_CLEAR_ALL during an upload gets
//!   MAV_MISSION_ERROR.

use mavlink::dialects::common::{MavCmd, MavFrame, MavMissionResult};

use crate::items::MissionItem;

/// ArduPilot's `LOCATION_ALT_MAX_M`: altitudes at or beyond are refused.
const ALT_MAX_M: f32 = 83_000.0;

/// The STATUSTEXT ArduPilot sends with MAV_MISSION_NO_SPACE.
pub fn capacity_text(capacity: usize) -> String {
    format!("Only {capacity} items are supported")
}

/// Commands whose x/y/z are a location (`AP_Mission::stored_in_location`
/// for the commands we send).
#[allow(deprecated)] // NAV commands are what missions are made of.
fn has_location(c: MavCmd) -> bool {
    matches!(
        c,
        MavCmd::MAV_CMD_NAV_WAYPOINT
            | MavCmd::MAV_CMD_NAV_LOITER_UNLIM
            | MavCmd::MAV_CMD_NAV_LOITER_TURNS
            | MavCmd::MAV_CMD_NAV_LOITER_TIME
            | MavCmd::MAV_CMD_NAV_LAND
            | MavCmd::MAV_CMD_NAV_TAKEOFF
            | MavCmd::MAV_CMD_NAV_SPLINE_WAYPOINT
            | MavCmd::MAV_CMD_NAV_VTOL_TAKEOFF
            | MavCmd::MAV_CMD_NAV_VTOL_LAND
            | MavCmd::MAV_CMD_DO_SET_ROI
    )
}

/// Commands ArduPilot Copter accepts in a mission (a subset: the ones a
/// photo mission uses and their near kin); others get MAV_MISSION_UNSUPPORTED.
#[allow(deprecated)] // DIGICAM and MOUNT_CONTROL are ArduPilot's own.
fn supported(c: MavCmd) -> bool {
    has_location(c)
        || matches!(
            c,
            MavCmd::MAV_CMD_NAV_RETURN_TO_LAUNCH
                | MavCmd::MAV_CMD_NAV_DELAY
                | MavCmd::MAV_CMD_CONDITION_DELAY
                | MavCmd::MAV_CMD_CONDITION_DISTANCE
                | MavCmd::MAV_CMD_CONDITION_YAW
                | MavCmd::MAV_CMD_DO_JUMP
                | MavCmd::MAV_CMD_DO_CHANGE_SPEED
                | MavCmd::MAV_CMD_DO_SET_SERVO
                | MavCmd::MAV_CMD_DO_DIGICAM_CONFIGURE
                | MavCmd::MAV_CMD_DO_DIGICAM_CONTROL
                | MavCmd::MAV_CMD_DO_MOUNT_CONTROL
                | MavCmd::MAV_CMD_DO_SET_CAM_TRIGG_DIST
                | MavCmd::MAV_CMD_DO_GIMBAL_MANAGER_PITCHYAW
                | MavCmd::MAV_CMD_IMAGE_START_CAPTURE
                | MavCmd::MAV_CMD_IMAGE_STOP_CAPTURE
        )
}

/// `AP_Mission::sanity_check_params` and the location checks of
/// `mavlink_int_to_mission_cmd`: the MISSION_ACK result that refuses the
/// item, if any.
#[allow(deprecated)] // The deprecated _INT frames are accepted, as ArduPilot does.
pub fn check(item: &MissionItem) -> Result<(), MavMissionResult> {
    use MavMissionResult as R;
    let nan_ok: [bool; 4] = match item.command {
        MavCmd::MAV_CMD_NAV_WAYPOINT
        | MavCmd::MAV_CMD_NAV_LAND
        | MavCmd::MAV_CMD_NAV_TAKEOFF
        | MavCmd::MAV_CMD_NAV_VTOL_TAKEOFF => [false, false, false, true],
        MavCmd::MAV_CMD_NAV_VTOL_LAND => [false, false, true, true],
        _ => [false; 4],
    };
    let codes = [
        R::MAV_MISSION_INVALID_PARAM1,
        R::MAV_MISSION_INVALID_PARAM2,
        R::MAV_MISSION_INVALID_PARAM3,
        R::MAV_MISSION_INVALID_PARAM4,
    ];
    for k in 0..4 {
        let p = item.params[k];
        if p.is_infinite() || (p.is_nan() && !nan_ok[k]) {
            return Err(codes[k]);
        }
    }
    if !supported(item.command) {
        return Err(R::MAV_MISSION_UNSUPPORTED);
    }
    if has_location(item.command) {
        if item.x.unsigned_abs() > 900_000_000 {
            return Err(R::MAV_MISSION_INVALID_PARAM5_X);
        }
        if item.y.unsigned_abs() > 1_800_000_000 {
            return Err(R::MAV_MISSION_INVALID_PARAM6_Y);
        }
        if item.z.is_nan() || item.z.abs() >= ALT_MAX_M {
            return Err(R::MAV_MISSION_INVALID_PARAM7);
        }
        if !matches!(
            item.frame,
            MavFrame::MAV_FRAME_MISSION
                | MavFrame::MAV_FRAME_GLOBAL
                | MavFrame::MAV_FRAME_GLOBAL_INT
                | MavFrame::MAV_FRAME_GLOBAL_RELATIVE_ALT
                | MavFrame::MAV_FRAME_GLOBAL_RELATIVE_ALT_INT
                | MavFrame::MAV_FRAME_GLOBAL_TERRAIN_ALT
                | MavFrame::MAV_FRAME_GLOBAL_TERRAIN_ALT_INT
        ) {
            return Err(R::MAV_MISSION_UNSUPPORTED_FRAME);
        }
    }
    Ok(())
}

pub use crate::items::ardupilot_alt as stored_alt;

/// A float param kept in an unsigned byte (C's conversion; Rust's `as`
/// saturates where C would be undefined).
fn byte(p: f32) -> f32 {
    f32::from(p as u8)
}

/// The item as a download reads it back after ArduPilot stored it
/// (an item that passed [`check`]).
#[allow(deprecated)] // The float frame names are what ArduPilot sends back.
pub fn stored(item: &MissionItem) -> MissionItem {
    let mut out = MissionItem {
        params: [0.0; 4],
        x: 0,
        y: 0,
        z: 0.0,
        ..*item
    };
    let p = item.params;
    if has_location(item.command) {
        out.x = item.x;
        out.y = item.y;
        out.z = stored_alt(item.z);
        out.frame = match item.frame {
            MavFrame::MAV_FRAME_GLOBAL_RELATIVE_ALT
            | MavFrame::MAV_FRAME_GLOBAL_RELATIVE_ALT_INT => {
                MavFrame::MAV_FRAME_GLOBAL_RELATIVE_ALT
            }
            MavFrame::MAV_FRAME_GLOBAL_TERRAIN_ALT | MavFrame::MAV_FRAME_GLOBAL_TERRAIN_ALT_INT => {
                MavFrame::MAV_FRAME_GLOBAL_TERRAIN_ALT
            }
            _ => MavFrame::MAV_FRAME_GLOBAL,
        };
    }
    match item.command {
        // Copter: the hold in a 16-bit integer; radius and yaw dropped.
        MavCmd::MAV_CMD_NAV_WAYPOINT | MavCmd::MAV_CMD_NAV_TAKEOFF => {
            out.params[0] = f32::from(p[0] as u16);
        }
        MavCmd::MAV_CMD_NAV_LAND => {
            out.params[0] = f32::from(p[0] as u16);
            out.params[3] = if p[3] < 0.0 { -1.0 } else { 1.0 };
        }
        MavCmd::MAV_CMD_CONDITION_YAW => {
            out.params = [p[0], p[1], f32::from(p[2] as i8), byte(p[3])];
        }
        MavCmd::MAV_CMD_DO_CHANGE_SPEED => {
            out.params = [byte(p[0]), p[1], p[2], 0.0];
        }
        MavCmd::MAV_CMD_DO_MOUNT_CONTROL => {
            out.params = [p[0], p[1], p[2], 0.0];
        }
        MavCmd::MAV_CMD_DO_DIGICAM_CONTROL => {
            // Every field one byte; x and y are integers, so they wrap.
            out.params = [byte(p[0]), byte(p[1]), f32::from(p[2] as i8), byte(p[3])];
            out.x = i32::from(item.x as u8);
            out.y = i32::from(item.y as u8);
        }
        MavCmd::MAV_CMD_NAV_RETURN_TO_LAUNCH => {}
        // Other commands: kept as sent (we do not model their storage).
        _ if !has_location(item.command) => {
            out.params = p;
            out.x = item.x;
            out.y = item.y;
            out.z = item.z;
        }
        _ => {}
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn altitude_is_truncated_to_whole_centimetres() {
        // The case: 9.11 m is kept as 9.10 m (9.11 * 100 = 910.99994).
        assert!((stored_alt(9.11) - 9.10).abs() < 1e-6);
        assert!((stored_alt(40.0) - 40.0).abs() < 1e-6);
        assert!((stored_alt(-1.239) + 1.23).abs() < 1e-6);
    }

    #[test]
    fn nan_is_refused_outside_param4_of_nav_commands() {
        let gimbal = MissionItem::command(
            MavCmd::MAV_CMD_DO_GIMBAL_MANAGER_PITCHYAW,
            [-30.0, 0.0, f32::NAN, f32::NAN],
            12,
            0,
            0.0,
        );
        assert_eq!(
            check(&gimbal),
            Err(MavMissionResult::MAV_MISSION_INVALID_PARAM3)
        );
        let ok = MissionItem::command(
            MavCmd::MAV_CMD_DO_GIMBAL_MANAGER_PITCHYAW,
            [-30.0, 0.0, 0.0, 0.0],
            12,
            0,
            0.0,
        );
        assert_eq!(check(&ok), Ok(()));
    }

    #[test]
    #[allow(deprecated)] // DIGICAM_CONTROL is the ArduPilot trigger.
    fn digicam_identity_wraps_at_256() {
        let shot = MissionItem::command(MavCmd::MAV_CMD_DO_DIGICAM_CONTROL, [0.0; 4], 1, 300, 0.0);
        assert_eq!(stored(&shot).y, 44);
    }
}
