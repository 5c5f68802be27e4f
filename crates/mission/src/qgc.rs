//! QGroundControl `.plan` export (JSON, plan version 1, mission version 2).
//!
//! Items are written as `SimpleItem`s only (no survey or structure-scan
//! complex items), which every tool that imports QGC plans understands.
//! NaN params are written as `null`, as QGC does. The home position goes to
//! `plannedHomePosition` (lat, lon, altitude AMSL), not into the items, so
//! an ArduPilot mission's seq-0 home item is left out of `items`.

use serde_json::{json, Value};
use vp_scene::plan::Plan;

use crate::error::{MissionError, Result};
use crate::geodesy::{e7_to_deg, LocalFrame};
use crate::items::{build_mission, float_frame, Autopilot, Mission, MissionItem, MissionOptions};

/// Header values of the `.plan` file.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct QgcOptions {
    /// Fixed-wing cruise speed, m/s (QGC's default 15).
    pub cruise_speed_m_s: f64,
    /// Multicopter hover (mission) speed, m/s (QGC's default 5).
    pub hover_speed_m_s: f64,
    /// MAV_TYPE of the vehicle (2 = quadrotor).
    pub vehicle_type: u32,
}

impl Default for QgcOptions {
    fn default() -> Self {
        QgcOptions {
            cruise_speed_m_s: 15.0,
            hover_speed_m_s: 5.0,
            vehicle_type: 2,
        }
    }
}

fn num(v: f64) -> Value {
    if v.is_finite() {
        json!(v)
    } else {
        Value::Null
    }
}

fn simple_item(item: &MissionItem, jump_id: usize) -> Value {
    let positional = item.is_positional();
    let (x, y) = if positional {
        (e7_to_deg(item.x), e7_to_deg(item.y))
    } else {
        (f64::from(item.x), f64::from(item.y))
    };
    let p = item.params;
    let params = vec![
        num(f64::from(p[0])),
        num(f64::from(p[1])),
        num(f64::from(p[2])),
        num(f64::from(p[3])),
        num(x),
        num(y),
        num(f64::from(item.z)),
    ];
    let mut v = json!({
        "type": "SimpleItem",
        "autoContinue": item.autocontinue,
        "command": item.command as u32,
        "doJumpId": jump_id,
        "frame": float_frame(item.frame) as u32,
        "params": params,
    });
    if positional {
        v["AMSLAltAboveTerrain"] = Value::Null;
        v["Altitude"] = num(f64::from(item.z));
        // 1 = altitude relative to home, the frame the items use.
        v["AltitudeMode"] = json!(1);
    }
    v
}

/// The `.plan` JSON of a mission; `fence` is an inclusion polygon as
/// (lat, lon) degrees (empty: no fence).
pub fn qgc_plan(mission: &Mission, fence: &[[f64; 2]], opts: &QgcOptions) -> Value {
    let skip = usize::from(mission.autopilot == Autopilot::ArduPilot);
    let items: Vec<Value> = mission
        .items
        .iter()
        .skip(skip)
        .enumerate()
        .map(|(i, it)| simple_item(it, i + 1))
        .collect();
    let firmware = match mission.autopilot {
        Autopilot::Px4 => 12,
        Autopilot::ArduPilot => 3,
    };
    let polygons = if fence.is_empty() {
        Vec::new()
    } else {
        vec![json!({ "inclusion": true, "polygon": fence, "version": 1 })]
    };
    let home = mission.home;
    json!({
        "fileType": "Plan",
        "version": 1,
        "groundStation": "QGroundControl",
        "mission": {
            "version": 2,
            "firmwareType": firmware,
            "vehicleType": opts.vehicle_type,
            "cruiseSpeed": opts.cruise_speed_m_s,
            "hoverSpeed": opts.hover_speed_m_s,
            "globalPlanAltitudeMode": 1,
            "plannedHomePosition": [home.lat_deg, home.lon_deg, home.alt_m],
            "items": items,
        },
        "geoFence": { "version": 2, "circles": [], "polygons": polygons },
        "rallyPoints": { "version": 2, "points": [] },
    })
}

