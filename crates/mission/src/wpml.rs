//! DJI WPML missions (`.kmz`) for DJI Pilot 2 and FlightHub 2.
//!
//! A `.kmz` is a ZIP holding `wpmz/template.kml` (what the apps show and
//! edit) and `wpmz/waylines.wpml` (what the aircraft executes), both KML
//! with DJI's `wpml` namespace (WPML 1.0.6, as DJI Pilot 2 writes it today;
//! the element reference is DJI's Cloud API documentation). One waypoint
//! per planned photo; each has the planned heading (`smoothTransition`,
//! turning during the leg), stops (`toPointAndStopWithDiscontinuityCurvature`)
//! and on arrival runs one action group: `gimbalRotate` to the planned
//! pitch, `hover` for the hold time, `takePhoto`.
//!
//! Heights: `relativeToStartPoint` (above the take-off point: the home
//! must be known, which [`Flight::of_plan`] insists on) or `WGS84`
//! ellipsoidal heights in the waylines with EGM96 heights in the template
//! (as DJI's own mapping missions do), converted from the plan's datum.
//!
//! Safety defaults: at the end go home (`goHome`; `noAction` when the
//! operator asked for no return-to-launch), on RC loss leave the mission
//! and fly back (`executeLostAction`, `goBack`), climb to the take-off
//! height before the first leg (`takeOffSecurityHeight`), return at the
//! highest planned height (`globalRTHHeight`).
//!
//! This writer has been checked against DJI's files and reference, not
//! loaded on a real aircraft.

use std::io::Write;

use crate::error::{MissionError, Result};
use crate::fly::{estimate, Flight, FlightPoint};
use crate::xml::{num, Writer};
use vp_scene::plan::VerticalDatum;

/// The WPML namespace DJI Pilot 2 writes.
pub const WPML_NS: &str = "http://www.dji.com/wpmz/1.0.6";
/// The KML namespace.
pub const KML_NS: &str = "http://www.opengis.net/kml/2.2";
/// At most this many waypoints in one wayline (`wpml:index` is 0-65535).
pub const MAX_WAYPOINTS: usize = 65_535;
/// Gimbal pitch every supported aircraft reaches, degrees (the M3E/M3T
/// gimbal: -90 to +35).
pub const GIMBAL_PITCH_RANGE_DEG: (f64, f64) = (-90.0, 35.0);

/// An aircraft and its camera, as WPML names them (`droneEnumValue`,
/// `droneSubEnumValue`, `payloadEnumValue`; DJI Cloud API, "Common
/// Elements" and the product support enumerations).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Drone {
    /// Mavic 3 Enterprise (M3E), its wide camera.
    M3e,
    /// Mavic 3 Thermal (M3T).
    M3t,
    /// Mavic 3 Multispectral (M3M).
    M3m,
    /// Matrice 30.
    M30,
    /// Matrice 30T.
    M30t,
    /// Matrice 300 RTK with a Zenmuse H20 in the first gimbal port.
    M300,
    /// Matrice 350 RTK with a Zenmuse H20 in the first gimbal port.
    M350,
    /// Matrice 3D (dock).
    M3d,
    /// Matrice 3TD (dock).
    M3td,
}

impl Drone {
    /// Every supported aircraft.
    pub const ALL: [Drone; 9] = [
        Drone::M3e,
        Drone::M3t,
        Drone::M3m,
        Drone::M30,
        Drone::M30t,
        Drone::M300,
        Drone::M350,
        Drone::M3d,
        Drone::M3td,
    ];

    /// The name on command lines and in Python.
    pub fn name(self) -> &'static str {
        match self {
            Drone::M3e => "m3e",
            Drone::M3t => "m3t",
            Drone::M3m => "m3m",
            Drone::M30 => "m30",
            Drone::M30t => "m30t",
            Drone::M300 => "m300",
            Drone::M350 => "m350",
            Drone::M3d => "m3d",
            Drone::M3td => "m3td",
        }
    }

    /// (droneEnumValue, droneSubEnumValue, payloadEnumValue).
    pub fn enums(self) -> (u32, u32, u32) {
        match self {
            Drone::M3e => (77, 0, 66),
            Drone::M3t => (77, 1, 67),
            Drone::M3m => (77, 2, 68),
            Drone::M30 => (67, 0, 52),
            Drone::M30t => (67, 1, 53),
            Drone::M300 => (60, 0, 42),
            Drone::M350 => (89, 0, 42),
            Drone::M3d => (91, 0, 80),
            Drone::M3td => (91, 1, 81),
        }
    }
}

