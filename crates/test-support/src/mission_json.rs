//! Mission items a Python peer (MAVSDK, pymavlink) printed as JSON, read
//! back into vp-mission's type so a test can compare them with what was
//! sent (one reader for both peers' tests).

use mavlink::dialects::common::{MavCmd, MavFrame};
use num_traits::FromPrimitive;
use serde_json::Value;
use vp_mission::MissionItem;

/// A JSON number as `f32`; `null` (how the scripts write NaN) is NaN.
fn json_f32(v: &Value) -> f32 {
    v.as_f64().map_or(f32::NAN, |x| x as f32)
}

/// The items of a JSON array of MAVLink `MISSION_ITEM_INT` fields
/// (`command`, `frame`, `param1`-`param4`, `x`, `y`, `z`, `autocontinue`).
/// Panics on a malformed array: the peer scripts are the tests' own.
pub fn items_from_json(items: &Value) -> Vec<MissionItem> {
    items
        .as_array()
        .expect("a JSON array of mission items")
        .iter()
        .map(|it| MissionItem {
            command: MavCmd::from_u64(it["command"].as_u64().unwrap()).unwrap(),
            frame: MavFrame::from_u64(it["frame"].as_u64().unwrap()).unwrap(),
            params: [
                json_f32(&it["param1"]),
                json_f32(&it["param2"]),
                json_f32(&it["param3"]),
                json_f32(&it["param4"]),
            ],
            x: it["x"].as_i64().unwrap() as i32,
            y: it["y"].as_i64().unwrap() as i32,
            z: json_f32(&it["z"]),
            autocontinue: it["autocontinue"].as_u64() == Some(1),
        })
        .collect()
}