/// Builds the mission of `plan` and returns its `.plan` file text
/// (pretty JSON), with the plan's geofence converted to lat/lon.
pub fn export_qgc(plan: &Plan, mission_opts: &MissionOptions, opts: &QgcOptions) -> Result<String> {
    let mission = build_mission(plan, mission_opts)?;
    let fence = match (&plan.geofence, plan.origin) {
        (Some(poly), Some(origin)) => {
            let frame = LocalFrame::new(origin)?;
            poly.iter()
                .map(|p| {
                    let g = frame.to_geodetic([p[0], p[1], 0.0]);
                    [g.lat_deg, g.lon_deg]
                })
                .collect()
        }
        _ => Vec::new(),
    };
    serde_json::to_string_pretty(&qgc_plan(&mission, &fence, opts))
        .map_err(|e| MissionError::InvalidInput(format!("cannot serialise the .plan: {e}")))
}

#[cfg(test)]
mod tests {
    use super::*;
    use vp_scene::plan::{GeodeticOrigin, PlannedView, Role};

    fn plan() -> Plan {
        let mut p = Plan::new(Some(GeodeticOrigin {
            lat_deg: 47.397_742,
            lon_deg: 8.545_594,
            alt_m: 488.0,
        }));
        p.home = p.origin.map(vp_scene::plan::Home::origin_on_ground);
        for i in 0..2 {
            p.waypoints.push(PlannedView {
                position: [f64::from(i) * 20.0, 0.0, 30.0],
                yaw_deg: 0.0,
                pitch_deg: -90.0,
                roll_deg: 0.0,
                role: Role::Grid,
                triplet_id: None,
                expected_gain: None,
                angle_bin_deg: None,
            });
        }
        p.geofence = Some(vec![
            [-100.0, -100.0],
            [100.0, -100.0],
            [100.0, 100.0],
            [-100.0, 100.0],
        ]);
        p
    }

    #[test]
    fn plan_file_has_the_structure_qgc_reads() {
        let text = export_qgc(
            &plan(),
            &MissionOptions::for_autopilot(Autopilot::Px4),
            &QgcOptions::default(),
        )
        .unwrap();
        let v: Value = serde_json::from_str(&text).unwrap();
        assert_eq!(v["fileType"], "Plan");
        assert_eq!(v["version"], 1);
        let m = &v["mission"];
        assert_eq!(m["version"], 2);
        assert_eq!(m["firmwareType"], 12);
        assert_eq!(m["vehicleType"], 2);
        assert_eq!(m["plannedHomePosition"].as_array().unwrap().len(), 3);
        let items = m["items"].as_array().unwrap();
        // takeoff + 2 x (gimbal, waypoint, photo) + RTL
        assert_eq!(items.len(), 8);
        for (i, it) in items.iter().enumerate() {
            assert_eq!(it["type"], "SimpleItem");
            assert_eq!(it["doJumpId"], i + 1);
            assert_eq!(it["params"].as_array().unwrap().len(), 7);
        }
        let wp = &items[2];
        assert_eq!(wp["command"], 16);
        assert_eq!(wp["frame"], 3);
        let lat = wp["params"][4].as_f64().unwrap();
        assert!((lat - 47.397_742).abs() < 1e-6);
        assert!((wp["Altitude"].as_f64().unwrap() - 30.0).abs() < 1e-3);
        // The photo's reserved param7 is NaN: written as null.
        assert!(items[3]["params"][6].is_null());
        let fence = &v["geoFence"]["polygons"][0];
        assert_eq!(fence["inclusion"], true);
        assert_eq!(fence["polygon"].as_array().unwrap().len(), 4);
        assert_eq!(v["rallyPoints"]["points"].as_array().unwrap().len(), 0);
    }

    #[test]
    fn ardupilot_home_goes_to_planned_home_not_items() {
        let text = export_qgc(
            &plan(),
            &MissionOptions::for_autopilot(Autopilot::ArduPilot),
            &QgcOptions::default(),
        )
        .unwrap();
        let v: Value = serde_json::from_str(&text).unwrap();
        assert_eq!(v["mission"]["firmwareType"], 3);
        let items = v["mission"]["items"].as_array().unwrap();
        assert_eq!(
            items[0]["command"], 22,
            "first item is the takeoff, not home"
        );
        // Takeoff, 2 views x (gimbal, heading, waypoint, photo), RTL.
        assert_eq!(items.len(), 10);
    }
}