impl std::str::FromStr for Drone {
    type Err = MissionError;
    fn from_str(s: &str) -> Result<Drone> {
        let key = s.trim().to_ascii_lowercase().replace(['-', '_', ' '], "");
        Drone::ALL
            .into_iter()
            .find(|d| d.name() == key)
            .ok_or_else(|| {
                let names: Vec<&str> = Drone::ALL.iter().map(|d| d.name()).collect();
                MissionError::InvalidInput(format!(
                    "unknown drone {s:?}: DJI WPML missions are written for {}",
                    names.join(", ")
                ))
            })
    }
}

/// The height reference of a WPML mission.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum WpmlHeights {
    /// `relativeToStartPoint`: heights above the take-off point.
    RelativeToStartPoint,
    /// `WGS84`: ellipsoidal heights (EGM96 in the template).
    Wgs84,
}

impl std::str::FromStr for WpmlHeights {
    type Err = MissionError;
    fn from_str(s: &str) -> Result<WpmlHeights> {
        match s.trim().to_ascii_lowercase().as_str() {
            "relative" | "relativetostartpoint" | "takeoff" => {
                Ok(WpmlHeights::RelativeToStartPoint)
            }
            "wgs84" | "ellipsoid" => Ok(WpmlHeights::Wgs84),
            _ => Err(MissionError::InvalidInput(format!(
                "WPML heights {s:?}: expected relative (above the take-off point) or wgs84"
            ))),
        }
    }
}

/// What a WPML mission is written for.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct WpmlOptions {
    /// Aircraft and camera.
    pub drone: Drone,
    /// Height reference.
    pub heights: WpmlHeights,
    /// `createTime`/`updateTime`, milliseconds since 1970 (fixed in tests
    /// so that the same plan gives the same bytes).
    pub time_ms: u64,
}

/// The two documents of a `.kmz`: (`template.kml`, `waylines.wpml`).
pub fn wpml_documents(flight: &Flight, opts: &WpmlOptions) -> Result<(String, String)> {
    if flight.points.len() > MAX_WAYPOINTS {
        return Err(MissionError::InvalidInput(format!(
            "{} waypoints: a WPML wayline holds at most {MAX_WAYPOINTS}",
            flight.points.len()
        )));
    }
    let (lo, hi) = GIMBAL_PITCH_RANGE_DEG;
    if let Some((i, p)) = flight
        .points
        .iter()
        .enumerate()
        .find(|(_, p)| !(lo..=hi).contains(&p.gimbal_pitch_deg))
    {
        return Err(MissionError::InvalidInput(format!(
            "waypoint {i}: gimbal pitch {:.1} deg is outside the {lo} to {hi} deg DJI gimbals reach",
            p.gimbal_pitch_deg
        )));
    }
    let heights = Heights::of(flight, opts.heights)?;
    let e = estimate(flight);
    let (distance_m, duration_s) = (e.distance_m, e.duration_s);
    Ok((
        template(flight, opts, &heights),
        waylines(flight, opts, &heights, distance_m, duration_s),
    ))
}

/// The `.kmz` bytes of a flight (deflated ZIP, fixed timestamps).
pub fn kmz_bytes(flight: &Flight, opts: &WpmlOptions) -> Result<Vec<u8>> {
    let (template, waylines) = wpml_documents(flight, opts)?;
    let zip_err = |e: zip::result::ZipError| {
        MissionError::InvalidInput(format!("cannot build the .kmz archive: {e}"))
    };
    let mut zip = zip::ZipWriter::new(std::io::Cursor::new(Vec::new()));
    let o = zip::write::SimpleFileOptions::default()
        .compression_method(zip::CompressionMethod::Deflated)
        .last_modified_time(zip::DateTime::default());
    zip.add_directory("wpmz/", o).map_err(zip_err)?;
    for (name, text) in [
        ("wpmz/template.kml", &template),
        ("wpmz/waylines.wpml", &waylines),
    ] {
        zip.start_file(name, o).map_err(zip_err)?;
        zip.write_all(text.as_bytes())
            .map_err(|e| MissionError::InvalidInput(format!("cannot deflate {name}: {e}")))?;
    }
    Ok(zip.finish().map_err(zip_err)?.into_inner())
}

