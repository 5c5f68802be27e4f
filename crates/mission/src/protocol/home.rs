//! Reading the vehicle's home: `MAV_CMD_REQUEST_MESSAGE` for HOME_POSITION
//! (id 242), as QGroundControl asks for it. A vehicle without a home yet
//! (no GNSS fix) answers the command with a failure, or stays silent.

use mavlink::dialects::common::{
    MavCmd, MavMessage, MavResult, COMMAND_LONG_DATA, HOME_POSITION_DATA,
};
use vp_scene::plan::GeodeticOrigin;

use super::{Link, ProtocolConfig, Target};
use crate::error::Result;

/// MAVLink message id of HOME_POSITION.
pub const HOME_POSITION_ID: u32 = 242;

/// The vehicle's home (altitude above mean sea level, as HOME_POSITION
/// gives it), or `None` when it reports none: it refused the request or
/// did not answer within `cfg.timeout` on either of two tries.
pub fn read_home(
    link: &mut dyn Link,
    target: Target,
    cfg: &ProtocolConfig,
) -> Result<Option<GeodeticOrigin>> {
    let (system, component) = target.ids();
    let request = MavMessage::COMMAND_LONG(COMMAND_LONG_DATA {
        param1: HOME_POSITION_ID as f32,
        param2: 0.0,
        param3: 0.0,
        param4: 0.0,
        param5: 0.0,
        param6: 0.0,
        param7: 0.0,
        command: MavCmd::MAV_CMD_REQUEST_MESSAGE,
        target_system: system,
        target_component: component,
        confirmation: 0,
    });
    for confirmation in 0..2u8 {
        let mut msg = request.clone();
        if let MavMessage::COMMAND_LONG(c) = &mut msg {
            c.confirmation = confirmation;
        }
        link.send(&msg)?;
        let deadline = link.now() + cfg.timeout;
        while let Some(left) = deadline.checked_sub(link.now()).filter(|d| !d.is_zero()) {
            let Some((header, reply)) = link.recv(left)? else {
                break;
            };
            if !target.is_source(&header) {
                continue;
            }
            match reply {
                MavMessage::HOME_POSITION(h) => return Ok(Some(home_of(&h))),
                MavMessage::COMMAND_ACK(a)
                    if a.command == MavCmd::MAV_CMD_REQUEST_MESSAGE
                        && a.result != MavResult::MAV_RESULT_ACCEPTED
                        && a.result != MavResult::MAV_RESULT_IN_PROGRESS =>
                {
                    return Ok(None)
                }
                _ => {}
            }
        }
    }
    Ok(None)
}

/// HOME_POSITION's position: degrees * 1e7 and millimetres above mean sea level.
fn home_of(h: &HOME_POSITION_DATA) -> GeodeticOrigin {
    GeodeticOrigin {
        lat_deg: f64::from(h.latitude) * 1e-7,
        lon_deg: f64::from(h.longitude) * 1e-7,
        alt_m: f64::from(h.altitude) * 1e-3,
    }
}

/// The HOME_POSITION a vehicle with home `home` sends (the simulator's answer).
pub fn home_position(home: &GeodeticOrigin) -> HOME_POSITION_DATA {
    HOME_POSITION_DATA {
        latitude: (home.lat_deg * 1e7).round() as i32,
        longitude: (home.lon_deg * 1e7).round() as i32,
        altitude: (home.alt_m * 1e3).round() as i32,
        q: [1.0, 0.0, 0.0, 0.0],
        ..HOME_POSITION_DATA::DEFAULT
    }
}
