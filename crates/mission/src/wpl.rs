//! The plain `QGC WPL 110` waypoint text format (QGC, Mission Planner, MAVProxy).
//!
//! One line per item, tab separated: index, current, frame, command,
//! param1..4, x/lat, y/lon, z/alt, autocontinue. Line 0 is the home
//! position (absolute altitude, frame 0), as every reader expects; an
//! ArduPilot mission's own seq-0 home item becomes that line.

use std::fmt::Write as _;
use std::path::Path;

use mavlink::dialects::common::{MavCmd, MavFrame};
use num_traits::FromPrimitive;
use vp_scene::{Location, SceneError};

use crate::error::{MissionError, Result};
use crate::geodesy::{deg_to_e7, e7_to_deg};
use crate::items::{Autopilot, Mission, MissionItem};

/// The first line of the format.
pub const WPL_HEADER: &str = "QGC WPL 110";

fn fmt_f(v: f64, decimals: usize) -> String {
    if v.is_nan() {
        "nan".into()
    } else {
        format!("{v:.decimals$}")
    }
}

fn line(out: &mut String, seq: usize, item: &MissionItem) {
    let (x, y) = if item.is_positional() {
        (fmt_f(e7_to_deg(item.x), 8), fmt_f(e7_to_deg(item.y), 8))
    } else {
        (item.x.to_string(), item.y.to_string())
    };
    let p = item.params.map(|v| fmt_f(f64::from(v), 6));
    let _ = writeln!(
        out,
        "{seq}\t0\t{}\t{}\t{}\t{}\t{}\t{}\t{x}\t{y}\t{}\t{}",
        item.frame as u32,
        item.command as u32,
        p[0],
        p[1],
        p[2],
        p[3],
        fmt_f(f64::from(item.z), 6),
        u8::from(item.autocontinue)
    );
}

/// The mission as `QGC WPL 110` text.
pub fn export_wpl(mission: &Mission) -> Result<String> {
    let mut out = String::from(WPL_HEADER);
    out.push('\n');
    let h = mission.home;
    let _ = writeln!(
        out,
        "0\t1\t0\t16\t0\t0\t0\t0\t{}\t{}\t{}\t1",
        fmt_f(e7_to_deg(deg_to_e7(h.lat_deg)?), 8),
        fmt_f(e7_to_deg(deg_to_e7(h.lon_deg)?), 8),
        fmt_f(h.alt_m, 6)
    );
    let skip = usize::from(mission.autopilot == Autopilot::ArduPilot);
    for (i, item) in mission.items.iter().skip(skip).enumerate() {
        line(&mut out, i + 1, item);
    }
    Ok(out)
}

/// Parses `QGC WPL 110` text into its home line and items (seq order).
/// `path` only names the source in errors.
pub fn parse_wpl(text: &str, path: &Path) -> Result<(MissionItem, Vec<MissionItem>)> {
    let err = |line: usize, msg: String| -> MissionError {
        SceneError::parse(path, Location::Line(line), msg).into()
    };
    let mut lines = text
        .lines()
        .enumerate()
        .filter(|(_, l)| !l.trim().is_empty());
    match lines.next() {
        Some((_, l)) if l.trim() == WPL_HEADER => {}
        _ => return Err(err(1, format!("missing header {WPL_HEADER:?}"))),
    }
    let mut items = Vec::new();
    for (i, l) in lines {
        let n = i + 1;
        let f: Vec<&str> = l.split_whitespace().collect();
        if f.len() != 12 {
            return Err(err(n, format!("expected 12 fields, found {}", f.len())));
        }
        let int = |k: usize| {
            f[k].parse::<i64>()
                .map_err(|_| err(n, format!("field {}: {:?} is not an integer", k + 1, f[k])))
        };
        let float = |k: usize| {
            f[k].parse::<f64>()
                .map_err(|_| err(n, format!("field {}: {:?} is not a number", k + 1, f[k])))
        };
        if usize::try_from(int(0)?).ok() != Some(items.len()) {
            return Err(err(
                n,
                format!("index {} out of sequence (expected {})", f[0], items.len()),
            ));
        }
        let frame = u32::try_from(int(2)?)
            .ok()
            .and_then(MavFrame::from_u32)
            .ok_or_else(|| err(n, format!("unknown frame {}", f[2])))?;
        let command = u32::try_from(int(3)?)
            .ok()
            .and_then(MavCmd::from_u32)
            .ok_or_else(|| err(n, format!("unknown command {}", f[3])))?;
        let mut item = MissionItem {
            command,
            frame,
            params: [
                float(4)? as f32,
                float(5)? as f32,
                float(6)? as f32,
                float(7)? as f32,
            ],
            x: 0,
            y: 0,
            z: float(10)? as f32,
            autocontinue: int(11)? != 0,
        };
        if item.is_positional() {
            item.x = deg_to_e7(float(8)?).map_err(|e| err(n, e.to_string()))?;
            item.y = deg_to_e7(float(9)?).map_err(|e| err(n, e.to_string()))?;
        } else {
            item.x = float(8)? as i32;
            item.y = float(9)? as i32;
        }
        items.push(item);
    }
    if items.is_empty() {
        return Err(err(2, "no home line".into()));
    }
    let home = items.remove(0);
    Ok((home, items))
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::items::{build_mission, compare_items, MissionOptions};
    use vp_scene::plan::{GeodeticOrigin, Plan, PlannedView, Role};

    fn mission(a: Autopilot) -> Mission {
        let mut p = Plan::new(Some(GeodeticOrigin {
            lat_deg: -33.86,
            lon_deg: 151.21,
            alt_m: 20.0,
        }));
        p.home = p.origin.map(vp_scene::plan::Home::origin_on_ground);
        p.waypoints.push(PlannedView {
            position: [5.0, 6.0, 25.0],
            yaw_deg: 45.0,
            pitch_deg: -60.0,
            roll_deg: 0.0,
            role: Role::Bridge,
            triplet_id: None,
            expected_gain: None,
            angle_bin_deg: None,
        });
        build_mission(&p, &MissionOptions::for_autopilot(a)).unwrap()
    }

    #[test]
    fn wpl_round_trip() {
        let m = mission(Autopilot::Px4);
        let text = export_wpl(&m).unwrap();
        assert!(text.starts_with("QGC WPL 110\n0\t1\t0\t16\t"));
        let (home, items) = parse_wpl(&text, Path::new("m.waypoints")).unwrap();
        assert_eq!(home.x, -338_600_000);
        compare_items(&m.items, &items, Autopilot::Px4).unwrap();
    }

    #[test]
    fn ardupilot_home_is_line_zero_once() {
        let m = mission(Autopilot::ArduPilot);
        let text = export_wpl(&m).unwrap();
        let (_, items) = parse_wpl(&text, Path::new("m.waypoints")).unwrap();
        assert_eq!(items.len(), m.items.len() - 1);
    }

    #[test]
    fn bad_line_is_named() {
        let text = "QGC WPL 110\n0\t1\t0\t16\t0\t0\t0\t0\t1\t2\t3\t1\n1\t0\t3\t16\t0\t0\n";
        let e = parse_wpl(text, Path::new("m.waypoints"))
            .unwrap_err()
            .to_string();
        assert!(
            e.contains("m.waypoints: line 3") && e.contains("12 fields"),
            "{e}"
        );
    }
}
