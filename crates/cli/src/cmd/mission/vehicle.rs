//! `vpctl mission vehicle`: a simulated MAVLink mission server to try
//! `upload` and `download` without a drone.

use std::io::Write;
use std::path::Path;
use std::time::Duration;

use anyhow::Result;
use vp_mission::sim_vehicle::{spawn_udp_vehicle, VehicleConfig};
use vp_mission::Autopilot;

use super::args::{load_key, AutopilotArg};

pub(super) fn vehicle(
    bind: &str,
    autopilot: AutopilotArg,
    seconds: Option<u64>,
    signing_key: Option<&Path>,
    home: Option<crate::cmd::plan::HomeArg>,
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
