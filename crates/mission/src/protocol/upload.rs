//! Mission upload, ground side: MISSION_COUNT, then serve the vehicle's
//! MISSION_REQUEST_INT / MISSION_REQUEST in any order and any number of
//! times, until MISSION_ACK.

use std::time::Duration;

use mavlink::dialects::common::{
    MavMessage, MavMissionResult, MavMissionType, MISSION_ACK_DATA, MISSION_COUNT_DATA,
};

use super::{
    is_mission, recv_until, result_name, statustext, Link, Phase, Progress, ProtocolConfig, Target,
};
use crate::error::{MissionError, Result};
use crate::items::MissionItem;

const OP: &str = "mission upload";

/// What an upload did.
#[derive(Debug, Clone, PartialEq, Default)]
pub struct UploadReport {
    /// Items in the mission.
    pub items: usize,
    /// Time from the first MISSION_COUNT to the end.
    pub elapsed: Duration,
    /// Attempts used (1 when nothing went wrong badly).
    pub attempts: u32,
    /// Control messages sent again after a timeout (MISSION_COUNT, last item).
    pub resends: u32,
    /// Item messages sent, repeats included.
    pub items_sent: u32,
    /// Requests answered again (the vehicle asked twice for an item).
    pub repeated_requests: u32,
    /// Requests not answered because the same item went out less than
    /// [`ProtocolConfig::duplicate_window`] before: copies of one request
    /// made by the link, not the vehicle asking again.
    pub duplicate_requests: u32,
    /// Messages ignored: other vehicles, stale or duplicate answers.
    pub ignored: u32,
    /// False when every item was served but the final MISSION_ACK never
    /// arrived; only a read-back can then tell whether the vehicle kept it.
    pub ack_received: bool,
}

/// Uploads `items` (seq = index) to the vehicle.
///
/// Returns an error naming the MAV_MISSION_RESULT when the vehicle rejects
/// the mission; transient failures (timeouts, MAV_MISSION_ERROR,
/// MAV_MISSION_OPERATION_CANCELLED) start the upload over, up to
/// `cfg.attempts` times within [`ProtocolConfig::deadline`].
pub fn upload(
    link: &mut dyn Link,
    target: Target,
    items: &[MissionItem],
    cfg: &ProtocolConfig,
    progress: &mut dyn FnMut(Progress),
) -> Result<UploadReport> {
    let n = items.len();
    let count = u16::try_from(n).map_err(|_| {
        MissionError::InvalidInput(format!("{n} items exceed the MAVLink limit of 65535"))
    })?;
    let start = link.now();
    let deadline = start + cfg.deadline(n);
    let mut report = UploadReport {
        items: n,
        ..UploadReport::default()
    };
    let mut attempt = 0;
    loop {
        attempt += 1;
        report.attempts = attempt;
        let mut run = Attempt {
            link: &mut *link,
            target,
            items,
            count,
            cfg,
            deadline,
            start,
            report: &mut report,
            number: attempt,
            count_sends: 0,
            highest: None,
            served: vec![false; n],
            last_sent: vec![None; n],
            n_served: 0,
            end_waits: 0,
            last_progress: Duration::ZERO,
            said: Vec::new(),
        };
        let result = run.run(progress);
        report.elapsed = link.now().saturating_sub(start);
        match result {
            Ok(()) => return Ok(report),
            Err(e) if is_transient(&e) && attempt < cfg.attempts && link.now() < deadline => {
                // Tell the vehicle to drop the half transfer before starting over.
                send_ack(
                    link,
                    target,
                    MavMissionResult::MAV_MISSION_OPERATION_CANCELLED,
                )?;
            }
            Err(e) => return Err(e),
        }
    }
}

fn is_transient(e: &MissionError) -> bool {
    match e {
        MissionError::Timeout { .. } => true,
        MissionError::Rejected { result, .. } => {
            result == &result_name(MavMissionResult::MAV_MISSION_ERROR)
                || result == &result_name(MavMissionResult::MAV_MISSION_OPERATION_CANCELLED)
                || result == &result_name(MavMissionResult::MAV_MISSION_INVALID_SEQUENCE)
        }
        _ => false,
    }
}

