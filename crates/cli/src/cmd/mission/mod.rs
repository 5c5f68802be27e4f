//! `vpctl mission ...`: plan -> MAVLink mission; export, upload, download.

use std::io::Write;
use std::path::{Path, PathBuf};
use std::time::Duration;

use anyhow::{Context, Result};
use clap::{Args, Subcommand, ValueEnum};
use vp_mission::heights::{HeightLimits, UserMissionOptions};
use vp_mission::sim_vehicle::{spawn_udp_vehicle, VehicleConfig};
use vp_mission::{
    build_mission, export_flights, one_flight, write_flights, Autopilot, ConnectOptions,
    DjiOptions, HomePolicy, MissionItem, MissionOptions, Progress, SigningKey,
};
use vp_scene::fsio;
use vp_scene::plan::Plan;

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
        #[arg(long, value_name = "LAT,LON,ALT", allow_hyphen_values = true, value_parser = super::plan::home_arg)]
        home: Option<super::plan::HomeArg>,
    },
}

/// Export formats.
#[derive(Debug, Clone, Copy, ValueEnum)]
pub enum ExportFormat {
    /// QGroundControl `.plan` JSON (SimpleItems only).
    Qgc,
    /// `QGC WPL 110` waypoint text.
    Wpl,
    /// DJI WPML mission (`.kmz`).
    Wpml,
    /// Litchi waypoint CSV.
    Litchi,
    /// KML preview of the path and photos (not a mission).
    Kml,
}

fn drone_arg(s: &str) -> std::result::Result<vp_mission::wpml::Drone, String> {
    s.parse()
        .map_err(|e: vp_mission::MissionError| e.to_string())
}

fn dji_heights_arg(s: &str) -> std::result::Result<vp_mission::wpml::WpmlHeights, String> {
    s.parse()
        .map_err(|e: vp_mission::MissionError| e.to_string())
}

/// Autopilot conventions.
#[derive(Debug, Clone, Copy, ValueEnum)]
pub enum AutopilotArg {
    /// PX4: the mission starts at seq 0.
    Px4,
    /// ArduPilot: seq 0 is home.
    Ardupilot,
}

impl From<AutopilotArg> for Autopilot {
    fn from(a: AutopilotArg) -> Self {
        match a {
            AutopilotArg::Px4 => Autopilot::Px4,
            AutopilotArg::Ardupilot => Autopilot::ArduPilot,
        }
    }
}

/// How the plan becomes mission items.
#[derive(Debug, Args)]
pub struct MissionArgs {
    /// Autopilot conventions: ArduPilot keeps home at seq 0 and ignores a
    /// waypoint's heading, so each photo also gets a CONDITION_YAW (4
    /// items per photo instead of 3).
    #[arg(long, value_enum, default_value_t = AutopilotArg::Px4)]
    autopilot: AutopilotArg,
    /// Seconds to hold at each waypoint before the photo (0 to 60).
    #[arg(long, default_value_t = 2.0, allow_negative_numbers = true)]
    hold: f32,
    /// Mission speed, m/s (0.5 to 20).
    #[arg(long, allow_negative_numbers = true)]
    speed: Option<f32>,
    /// Take off to this height above home first, metres (0: no takeoff
    /// item; else between --min-height and --ceiling).
    #[arg(long, default_value_t = 20.0, allow_negative_numbers = true)]
    takeoff: f32,
    /// Do not end the mission with return-to-launch.
    #[arg(long)]
    no_rtl: bool,
    /// Where the vehicle takes off: LAT,LON,ALT[,DATUM] on the ground
    /// (DATUM egm96, ellipsoid or takeoff; default the plan's). Overrides
    /// the plan's home; a plan without one needs it.
    #[arg(long, value_name = "LAT,LON,ALT[,DATUM]", allow_hyphen_values = true, value_parser = super::plan::home_arg)]
    home: Option<super::plan::HomeArg>,
    /// Highest waypoint allowed, metres above home (most rules: 120).
    #[arg(long, default_value_t = vp_mission::heights::DEFAULT_CEILING_M, allow_negative_numbers = true)]
    ceiling: f64,
    /// Lowest waypoint allowed, metres above home.
    #[arg(long, default_value_t = vp_mission::heights::DEFAULT_MIN_HEIGHT_M, allow_negative_numbers = true)]
    min_height: f64,
}

