//! `vpctl mission ...`: plan -> MAVLink mission; export, upload, download.

use std::io::Write;
use std::path::{Path, PathBuf};

use anyhow::{Context, Result};
use clap::Subcommand;
use vp_mission::{export_flights, write_flights, DjiOptions};
use vp_scene::fsio;
use vp_scene::plan::Plan;

mod args;
mod link;
mod vehicle;

use args::{dji_heights_arg, drone_arg};
pub use args::{AutopilotArg, ExportFormat, LinkArgs, MissionArgs};

/// Mission subcommands.
#[derive(Debug, Subcommand)]
pub enum MissionCommand {
    /// Export a plan as a QGroundControl `.plan` file, `QGC WPL 110` text, a
    /// DJI WPML mission (`.kmz`, DJI Pilot 2 / FlightHub 2), a Litchi CSV or
    /// a KML preview for Google Earth.
    Export {
        /// The plan (JSON written by `vpctl plan`).
        plan: PathBuf,
        /// Output format (default: from the extension of --out: `.plan` qgc,
        /// `.waypoints` or `.txt` wpl, `.kmz` wpml, `.csv` litchi, `.kml` a
        /// preview; qgc on standard output).
        #[arg(long, value_enum)]
        format: Option<ExportFormat>,
        /// The DJI aircraft of a `.kmz` (WPML) mission: m3e, m3t, m3m, m30,
        /// m30t, m300, m350 (both with a Zenmuse H20), m3d, m3td.
        #[arg(long, value_parser = drone_arg)]
        drone: Option<vp_mission::wpml::Drone>,
        /// Heights of a `.kmz`: relative (above the take-off point, the
        /// plan's home) or wgs84 (ellipsoidal, converted from the plan's datum).
        #[arg(long, value_parser = dji_heights_arg, default_value = "relative")]
        dji_heights: vp_mission::wpml::WpmlHeights,
        /// Litchi: write a plan over 99 waypoints as several missions
        /// NAME-1.csv, NAME-2.csv, ... (flown one after another).
        #[arg(long)]
        split: bool,
        /// Output file; prints to standard output when absent. A plan split
        /// into flights (`plan --max-flight-time`) writes one numbered file
        /// per flight: `m.plan` -> `m-1.plan`, `m-2.plan`, ...
        #[arg(long)]
        out: Option<PathBuf>,
        /// Overwrite the output file if it exists.
        #[arg(long)]
        force: bool,
        #[command(flatten)]
        mission: MissionArgs,
    },
    /// Upload a plan to the vehicle with the MAVLink mission protocol, then read
    /// it back and compare item by item ("verified: yes" only when the
    /// read-back equals the upload).
    ///
    /// Exit codes: 0 verified, 2 bad input, 3 no vehicle, 4 timeout, 5
    /// rejected by the vehicle, 6 read-back differs, 7 protocol violation,
    /// 9 signing (the vehicle's messages are not signed with our key, or it
    /// signs and we were given no key), 1 other failures. A failed upload
    /// says what the vehicle holds afterwards: ArduPilot writes items as
    /// they arrive, so vpctl clears a half-written mission (or says it could
    /// not); a vehicle without room says how many photos fit per flight.
    Upload {
        /// The plan (JSON written by `vpctl plan`).
        plan: PathBuf,
        /// Which flight of a plan split into flights to upload (1, 2, ...);
        /// needed when there are several.
        #[arg(long, value_name = "N")]
        flight: Option<usize>,
        /// Upload even when the vehicle's home (HOME_POSITION) lies more
        /// than 5 m across or 2 m in height from the plan's home.
        #[arg(long)]
        accept_home_offset: bool,
        #[command(flatten)]
        link: LinkArgs,
        #[command(flatten)]
        mission: MissionArgs,
    },
    /// Download the vehicle's mission and print its items, one per line
    /// (seq, command, frame, param1-4, x, y, z).
    Download {
        #[command(flatten)]
        link: LinkArgs,
    },
    /// Run a simulated vehicle (a MAVLink mission server) until interrupted,
    /// to try `upload` and `download` without a drone.
    Vehicle {
        /// Address to listen on; give the ground side `--url udpout:ADDR`.
        #[arg(long, default_value = "127.0.0.1:14550")]
        bind: String,
        /// Autopilot conventions to mimic.
        #[arg(long, value_enum, default_value_t = AutopilotArg::Px4)]
        autopilot: AutopilotArg,
        /// Stop after this many seconds (default: run until interrupted).
        #[arg(long)]
        seconds: Option<u64>,
        /// MAVLink 2 signing: sign every message with the key in FILE (64
        /// hexadecimal digits) and ignore messages not signed with it.
        #[arg(long, value_name = "FILE")]
        signing_key: Option<PathBuf>,
        /// The vehicle's home, LAT,LON,ALT (altitude above mean sea level),
        /// reported as HOME_POSITION; without it the vehicle has no fix.
        #[arg(long, value_name = "LAT,LON,ALT", allow_hyphen_values = true, value_parser = crate::cmd::plan::home_arg)]
        home: Option<crate::cmd::plan::HomeArg>,
    },
}