/// Per-point heights in the template and the waylines.
struct Heights {
    /// `executeHeight` of each point.
    execute: Vec<f64>,
    /// Template `height` of each point (EGM96 or relative).
    template: Vec<f64>,
    /// Template `ellipsoidHeight` of each point.
    ellipsoid: Vec<f64>,
    /// The home's ellipsoidal height, where the plan's datum gives it.
    home_ellipsoid: Option<f64>,
    mode: WpmlHeights,
}

impl Heights {
    fn of(flight: &Flight, mode: WpmlHeights) -> Result<Heights> {
        let h = flight.home;
        let home_ellipsoid = flight.datum.and_then(|d| {
            d.convert(h.alt_m, h.lat_deg, h.lon_deg, VerticalDatum::Ellipsoid)
                .ok()
        });
        match mode {
            WpmlHeights::RelativeToStartPoint => {
                let rel: Vec<f64> = flight
                    .points
                    .iter()
                    .map(|p| p.height_above_home_m)
                    .collect();
                Ok(Heights {
                    execute: rel.clone(),
                    template: rel.clone(),
                    ellipsoid: rel,
                    home_ellipsoid,
                    mode,
                })
            }
            WpmlHeights::Wgs84 => {
                let ell = flight.ellipsoid_heights_m()?;
                let egm: Vec<f64> = flight
                    .points
                    .iter()
                    .zip(&ell)
                    .map(|(p, &e)| {
                        VerticalDatum::Ellipsoid.convert(
                            e,
                            p.lat_deg,
                            p.lon_deg,
                            VerticalDatum::Egm96,
                        )
                    })
                    .collect::<std::result::Result<_, _>>()?;
                Ok(Heights {
                    execute: ell.clone(),
                    template: egm,
                    ellipsoid: ell,
                    home_ellipsoid,
                    mode,
                })
            }
        }
    }
}

/// Compass heading in [0, 360) as WPML's [-180, 180].
fn wpml_heading(deg: f64) -> f64 {
    let d = deg.rem_euclid(360.0);
    if d > 180.0 {
        d - 360.0
    } else {
        d
    }
}

fn root(w: &mut Writer) {
    w.open("kml", &[("xmlns", KML_NS), ("xmlns:wpml", WPML_NS)]);
    w.open("Document", &[]);
}

fn mission_config(w: &mut Writer, flight: &Flight, opts: &WpmlOptions, h: &Heights, tpl: bool) {
    let (drone, drone_sub, payload) = opts.drone.enums();
    let rth = flight
        .points
        .iter()
        .map(|p| p.height_above_home_m)
        .fold(flight.takeoff_m.unwrap_or(20.0), f64::max)
        .ceil()
        .min(flight.ceiling_m);
    w.open("wpml:missionConfig", &[]);
    w.leaf("wpml:flyToWaylineMode", "safely");
    w.leaf(
        "wpml:finishAction",
        if flight.return_to_launch {
            "goHome"
        } else {
            "noAction"
        },
    );
    w.leaf("wpml:exitOnRCLost", "executeLostAction");
    w.leaf("wpml:executeRCLostAction", "goBack");
    w.leaf(
        "wpml:takeOffSecurityHeight",
        num(flight.takeoff_m.unwrap_or(20.0).clamp(2.0, 1500.0), 3),
    );
    if tpl {
        if let Some(alt) = h.home_ellipsoid {
            let home = flight.home;
            w.leaf(
                "wpml:takeOffRefPoint",
                format!(
                    "{},{},{}",
                    num(home.lat_deg, 9),
                    num(home.lon_deg, 9),
                    num(alt, 3)
                ),
            );
            w.leaf("wpml:takeOffRefPointAGLHeight", 0);
        }
    }
    w.leaf(
        "wpml:globalTransitionalSpeed",
        num(flight.speed_m_s.min(15.0), 2),
    );
    w.leaf("wpml:globalRTHHeight", num(rth, 1));
    w.open("wpml:droneInfo", &[]);
    w.leaf("wpml:droneEnumValue", drone);
    w.leaf("wpml:droneSubEnumValue", drone_sub);
    w.close();
    w.leaf("wpml:waylineAvoidLimitAreaMode", 0);
    w.open("wpml:payloadInfo", &[]);
    w.leaf("wpml:payloadEnumValue", payload);
    w.leaf("wpml:payloadSubEnumValue", 0);
    w.leaf("wpml:payloadPositionIndex", 0);
    w.close();
    w.close();
}