impl MissionArgs {
    /// The options for `plan` (vp-mission's `UserMissionOptions`, as Python's).
    fn options(&self, plan: &Plan) -> Result<MissionOptions> {
        let user = UserMissionOptions {
            autopilot: self.autopilot.into(),
            hold_s: self.hold,
            speed_m_s: self.speed,
            takeoff_m: self.takeoff,
            return_to_launch: !self.no_rtl,
            home: self.home.map(|h| (h.position, h.datum)),
            limits: HeightLimits {
                min_height_m: self.min_height,
                ceiling_m: self.ceiling,
            },
        };
        Ok(user.resolve(plan)?)
    }
}

/// Where the vehicle is.
#[derive(Debug, Args)]
pub struct LinkArgs {
    /// MAVLink connection: `udpout:HOST:PORT`, `udpin:HOST:PORT`,
    /// `tcpout:HOST:PORT` or `serial:/dev/ttyUSB0:57600`.
    #[arg(long, default_value = "udpout:127.0.0.1:14550")]
    url: String,
    /// Seconds to wait for the vehicle's heartbeat.
    #[arg(long, allow_negative_numbers = true, default_value_t = 5.0)]
    heartbeat_timeout: f64,
    /// MAVLink 2 signing: sign every message with the key in FILE (64
    /// hexadecimal digits; see docs/formats.md) and ignore messages from
    /// the vehicle that are not signed with it (unsigned, another key,
    /// replays).
    #[arg(long, value_name = "FILE")]
    signing_key: Option<PathBuf>,
}

impl LinkArgs {
    fn options(&self) -> Result<ConnectOptions> {
        Ok(ConnectOptions {
            signing: load_key(self.signing_key.as_deref())?,
            ..ConnectOptions::from_user(self.heartbeat_timeout, 1.0)?
        })
    }
}

/// Reads a signing key file; its permission warning goes to standard
/// error (never the key).
fn load_key(path: Option<&Path>) -> Result<Option<SigningKey>> {
    let Some(path) = path else { return Ok(None) };
    let loaded = SigningKey::load(path)?;
    if let Some(w) = loaded.warning {
        eprintln!("{w}");
    }
    Ok(Some(loaded.key))
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
        } => upload(&plan, (flight, accept_home_offset), &link, &mission, out),
        MissionCommand::Download { link } => download(&link, out),
        MissionCommand::Vehicle {
            bind,
            autopilot,
            seconds,
            signing_key,
            home,
        } => vehicle(&bind, autopilot, seconds, signing_key.as_deref(), home, out),
    }
}

fn upload(
    plan_path: &Path,
    (flight, accept_home_offset): (Option<usize>, bool),
    link: &LinkArgs,
    mission: &MissionArgs,
    out: &mut dyn Write,
) -> Result<()> {
    let plan = one_flight(&load_plan(plan_path)?, flight)
        .with_context(|| format!("plan {}", plan_path.display()))?;
    let opts = ConnectOptions {
        home_check: Some(HomePolicy {
            datum: plan.vertical_datum,
            accept_offset: accept_home_offset,
        }),
        ..link.options()?
    };
    let m = build_mission(&plan, &mission.options(&plan)?)
        .with_context(|| format!("mission of {}", plan_path.display()))?;
    writeln!(
        out,
        "mission: {} items ({} photos) for {:?}",
        m.items.len(),
        m.photos,
        m.autopilot
    )?;
    let bar = super::Progress::new();
    let (report, info) = vp_mission::upload(&link.url, &m, &opts, &mut |p| progress(&bar, &p))?;
    bar.finish();
    writeln!(
        out,
        "vehicle: system {} component {} ({:?})",
        info.target.system, info.target.component, info.autopilot
    )?;
    if let Some(home) = &report.home {
        writeln!(out, "home: {home}")?;
    }
    writeln!(
        out,
        "uploaded {} items in {:.2} s ({} resends); verified: {}",
        m.items.len(),
        report.upload.elapsed.as_secs_f64(),
        report.upload.resends,
        if report.verified {
            "yes, item by item"
        } else {
            "no"
        }
    )?;
    Ok(())
}

