//! `vpctl mission upload` and `download`: the MAVLink mission protocol
//! with a vehicle.

use std::io::Write;
use std::path::Path;

use anyhow::{Context, Result};
use vp_mission::{build_mission, one_flight, ConnectOptions, HomePolicy, MissionItem, Progress};

use super::args::{LinkArgs, MissionArgs};
use super::load_plan;

pub(super) fn upload(
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
    let bar = crate::cmd::Progress::new();
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

pub(super) fn download(link: &LinkArgs, out: &mut dyn Write) -> Result<()> {
    let bar = crate::cmd::Progress::new();
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

/// One progress report: redrawn in place on a terminal, a line otherwise.
fn progress(bar: &crate::cmd::Progress, p: &Progress) {
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