fn point(w: &mut Writer, p: &FlightPoint) {
    w.open("Point", &[]);
    w.leaf(
        "coordinates",
        format!("{},{}", num(p.lon_deg, 12), num(p.lat_deg, 12)),
    );
    w.close();
}

fn heading_param(w: &mut Writer, p: &FlightPoint, waylines: bool) {
    w.open("wpml:waypointHeadingParam", &[]);
    w.leaf("wpml:waypointHeadingMode", "smoothTransition");
    w.leaf(
        "wpml:waypointHeadingAngle",
        num(wpml_heading(p.heading_deg), 3),
    );
    w.leaf("wpml:waypointPoiPoint", "0.000000,0.000000,0.000000");
    if waylines {
        w.leaf("wpml:waypointHeadingAngleEnable", 1);
    }
    w.leaf("wpml:waypointHeadingPathMode", "followBadArc");
    w.leaf("wpml:waypointHeadingPoiIndex", 0);
    w.close();
}

fn turn_param(w: &mut Writer) {
    w.open("wpml:waypointTurnParam", &[]);
    w.leaf(
        "wpml:waypointTurnMode",
        "toPointAndStopWithDiscontinuityCurvature",
    );
    w.leaf("wpml:waypointTurnDampingDist", 0);
    w.close();
}

/// The action group of waypoint `i`: gimbal to the planned pitch, hover
/// for the hold, one photo.
fn action_group(w: &mut Writer, i: usize, p: &FlightPoint, hold_s: f64) {
    w.open("wpml:actionGroup", &[]);
    w.leaf("wpml:actionGroupId", i);
    w.leaf("wpml:actionGroupStartIndex", i);
    w.leaf("wpml:actionGroupEndIndex", i);
    w.leaf("wpml:actionGroupMode", "sequence");
    w.open("wpml:actionTrigger", &[]);
    w.leaf("wpml:actionTriggerType", "reachPoint");
    w.close();
    let mut id = 0;
    w.open("wpml:action", &[]);
    w.leaf("wpml:actionId", id);
    w.leaf("wpml:actionActuatorFunc", "gimbalRotate");
    w.open("wpml:actionActuatorFuncParam", &[]);
    w.leaf("wpml:gimbalHeadingYawBase", "north");
    w.leaf("wpml:gimbalRotateMode", "absoluteAngle");
    w.leaf("wpml:gimbalPitchRotateEnable", 1);
    w.leaf("wpml:gimbalPitchRotateAngle", num(p.gimbal_pitch_deg, 3));
    w.leaf("wpml:gimbalRollRotateEnable", 0);
    w.leaf("wpml:gimbalRollRotateAngle", 0);
    w.leaf("wpml:gimbalYawRotateEnable", 0);
    w.leaf("wpml:gimbalYawRotateAngle", 0);
    w.leaf("wpml:gimbalRotateTimeEnable", 0);
    w.leaf("wpml:gimbalRotateTime", 0);
    w.leaf("wpml:payloadPositionIndex", 0);
    w.close();
    w.close();
    if hold_s > 0.0 {
        id += 1;
        w.open("wpml:action", &[]);
        w.leaf("wpml:actionId", id);
        w.leaf("wpml:actionActuatorFunc", "hover");
        w.open("wpml:actionActuatorFuncParam", &[]);
        w.leaf("wpml:hoverTime", num(hold_s, 2));
        w.close();
        w.close();
    }
    id += 1;
    w.open("wpml:action", &[]);
    w.leaf("wpml:actionId", id);
    w.leaf("wpml:actionActuatorFunc", "takePhoto");
    w.open("wpml:actionActuatorFuncParam", &[]);
    w.leaf("wpml:fileSuffix", format!("vpctl{:04}", i + 1));
    w.leaf("wpml:payloadPositionIndex", 0);
    w.leaf("wpml:useGlobalPayloadLensIndex", 0);
    w.close();
    w.close();
    w.close();
}

