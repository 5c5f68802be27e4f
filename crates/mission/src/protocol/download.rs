//! Mission download (MISSION_REQUEST_LIST, MISSION_COUNT, then one
//! MISSION_REQUEST_INT per item, MISSION_ACK) and clear (MISSION_CLEAR_ALL).

use std::time::Duration;

use mavlink::dialects::common::{
    MavMessage, MavMissionResult, MavMissionType, MISSION_CLEAR_ALL_DATA, MISSION_REQUEST_INT_DATA,
    MISSION_REQUEST_LIST_DATA,
};

use super::upload::send_ack;
use super::{is_mission, recv_until, result_name, Link, Phase, Progress, ProtocolConfig, Target};
use crate::error::{MissionError, Result};
use crate::items::MissionItem;

const OP: &str = "mission download";

/// What a download did.
#[derive(Debug, Clone, PartialEq, Default)]
pub struct DownloadReport {
    /// Items read.
    pub items: usize,
    /// Time from the first MISSION_REQUEST_LIST to the end.
    pub elapsed: Duration,
    /// Attempts used.
    pub attempts: u32,
    /// Requests sent again after a timeout.
    pub resends: u32,
    /// Messages ignored: other vehicles, duplicates, items not asked for.
    pub ignored: u32,
}

/// Reads the vehicle's mission.
pub fn download(
    link: &mut dyn Link,
    target: Target,
    cfg: &ProtocolConfig,
    progress: &mut dyn FnMut(Progress),
) -> Result<(Vec<MissionItem>, DownloadReport)> {
    let start = link.now();
    // The count is not known yet: bound the first attempt by a generous
    // item count and recompute once the vehicle has told it.
    let mut deadline = start + cfg.deadline(usize::from(u16::MAX));
    let mut report = DownloadReport::default();
    let mut got: Vec<Option<MissionItem>> = Vec::new();
    let mut attempt = 0;
    loop {
        attempt += 1;
        report.attempts = attempt;
        let result = download_attempt(
            link,
            target,
            cfg,
            start,
            &mut deadline,
            attempt,
            &mut got,
            &mut report,
            progress,
        );
        report.elapsed = link.now().saturating_sub(start);
        match result {
            Ok(()) => {
                let items: Vec<MissionItem> = got.into_iter().flatten().collect();
                report.items = items.len();
                return Ok((items, report));
            }
            Err(e @ MissionError::Timeout { .. })
                if attempt < cfg.attempts && link.now() < deadline =>
            {
                drop(e);
            }
            Err(e) => return Err(e),
        }
    }
}

#[allow(clippy::too_many_arguments)] // One attempt's whole state, passed once.
#[allow(deprecated)] // MISSION_ITEM: older vehicles answer with it.
fn download_attempt(
    link: &mut dyn Link,
    target: Target,
    cfg: &ProtocolConfig,
    start: Duration,
    deadline: &mut Duration,
    attempt: u32,
    got: &mut Vec<Option<MissionItem>>,
    report: &mut DownloadReport,
    progress: &mut dyn FnMut(Progress),
) -> Result<()> {
    let timeout = |link: &dyn Link, stage: String, attempts: u32| MissionError::Timeout {
        operation: OP,
        stage,
        attempts,
        elapsed: link.now().saturating_sub(start),
    };
    let count = request_count(link, target, cfg, deadline, attempt, report, &timeout)?;
    if got.len() != count {
        // First attempt, or the mission changed under us: start afresh.
        *got = vec![None; count];
    }
    *deadline = (start + cfg.deadline(count)).min(*deadline);
    let total = count;
    let mut have = got.iter().filter(|g| g.is_some()).count();
    // Phase 2: the items, lowest missing first.
    let mut last_progress = link.now();
    while let Some(seq) = got.iter().position(Option::is_none) {
        if link.now().saturating_sub(last_progress) >= cfg.stall_limit() {
            return Err(timeout(
                link,
                format!("waiting for item {seq} of {count}"),
                attempt,
            ));
        }
        if link.now() >= *deadline {
            return Err(timeout(link, "before the overall deadline".into(), attempt));
        }
        link.send(&MavMessage::MISSION_REQUEST_INT(MISSION_REQUEST_INT_DATA {
            seq: seq as u16,
            target_system: target.system,
            target_component: target.component,
            mission_type: MavMissionType::MAV_MISSION_TYPE_MISSION,
        }))?;
        let until = (link.now() + cfg.item_timeout).min(*deadline);
        let mut answered = false;
        while let Some((h, msg)) = recv_until(link, until)? {
            if !target.is_source(&h) {
                report.ignored += 1;
                continue;
            }
            let item = match &msg {
                MavMessage::MISSION_ITEM_INT(m) if is_mission(m.mission_type) => {
                    Some((m.seq, MissionItem::from_mavlink(m)))
                }
                MavMessage::MISSION_ITEM(m) if is_mission(m.mission_type) => {
                    Some((m.seq, MissionItem::from_mavlink_float(m)))
                }
                MavMessage::MISSION_ACK(a)
                    if is_mission(a.mission_type)
                        && a.mavtype != MavMissionResult::MAV_MISSION_ACCEPTED =>
                {
                    return Err(MissionError::Rejected {
                        operation: OP,
                        result: result_name(a.mavtype),
                        seq: Some(seq as u16),
                        said: Vec::new(),
                    });
                }
                _ => None,
            };
            match item {
                Some((s, it)) if usize::from(s) < count && got[usize::from(s)].is_none() => {
                    got[usize::from(s)] = Some(it);
                    have += 1;
                    last_progress = link.now();
                    progress(Progress {
                        phase: Phase::Download,
                        done: have,
                        total,
                        attempt,
                    });
                    if usize::from(s) == seq {
                        answered = true;
                        break;
                    }
                }
                _ => report.ignored += 1,
            }
        }
        if !answered && got[seq].is_none() {
            report.resends += 1;
        }
    }
    // Phase 3: tell the vehicle we are done (it does not answer).
    send_ack(link, target, MavMissionResult::MAV_MISSION_ACCEPTED)?;
    Ok(())
}

