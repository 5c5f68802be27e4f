//! The view heading for ArduPilot: `MAV_CMD_CONDITION_YAW`.
//!
//! ArduCopter stores only param1 (the hold) of a NAV_WAYPOINT; it flies
//! with the nose along the track, so a photo planned to face 90 deg faced
//! wherever the last leg pointed (the issue measured 229, 0 and 270 deg in
//! SITL). CONDITION_YAW with an absolute heading is honoured: flown in
//! SITL it gave every photo 90 +/- 0.33 deg.
//!
//! Where it goes: ArduPilot starts the DO/CONDITION items that follow a NAV
//! item when that NAV item is done, together with the next NAV item (the
//! next waypoint). Placed before the view's waypoint, the turn runs during
//! the transit to it; Copter's `verify_yaw` re-asserts the fixed heading
//! each cycle against the waypoint controller (which resets yaw when a
//! waypoint starts), and the heading then holds through the arrival, the
//! hold and the photo, which fires the moment the waypoint is done, before
//! the next waypoint resets the yaw. Placed after the waypoint (before the
//! photo) the heading is also reached, but the turn starts only when the
//! waypoint is done, while the vehicle already leaves for the next one, so
//! the photo is taken late and away from its waypoint.

use mavlink::dialects::common::MavCmd;

use super::MissionItem;

/// CONDITION_YAW to the compass heading `deg` (clockwise from north):
/// default turn rate (0), shortest direction (0), absolute (param4 = 0).
pub(super) fn heading_item(deg: f32) -> MissionItem {
    // ArduPilot takes 0..360; 360.0 after rounding is north.
    let deg = if deg >= 360.0 { deg - 360.0 } else { deg };
    MissionItem::command(
        MavCmd::MAV_CMD_CONDITION_YAW,
        [deg, 0.0, 0.0, 0.0],
        0,
        0,
        0.0,
    )
}