pub(crate) fn send_ack(link: &mut dyn Link, target: Target, r: MavMissionResult) -> Result<()> {
    link.send(&MavMessage::MISSION_ACK(MISSION_ACK_DATA {
        target_system: target.system,
        target_component: target.component,
        mavtype: r,
        mission_type: MavMissionType::MAV_MISSION_TYPE_MISSION,
        opaque_id: 0,
    }))
}

struct Attempt<'a> {
    link: &'a mut dyn Link,
    target: Target,
    items: &'a [MissionItem],
    count: u16,
    cfg: &'a ProtocolConfig,
    deadline: Duration,
    start: Duration,
    report: &'a mut UploadReport,
    number: u32,
    // Progress of this attempt.
    count_sends: u32,
    highest: Option<u16>,
    served: Vec<bool>,
    /// When each item last went out: a request for it within the
    /// duplicate window is a copy made by the link.
    last_sent: Vec<Option<Duration>>,
    n_served: usize,
    end_waits: u32,
    last_progress: Duration,
    /// The vehicle's STATUSTEXT messages during this attempt.
    said: Vec<String>,
}

/// What a timeout led to.
enum AfterTimeout {
    /// Keep waiting.
    Continue,
    /// Everything was served and the ACK never came: done, unconfirmed.
    Unconfirmed,
}

