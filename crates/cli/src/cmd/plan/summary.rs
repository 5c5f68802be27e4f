//! The summary lines `vpctl plan` and `vpctl plan grid` print after the
//! plan is written: the home, the flights with their distance and time, a
//! grid's resolution and spacings.

use std::io::Write;

use anyhow::Result;
use vp_planner::grid::GridFigures;
use vp_scene::datum::VerticalDatum;
use vp_scene::flight_time::FlightParams;
use vp_scene::plan::Plan;

/// The home line of the summary: where relative heights are measured from,
/// or what a mission export will need.
pub(super) fn print_home(plan: &Plan, out: &mut dyn Write) -> Result<()> {
    let datum = plan
        .vertical_datum
        .map_or("unstated datum", VerticalDatum::name);
    match &plan.home {
        Some(h) => writeln!(
            out,
            "home: {:.7},{:.7},{:.2} m ({datum}; {})",
            h.position.lat_deg, h.position.lon_deg, h.position.alt_m, h.source
        )?,
        None => writeln!(
            out,
            "home: none (a mission export will need --home LAT,LON,ALT; or plan again with \
             --home or --home-from-first-image)"
        )?,
    }
    Ok(())
}

/// One line per flight: waypoints, distance, estimated time; and what the
/// estimate assumes, so nobody reads it as a promise.
pub(super) fn print_flights(plan: &Plan, params: &FlightParams, out: &mut dyn Write) -> Result<()> {
    let Some(first) = plan.flights.first() else {
        return Ok(());
    };
    let total: f64 = plan.flights.iter().map(|f| f.duration_s).sum();
    let limit = match (params.max_flight_time_s, params.usable_s()) {
        (Some(m), Some(u)) => format!(
            "; each at most {} (max flight time {} less the reserve {})",
            duration(u),
            duration(m),
            duration(params.reserve_s)
        ),
        _ => String::new(),
    };
    writeln!(
        out,
        "flights: {} ({} in all{limit})",
        plan.flights.len(),
        duration(total)
    )?;
    for (i, f) in plan.flights.iter().enumerate() {
        let (a, b) = (
            f.waypoints.first().copied().unwrap_or(0),
            f.waypoints.last().copied().unwrap_or(0),
        );
        writeln!(
            out,
            "  flight {}: waypoints {a}-{b}, {:.0} m, about {}",
            i + 1,
            f.distance_m,
            duration(f.duration_s)
        )?;
    }
    let legs = if first.from_home {
        "take-off, landing and the legs to and from home included"
    } else {
        "no home: take-off, landing and the legs to and from home NOT included"
    };
    writeln!(
        out,
        "  (estimate: {} m/s between waypoints, climb {} m/s, descent {} m/s, {} s per photo, \
         no wind; {legs}; [mission] in --config sets it)",
        params.cruise_speed_m_s,
        params.climb_rate_m_s,
        params.descent_rate_m_s,
        params.hover_per_photo_s
    )?;
    Ok(())
}

/// A grid's height, ground resolution, line spacing and trigger distance.
pub(super) fn print_grid_figures(g: &GridFigures, out: &mut dyn Write) -> Result<()> {
    writeln!(
        out,
        "grid: {:.1} m above the lowest point, GSD {:.1} mm/px at nadir, lines {:.1} m apart, \
         a photo every {:.1} m",
        g.height_m,
        g.gsd_m * 1000.0,
        g.line_spacing_m,
        g.trigger_distance_m
    )?;
    Ok(())
}

/// `754.2` -> "12 min 34 s".
fn duration(s: f64) -> String {
    let s = s.round().max(0.0) as u64;
    if s >= 60 {
        format!("{} min {:02} s", s / 60, s % 60)
    } else {
        format!("{s} s")
    }
}
