//! One mission item as it travels: MISSION_ITEM_INT (and the float
//! MISSION_ITEM some vehicles answer with) to and from [`MissionItem`].

#[allow(deprecated)] // MISSION_ITEM: see from_mavlink_float.
use mavlink::dialects::common::{
    MavCmd, MavFrame, MavMissionType, MISSION_ITEM_DATA, MISSION_ITEM_INT_DATA,
};

/// One mission item: the content of a MISSION_ITEM_INT without addressing.
///
/// `x`/`y` are lat/lon * 1e7 for positional commands and the raw param5/param6
/// otherwise; `z` is param7 (altitude for positional commands).
///
/// `==` compares floats bit for bit, so NaN params (meaning "unchanged")
/// compare equal to themselves; [`compare_items`] is the tolerant check.
#[derive(Debug, Clone, Copy)]
pub struct MissionItem {
    /// The MAV_CMD.
    pub command: MavCmd,
    /// Coordinate frame.
    pub frame: MavFrame,
    /// param1..param4.
    pub params: [f32; 4],
    /// param5: latitude * 1e7 or raw integer.
    pub x: i32,
    /// param6: longitude * 1e7 or raw integer.
    pub y: i32,
    /// param7: altitude (m) or raw value.
    pub z: f32,
    /// Continue to the next item when done.
    pub autocontinue: bool,
}

impl PartialEq for MissionItem {
    fn eq(&self, o: &Self) -> bool {
        self.command == o.command
            && self.frame == o.frame
            && self.params.map(f32::to_bits) == o.params.map(f32::to_bits)
            && self.x == o.x
            && self.y == o.y
            && self.z.to_bits() == o.z.to_bits()
            && self.autocontinue == o.autocontinue
    }
}

impl MissionItem {
    /// A non-positional (DO/CONDITION) item in `MAV_FRAME_MISSION`.
    pub fn command(command: MavCmd, params: [f32; 4], x: i32, y: i32, z: f32) -> Self {
        MissionItem {
            command,
            frame: MavFrame::MAV_FRAME_MISSION,
            params,
            x,
            y,
            z,
            autocontinue: true,
        }
    }

    /// True when x/y/z are a global position (lat, lon, alt).
    pub fn is_positional(&self) -> bool {
        matches!(
            self.command,
            MavCmd::MAV_CMD_NAV_WAYPOINT | MavCmd::MAV_CMD_NAV_TAKEOFF | MavCmd::MAV_CMD_NAV_LAND
        )
    }

    /// The MISSION_ITEM_INT message for this item at `seq`.
    pub fn to_mavlink(&self, seq: u16, target: (u8, u8)) -> MISSION_ITEM_INT_DATA {
        MISSION_ITEM_INT_DATA {
            param1: self.params[0],
            param2: self.params[1],
            param3: self.params[2],
            param4: self.params[3],
            x: self.x,
            y: self.y,
            z: self.z,
            seq,
            command: self.command,
            target_system: target.0,
            target_component: target.1,
            frame: self.frame,
            current: 0,
            autocontinue: u8::from(self.autocontinue),
            mission_type: MavMissionType::MAV_MISSION_TYPE_MISSION,
        }
    }

    /// The item carried by a MISSION_ITEM_INT message.
    pub fn from_mavlink(m: &MISSION_ITEM_INT_DATA) -> Self {
        MissionItem {
            command: m.command,
            frame: m.frame,
            params: [m.param1, m.param2, m.param3, m.param4],
            x: m.x,
            y: m.y,
            z: m.z,
            autocontinue: m.autocontinue != 0,
        }
    }

    /// The item carried by a legacy float MISSION_ITEM (lat/lon as f32
    /// degrees, about 1 m resolution), which old vehicles still send.
    #[allow(deprecated)] // Reading the deprecated message is the point.
    pub fn from_mavlink_float(m: &MISSION_ITEM_DATA) -> Self {
        let mut item = MissionItem {
            command: m.command,
            frame: m.frame,
            params: [m.param1, m.param2, m.param3, m.param4],
            x: m.x as i32,
            y: m.y as i32,
            z: m.z,
            autocontinue: m.autocontinue != 0,
        };
        if item.is_positional() {
            item.x = (f64::from(m.x) * 1e7).round() as i32;
            item.y = (f64::from(m.y) * 1e7).round() as i32;
        }
        item
    }
}

/// The float-frame synonym of an `_INT` frame (frames 5/6/11 are the
/// deprecated integer names of 0/3/10; vehicles echo either).
#[allow(deprecated)] // The deprecated names are exactly what we map away from.
pub fn float_frame(f: MavFrame) -> MavFrame {
    match f {
        MavFrame::MAV_FRAME_GLOBAL_INT => MavFrame::MAV_FRAME_GLOBAL,
        MavFrame::MAV_FRAME_GLOBAL_RELATIVE_ALT_INT => MavFrame::MAV_FRAME_GLOBAL_RELATIVE_ALT,
        MavFrame::MAV_FRAME_GLOBAL_TERRAIN_ALT_INT => MavFrame::MAV_FRAME_GLOBAL_TERRAIN_ALT,
        other => other,
    }
}