/// Phase 1 of a download: MISSION_REQUEST_LIST until MISSION_COUNT.
fn request_count(
    link: &mut dyn Link,
    target: Target,
    cfg: &ProtocolConfig,
    deadline: &Duration,
    attempt: u32,
    report: &mut DownloadReport,
    timeout: &dyn Fn(&dyn Link, String, u32) -> MissionError,
) -> Result<usize> {
    let request_list = MavMessage::MISSION_REQUEST_LIST(MISSION_REQUEST_LIST_DATA {
        target_system: target.system,
        target_component: target.component,
        mission_type: MavMissionType::MAV_MISSION_TYPE_MISSION,
    });
    let mut sends = 0u32;
    Ok('count: loop {
        if sends > cfg.retries {
            return Err(timeout(link, "waiting for MISSION_COUNT".into(), sends));
        }
        link.send(&request_list)?;
        if sends > 0 {
            report.resends += 1;
        }
        sends += 1;
        let until = (link.now() + cfg.timeout).min(*deadline);
        while let Some((h, msg)) = recv_until(link, until)? {
            match msg {
                MavMessage::MISSION_COUNT(c)
                    if target.is_source(&h) && is_mission(c.mission_type) =>
                {
                    break 'count usize::from(c.count);
                }
                MavMessage::MISSION_ACK(a)
                    if target.is_source(&h)
                        && is_mission(a.mission_type)
                        && a.mavtype != MavMissionResult::MAV_MISSION_ACCEPTED =>
                {
                    return Err(MissionError::Rejected {
                        operation: OP,
                        result: result_name(a.mavtype),
                        seq: None,
                        said: Vec::new(),
                    });
                }
                _ => report.ignored += 1,
            }
        }
        if link.now() >= *deadline {
            return Err(timeout(link, "before the overall deadline".into(), attempt));
        }
    })
}

/// Deletes the vehicle's mission (MISSION_CLEAR_ALL, answered by MISSION_ACK).
pub fn clear(link: &mut dyn Link, target: Target, cfg: &ProtocolConfig) -> Result<Duration> {
    const CLEAR: &str = "mission clear";
    let start = link.now();
    let msg = MavMessage::MISSION_CLEAR_ALL(MISSION_CLEAR_ALL_DATA {
        target_system: target.system,
        target_component: target.component,
        mission_type: MavMissionType::MAV_MISSION_TYPE_MISSION,
    });
    for _ in 0..=cfg.retries {
        link.send(&msg)?;
        let until = link.now() + cfg.timeout;
        while let Some((h, m)) = recv_until(link, until)? {
            if let MavMessage::MISSION_ACK(a) = m {
                if target.is_source(&h) && is_mission(a.mission_type) {
                    if a.mavtype == MavMissionResult::MAV_MISSION_ACCEPTED {
                        return Ok(link.now().saturating_sub(start));
                    }
                    if !matches!(
                        a.mavtype,
                        MavMissionResult::MAV_MISSION_ERROR
                            | MavMissionResult::MAV_MISSION_DENIED
                            | MavMissionResult::MAV_MISSION_UNSUPPORTED
                    ) {
                        // An answer of the transfer before (a rejected
                        // item, a cancelled upload), still on its way.
                        continue;
                    }
                    return Err(MissionError::Rejected {
                        operation: CLEAR,
                        result: result_name(a.mavtype),
                        seq: None,
                        said: Vec::new(),
                    });
                }
            }
        }
    }
    Err(MissionError::Timeout {
        operation: CLEAR,
        stage: "waiting for MISSION_ACK to MISSION_CLEAR_ALL".into(),
        attempts: cfg.retries + 1,
        elapsed: link.now().saturating_sub(start),
    })
}