pub fn run(cmd: MissionCommand, out: &mut dyn Write) -> Result<()> {
    match cmd {
        MissionCommand::Export {
            plan,
            format,
            out: path,
            force,
            mission,
            drone,
            dji_heights,
            split,
        } => {
            let format = export_format(path.as_deref(), format)?;
            if let Some(p) = &path {
                fsio::check_output_file(p, force)?;
            }
            let plan_path = plan;
            let plan = load_plan(&plan_path)?;
            let opts = mission.options(&plan)?;
            let dji = DjiOptions {
                drone,
                heights: dji_heights,
                split,
                time_ms: std::time::SystemTime::now()
                    .duration_since(std::time::UNIX_EPOCH)
                    .map_or(0, |d| u64::try_from(d.as_millis()).unwrap_or(0)),
            };
            let files = export_flights(&plan, format, &opts, &dji, path.as_deref())
                .with_context(|| format!("mission of {}", plan_path.display()))?;
            write_flights(&files, force)?;
            for f in &files {
                match &f.path {
                    Some(p) => writeln!(out, "wrote {}", p.display())?,
                    None => out.write_all(&f.bytes)?,
                }
            }
            let flights = plan.flights.len();
            if flights > 1 {
                writeln!(
                    out,
                    "{flights} flights, one mission each: fly them in order, a fresh battery for each"
                )?;
            }
            Ok(())
        }
        MissionCommand::Upload {
            plan,
            flight,
            accept_home_offset,
            link,
            mission,
        } => link::upload(&plan, (flight, accept_home_offset), &link, &mission, out),
        MissionCommand::Download { link } => link::download(&link, out),
        MissionCommand::Vehicle {
            bind,
            autopilot,
            seconds,
            signing_key,
            home,
        } => vehicle::vehicle(&bind, autopilot, seconds, signing_key.as_deref(), home, out),
    }
}

/// The export format: `--format`, else from the extension of `--out`
/// (vp-mission's rule, the same as Python's); the error names the flag.
fn export_format(
    out: Option<&Path>,
    format: Option<ExportFormat>,
) -> Result<vp_mission::ExportFormat> {
    let format = format.map(|f| match f {
        ExportFormat::Qgc => vp_mission::ExportFormat::Qgc,
        ExportFormat::Wpl => vp_mission::ExportFormat::Wpl,
        ExportFormat::Wpml => vp_mission::ExportFormat::Wpml,
        ExportFormat::Litchi => vp_mission::ExportFormat::Litchi,
        ExportFormat::Kml => vp_mission::ExportFormat::Kml,
    });
    vp_mission::ExportFormat::for_output(out, format).map_err(|e| match e {
        vp_mission::MissionError::InvalidInput(m) => {
            crate::cmd::UsageError(format!("--out {m}")).into()
        }
        other => other.into(),
    })
}

/// Reads a plan for a mission, which needs its geodetic origin: without
/// one the error says where it comes from.
fn load_plan(path: &Path) -> Result<Plan> {
    let plan = Plan::load(path)?;
    if plan.origin.is_none() {
        return Err(crate::cmd::UsageError(format!(
            "{}: the plan has no geodetic origin, which a mission needs to place its waypoints \
             on the earth; plan again with --origin LAT,LON,ALT (`vpctl plan grid ... --origin \
             46.03,10.35,400`), or plan on a model aligned by `vpctl colmap align` (its \
             frame.json holds the origin)",
            path.display()
        ))
        .into());
    }
    Ok(plan)
}