fn template(flight: &Flight, opts: &WpmlOptions, h: &Heights) -> String {
    let mut w = Writer::document();
    root(&mut w);
    w.leaf("wpml:author", "vpctl");
    w.leaf("wpml:createTime", opts.time_ms);
    w.leaf("wpml:updateTime", opts.time_ms);
    mission_config(&mut w, flight, opts, h, true);
    w.open("Folder", &[]);
    w.leaf("wpml:templateType", "waypoint");
    w.leaf("wpml:templateId", 0);
    w.open("wpml:waylineCoordinateSysParam", &[]);
    w.leaf("wpml:coordinateMode", "WGS84");
    w.leaf(
        "wpml:heightMode",
        match h.mode {
            WpmlHeights::RelativeToStartPoint => "relativeToStartPoint",
            WpmlHeights::Wgs84 => "EGM96",
        },
    );
    w.close();
    w.leaf("wpml:autoFlightSpeed", num(flight.speed_m_s, 2));
    w.leaf(
        "wpml:globalHeight",
        num(h.template.first().copied().unwrap_or(0.0), 3),
    );
    w.leaf("wpml:caliFlightEnable", 0);
    w.leaf("wpml:gimbalPitchMode", "usePointSetting");
    w.open("wpml:globalWaypointHeadingParam", &[]);
    w.leaf("wpml:waypointHeadingMode", "followWayline");
    w.leaf("wpml:waypointHeadingAngle", 0);
    w.leaf("wpml:waypointPoiPoint", "0.000000,0.000000,0.000000");
    w.leaf("wpml:waypointHeadingPathMode", "followBadArc");
    w.leaf("wpml:waypointHeadingPoiIndex", 0);
    w.close();
    w.leaf(
        "wpml:globalWaypointTurnMode",
        "toPointAndStopWithDiscontinuityCurvature",
    );
    w.leaf("wpml:globalUseStraightLine", 1);
    for (i, p) in flight.points.iter().enumerate() {
        w.open("Placemark", &[]);
        point(&mut w, p);
        w.leaf("wpml:index", i);
        w.leaf("wpml:ellipsoidHeight", num(h.ellipsoid[i], 3));
        w.leaf("wpml:height", num(h.template[i], 3));
        w.leaf("wpml:useGlobalHeight", 0);
        w.leaf("wpml:waypointSpeed", num(flight.speed_m_s, 2));
        heading_param(&mut w, p, false);
        turn_param(&mut w);
        w.leaf("wpml:useGlobalSpeed", 1);
        w.leaf("wpml:useGlobalHeadingParam", 0);
        w.leaf("wpml:useGlobalTurnParam", 1);
        w.leaf("wpml:gimbalPitchAngle", num(p.gimbal_pitch_deg, 3));
        w.leaf("wpml:useStraightLine", 1);
        action_group(&mut w, i, p, flight.hold_s);
        w.leaf("wpml:isRisky", 0);
        w.close();
    }
    w.open("wpml:payloadParam", &[]);
    w.leaf("wpml:payloadPositionIndex", 0);
    w.leaf("wpml:focusMode", "firstPoint");
    w.leaf("wpml:meteringMode", "average");
    w.close();
    w.finish()
}

fn waylines(
    flight: &Flight,
    opts: &WpmlOptions,
    h: &Heights,
    distance_m: f64,
    duration_s: f64,
) -> String {
    let mut w = Writer::document();
    root(&mut w);
    mission_config(&mut w, flight, opts, h, false);
    w.open("Folder", &[]);
    w.leaf("wpml:templateId", 0);
    w.leaf(
        "wpml:executeHeightMode",
        match h.mode {
            WpmlHeights::RelativeToStartPoint => "relativeToStartPoint",
            WpmlHeights::Wgs84 => "WGS84",
        },
    );
    w.leaf("wpml:waylineId", 0);
    w.leaf("wpml:distance", num(distance_m, 3));
    w.leaf("wpml:duration", num(duration_s, 3));
    w.leaf("wpml:autoFlightSpeed", num(flight.speed_m_s, 2));
    for (i, p) in flight.points.iter().enumerate() {
        w.open("Placemark", &[]);
        point(&mut w, p);
        w.leaf("wpml:index", i);
        w.leaf("wpml:executeHeight", num(h.execute[i], 3));
        w.leaf("wpml:waypointSpeed", num(flight.speed_m_s, 2));
        heading_param(&mut w, p, true);
        turn_param(&mut w);
        w.leaf("wpml:useStraightLine", 1);
        action_group(&mut w, i, p, flight.hold_s);
        w.open("wpml:waypointGimbalHeadingParam", &[]);
        w.leaf("wpml:waypointGimbalPitchAngle", num(p.gimbal_pitch_deg, 3));
        w.leaf("wpml:waypointGimbalYawAngle", 0);
        w.close();
        w.leaf("wpml:isRisky", 0);
        w.leaf("wpml:waypointWorkType", 0);
        w.close();
    }
    w.finish()
}