fn download(link: &LinkArgs, out: &mut dyn Write) -> Result<()> {
    let bar = super::Progress::new();
    let (items, report, info) =
        vp_mission::download(&link.url, &link.options()?, &mut |p| progress(&bar, &p))?;
    bar.finish();
    writeln!(
        out,
        "vehicle: system {} component {}; {} items in {:.2} s",
        info.target.system,
        info.target.component,
        items.len(),
        report.elapsed.as_secs_f64()
    )?;
    for (seq, item) in items.iter().enumerate() {
        print_item(seq, item, out)?;
    }
    Ok(())
}

fn vehicle(
    bind: &str,
    autopilot: AutopilotArg,
    seconds: Option<u64>,
    signing_key: Option<&Path>,
    home: Option<super::plan::HomeArg>,
    out: &mut dyn Write,
) -> Result<()> {
    let d = VehicleConfig::default();
    let cfg = VehicleConfig {
        autopilot: autopilot.into(),
        signing: load_key(signing_key)?,
        home: home.map_or(d.home, |h| h.position),
        reports_home: home.is_some(),
        ..d
    };
    let signing = cfg.signing.is_some();
    let vehicle = spawn_udp_vehicle(bind, cfg)?;
    writeln!(
        out,
        "simulated {:?} vehicle listening on {} (connect with --url udpout:{}){}",
        Autopilot::from(autopilot),
        vehicle.addr(),
        vehicle.addr(),
        if signing {
            "; MAVLink 2 signing on"
        } else {
            ""
        }
    )?;
    out.flush()?;
    let deadline = seconds.map(|s| std::time::Instant::now() + Duration::from_secs(s));
    let mut last = (0, 0);
    let mut last_ignored = vp_mission::signing::IgnoredCounts::default();
    while deadline.is_none_or(|d| std::time::Instant::now() < d) {
        std::thread::sleep(Duration::from_millis(100));
        let ignored = vehicle.ignored();
        if ignored != last_ignored {
            writeln!(out, "ignored messages: {ignored}")?;
            out.flush()?;
            last_ignored = ignored;
        }
        let counts = vehicle.upload_counts();
        if counts != last {
            writeln!(
                out,
                "uploads completed: {}, abandoned: {}; stored items: {}",
                counts.0,
                counts.1,
                vehicle.mission().len()
            )?;
            out.flush()?;
            last = counts;
        }
    }
    Ok(())
}

/// One progress report: redrawn in place on a terminal, a line otherwise.
fn progress(bar: &super::Progress, p: &Progress) {
    let stage = if p.attempt > 1 {
        format!("{:?} items, attempt {}", p.phase, p.attempt)
    } else {
        format!("{:?} items", p.phase)
    };
    bar.message(&format!("{stage} ({}/{})", p.done, p.total));
}

fn print_item(seq: usize, item: &MissionItem, out: &mut dyn Write) -> Result<()> {
    let p = item.params;
    writeln!(
        out,
        "{seq:4} {:?} {:?} [{}, {}, {}, {}] x={} y={} z={}",
        item.command, item.frame, p[0], p[1], p[2], p[3], item.x, item.y, item.z
    )?;
    Ok(())
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
        vp_mission::MissionError::InvalidInput(m) => super::UsageError(format!("--out {m}")).into(),
        other => other.into(),
    })
}

/// Reads a plan for a mission, which needs its geodetic origin: without
/// one the error says where it comes from.
fn load_plan(path: &Path) -> Result<Plan> {
    let plan = Plan::load(path)?;
    if plan.origin.is_none() {
        return Err(super::UsageError(format!(
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