impl Attempt<'_> {
    fn send_count(&mut self) -> Result<()> {
        self.link
            .send(&MavMessage::MISSION_COUNT(MISSION_COUNT_DATA {
                count: self.count,
                target_system: self.target.system,
                target_component: self.target.component,
                mission_type: MavMissionType::MAV_MISSION_TYPE_MISSION,
                opaque_id: 0,
            }))
    }

    /// Sends item `seq` as MISSION_ITEM_INT, also in answer to the legacy
    /// MISSION_REQUEST, as the current spec asks.
    fn send_item(&mut self, seq: u16) -> Result<()> {
        let item = &self.items[usize::from(seq)];
        let msg = MavMessage::MISSION_ITEM_INT(item.to_mavlink(seq, self.target.ids()));
        self.report.items_sent += 1;
        self.link.send(&msg)
    }

    fn timeout(&self, stage: String, attempts: u32) -> MissionError {
        MissionError::Timeout {
            operation: OP,
            stage,
            attempts,
            elapsed: self.link.now().saturating_sub(self.start),
        }
    }

    /// After a rejection, the vehicle's own words: ArduPilot sends its
    /// STATUSTEXT ("Only 650 items are supported") just after the ACK.
    /// Waits one item timeout for them.
    fn linger_for_words(&mut self) -> Vec<String> {
        let until = self.link.now() + self.cfg.item_timeout;
        while let Ok(Some((h, msg))) = recv_until(&mut *self.link, until) {
            if let MavMessage::STATUSTEXT(t) = msg {
                if self.target.is_source(&h) {
                    self.said.push(statustext(&t));
                }
            }
        }
        std::mem::take(&mut self.said)
    }

    fn all_served(&self) -> bool {
        self.n_served == self.served.len()
    }

    fn on_timeout(&mut self) -> Result<AfterTimeout> {
        let n = self.served.len();
        if self.highest.is_none() {
            if self.count_sends > self.cfg.retries {
                return Err(self.timeout(
                    format!("waiting for the vehicle to answer MISSION_COUNT ({n} items)"),
                    self.count_sends,
                ));
            }
            self.send_count()?;
            self.count_sends += 1;
            self.report.resends += 1;
        } else if self.all_served() {
            self.end_waits += 1;
            if self.end_waits > self.cfg.retries {
                // Every item went out but no ACK came back: report it and
                // let the caller verify by reading back.
                return Ok(AfterTimeout::Unconfirmed);
            }
            // Resending the last item makes a vehicle that lost it ask
            // again, and one that already finished repeat its ACK.
            self.send_item(self.count - 1)?;
            self.report.resends += 1;
        } else if self.link.now().saturating_sub(self.last_progress) >= self.cfg.stall_limit() {
            return Err(self.timeout(
                format!(
                    "the vehicle stopped requesting items ({} of {n} served)",
                    self.n_served
                ),
                self.number,
            ));
        }
        Ok(AfterTimeout::Continue)
    }

    fn on_request(&mut self, seq: u16, progress: &mut dyn FnMut(Progress)) -> Result<()> {
        let idx = usize::from(seq);
        let now = self.link.now();
        // A link that duplicates every packet delivers each request twice;
        // answering both sends the item twice, and a vehicle that asks
        // again on a duplicate item doubles the next request: the exchange
        // grows exponentially. Autopilots time their own re-requests
        // (250 ms on PX4, 1 s on ArduPilot), so a request for an item sent
        // moments ago is a copy: answer once per window.
        if self.last_sent[idx].is_some_and(|t| now.saturating_sub(t) < self.cfg.duplicate_window())
        {
            self.report.duplicate_requests += 1;
            return Ok(());
        }
        self.last_sent[idx] = Some(now);
        self.send_item(seq)?;
        if self.served[idx] {
            self.report.repeated_requests += 1;
        } else {
            self.served[idx] = true;
            self.n_served += 1;
            self.last_progress = self.link.now();
            progress(Progress {
                phase: Phase::Upload,
                done: self.n_served,
                total: self.served.len(),
                attempt: self.number,
            });
        }
        if self.highest.is_none_or(|s| seq > s) {
            self.highest = Some(seq);
            self.end_waits = 0;
        }
        Ok(())
    }

    #[allow(deprecated)] // MISSION_REQUEST: older vehicles still ask with it.
    fn run(&mut self, progress: &mut dyn FnMut(Progress)) -> Result<()> {
        self.send_count()?;
        self.count_sends = 1;
        self.last_progress = self.link.now();
        let mut wait_until = self.link.now() + self.cfg.timeout;
        loop {
            let now = self.link.now();
            if now >= self.deadline {
                return Err(self.timeout("before the overall deadline".into(), self.number));
            }
            if now >= wait_until {
                if let AfterTimeout::Unconfirmed = self.on_timeout()? {
                    self.report.ack_received = false;
                    return Ok(());
                }
                wait_until = self.link.now() + self.cfg.timeout;
                continue;
            }
            let wait = wait_until.min(self.deadline).saturating_sub(now);
            let Some((header, msg)) = self.link.recv(wait)? else {
                continue;
            };
            if !self.target.is_source(&header) {
                self.report.ignored += 1;
                continue;
            }
            let seq = match &msg {
                MavMessage::MISSION_REQUEST_INT(r) if is_mission(r.mission_type) => r.seq,
                MavMessage::MISSION_REQUEST(r) if is_mission(r.mission_type) => r.seq,
                MavMessage::MISSION_ACK(a)
                    if is_mission(a.mission_type)
                        && a.mavtype == MavMissionResult::MAV_MISSION_INVALID_SEQUENCE
                        && self.highest.is_some() =>
                {
                    // ArduPilot answers an item it did not ask for (a
                    // duplicate, a stale copy) with INVALID_SEQUENCE and
                    // keeps the transfer going: not the end of the upload.
                    self.report.ignored += 1;
                    continue;
                }
                MavMessage::MISSION_ACK(a) if is_mission(a.mission_type) => {
                    if a.mavtype != MavMissionResult::MAV_MISSION_ACCEPTED {
                        let said = self.linger_for_words();
                        return Err(MissionError::Rejected {
                            operation: OP,
                            result: result_name(a.mavtype),
                            seq: self.highest,
                            said,
                        });
                    }
                    if self.all_served() {
                        self.report.ack_received = true;
                        return Ok(());
                    }
                    // An ACK from an earlier transfer, delayed.
                    self.report.ignored += 1;
                    continue;
                }
                MavMessage::STATUSTEXT(t) => {
                    self.said.push(statustext(t));
                    continue;
                }
                _ => {
                    self.report.ignored += 1;
                    continue;
                }
            };
            if seq >= self.count {
                // Out of range: a stale request from an earlier, longer transfer.
                self.report.ignored += 1;
                continue;
            }
            self.on_request(seq, progress)?;
            // A request is the vehicle's sign of life: restart the wait.
            wait_until = self.link.now() + self.cfg.timeout;
        }
    }
}
