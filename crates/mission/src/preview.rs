//! A KML preview of a mission for Google Earth (`mission export --out
//! plan-preview.kml`): the take-off point, the path and one placemark per
//! photo with its heading, pitch and height above take-off. A review file,
//! not a mission: no autopilot flies KML.
//!
//! Altitudes are KML `absolute` (above mean sea level) where the plan's
//! datum gives EGM96 heights, so that Google Earth draws them where the
//! drone will be; otherwise `relativeToGround` with the height above the
//! take-off point, which is only right where the ground is as high as the
//! take-off point (the description says so).

use vp_scene::plan::VerticalDatum;

use crate::error::Result;
use crate::fly::Flight;
use crate::xml::{num, Writer};

/// The preview KML of a flight.
pub fn preview_kml(flight: &Flight, title: &str) -> Result<String> {
    let msl: Option<Vec<f64>> = flight.datum.and_then(|d| {
        flight
            .points
            .iter()
            .map(|p| {
                d.convert(p.alt_m, p.lat_deg, p.lon_deg, VerticalDatum::Egm96)
                    .ok()
            })
            .collect()
    });
    let (mode, alts, note) = match &msl {
        Some(a) => (
            "absolute",
            a.clone(),
            "altitudes above mean sea level (EGM96)",
        ),
        None => (
            "relativeToGround",
            flight
                .points
                .iter()
                .map(|p| p.height_above_home_m)
                .collect(),
            "altitudes are heights above the take-off point, drawn above the ground under \
             each photo (the plan's datum does not give sea-level heights)",
        ),
    };
    let mut w = Writer::document();
    w.open("kml", &[("xmlns", crate::wpml::KML_NS)]);
    w.open("Document", &[]);
    w.leaf("name", title);
    w.leaf(
        "description",
        format!(
            "vpctl mission preview: {} photos, path {:.0} m; {note}. Not a mission file.",
            flight.points.len(),
            flight.path_length_m()
        ),
    );
    w.open("Style", &[("id", "path")]);
    w.open("LineStyle", &[]);
    w.leaf("color", "ff00ffff");
    w.leaf("width", 2);
    w.close();
    w.close();
    w.open("Placemark", &[]);
    w.leaf("name", "take-off (home)");
    w.open("Point", &[]);
    w.leaf("altitudeMode", "clampToGround");
    w.leaf(
        "coordinates",
        format!(
            "{},{},0",
            num(flight.home.lon_deg, 9),
            num(flight.home.lat_deg, 9)
        ),
    );
    w.close();
    w.close();
    w.open("Placemark", &[]);
    w.leaf("name", "path");
    w.leaf("styleUrl", "#path");
    w.open("LineString", &[]);
    w.leaf("altitudeMode", mode);
    let coords: Vec<String> = flight
        .points
        .iter()
        .zip(&alts)
        .map(|(p, a)| format!("{},{},{}", num(p.lon_deg, 9), num(p.lat_deg, 9), num(*a, 2)))
        .collect();
    w.leaf("coordinates", coords.join(" "));
    w.close();
    w.close();
    w.open("Folder", &[]);
    w.leaf("name", "photos");
    for (i, (p, a)) in flight.points.iter().zip(&alts).enumerate() {
        w.open("Placemark", &[]);
        w.leaf("name", format!("photo {}", i + 1));
        w.leaf(
            "description",
            format!(
                "heading {:.1} deg, gimbal pitch {:.1} deg, {:.1} m above take-off",
                p.heading_deg, p.gimbal_pitch_deg, p.height_above_home_m
            ),
        );
        w.open("Point", &[]);
        w.leaf("altitudeMode", mode);
        w.leaf(
            "coordinates",
            format!("{},{},{}", num(p.lon_deg, 9), num(p.lat_deg, 9), num(*a, 2)),
        );
        w.close();
        w.close();
    }
    Ok(w.finish())
}
