//! The MAVLink mission protocol, ground side: upload, download, clear.
//!
//! The protocol code runs over the [`Link`] trait (send a message, receive
//! one with a timeout, read a monotonic clock), so it can be driven by a
//! real MAVLink connection ([`crate::link::MavLink`]) or by the virtual-time
//! simulator in [`crate::sim_vehicle::sim`]; the network part stays thin.
//!
//! # Timeouts and retries
//! Defaults follow the MAVLink mission protocol: 1500 ms for a reply to a
//! control message (MISSION_COUNT, MISSION_REQUEST_LIST, MISSION_CLEAR_ALL,
//! the final ACK), 250 ms for an item, 5 retries. Control messages are
//! resent up to `retries` times. Item requests are resent every
//! `item_timeout` until the transfer has made no progress for
//! `timeout * (retries + 1)` (9 s by default) — the same stall bound as a
//! control message, but with enough tries per item that 20 % loss in each
//! direction does not break a long mission (5 retries would fail one item in
//! about 460). A failed operation is started over (`attempts`, default 3);
//! a download keeps the items it already has.

pub mod download;
pub mod home;
pub mod upload;

use std::time::Duration;

use mavlink::dialects::common::{MavMessage, MavMissionResult, MavMissionType, STATUSTEXT_DATA};
use mavlink::MavHeader;

use crate::error::Result;

pub use download::{clear, download, DownloadReport};
pub use upload::{upload, UploadReport};

/// A bidirectional MAVLink message channel with a clock.
pub trait Link {
    /// Sends one message to the vehicle.
    fn send(&mut self, msg: &MavMessage) -> Result<()>;
    /// The next message received within `timeout`, or `None` on timeout.
    fn recv(&mut self, timeout: Duration) -> Result<Option<(MavHeader, MavMessage)>>;
    /// Monotonic time since an arbitrary start (virtual in simulations).
    fn now(&self) -> Duration;
}

/// The vehicle we talk to: system and component id.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Target {
    /// MAVLink system id of the vehicle.
    pub system: u8,
    /// MAVLink component id of the autopilot.
    pub component: u8,
}

impl Target {
    /// `(system, component)`, as message fields want it.
    pub fn ids(self) -> (u8, u8) {
        (self.system, self.component)
    }

    /// True when a message header comes from this vehicle.
    pub fn is_source(self, h: &MavHeader) -> bool {
        h.system_id == u32::from(self.system) && h.component_id == self.component
    }
}

/// Protocol timing.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct ProtocolConfig {
    /// Wait for a reply to a control message (spec default 1500 ms).
    pub timeout: Duration,
    /// Wait for one item before asking again (spec default 250 ms).
    pub item_timeout: Duration,
    /// Resends of a control message (spec default 5).
    pub retries: u32,
    /// Times a failed operation is started over (default 3).
    pub attempts: u32,
}

impl Default for ProtocolConfig {
    fn default() -> Self {
        ProtocolConfig {
            timeout: Duration::from_millis(1500),
            item_timeout: Duration::from_millis(250),
            retries: 5,
            attempts: 3,
        }
    }
}

impl ProtocolConfig {
    /// All durations multiplied by `factor` (tests over loopback use small factors).
    pub fn scaled(self, factor: f64) -> Self {
        ProtocolConfig {
            timeout: self.timeout.mul_f64(factor),
            item_timeout: self.item_timeout.mul_f64(factor),
            ..self
        }
    }

    /// Two requests for the same item closer than this are one request
    /// duplicated by the link, answered once: a quarter of the item
    /// timeout, far below the autopilots' own re-request intervals (PX4
    /// 250 ms, ArduPilot 1 s) and far above a link's reordering (ms).
    pub fn duplicate_window(&self) -> Duration {
        self.item_timeout / 4
    }

    /// Longest time without progress before an attempt fails.
    pub fn stall_limit(&self) -> Duration {
        self.timeout * (self.retries + 1)
    }

    /// Upper bound of one operation on `n` items: every attempt may stall
    /// once per phase (start, each item, end) for the full stall limit.
    /// Operations give up when they pass it, so it is a hard bound.
    pub fn deadline(&self, n: usize) -> Duration {
        let per_attempt = self.stall_limit() * 3 + self.item_timeout * (4 * n as u32 + 4);
        per_attempt * self.attempts.max(1)
    }
}

/// Which transfer a progress event belongs to.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Phase {
    /// Sending items to the vehicle.
    Upload,
    /// Reading items back (download or verify).
    Download,
}

/// Progress of a transfer: `done` of `total` items.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Progress {
    /// Transfer kind.
    pub phase: Phase,
    /// Items transferred so far.
    pub done: usize,
    /// Items in the mission.
    pub total: usize,
    /// 1-based attempt number.
    pub attempt: u32,
}

/// The MAV_MISSION_RESULT name, e.g. `MAV_MISSION_NO_SPACE`.
pub fn result_name(r: MavMissionResult) -> String {
    format!("{r:?}")
}

/// The text of a STATUSTEXT, trimmed (the vehicle's own words).
pub(crate) fn statustext(t: &STATUSTEXT_DATA) -> String {
    String::from_utf8_lossy(&t.text[..])
        .trim_end_matches('\0')
        .trim()
        .to_string()
}

/// Receives until the absolute time `until`; `None` once it has passed.
pub(crate) fn recv_until(
    link: &mut dyn Link,
    until: Duration,
) -> Result<Option<(MavHeader, MavMessage)>> {
    loop {
        let now = link.now();
        if now >= until {
            return Ok(None);
        }
        if let Some(m) = link.recv(until.saturating_sub(now))? {
            return Ok(Some(m));
        }
    }
}

/// True when `mission_type` is the plain mission (other types are fences, rally points).
pub(crate) fn is_mission(t: MavMissionType) -> bool {
    t == MavMissionType::MAV_MISSION_TYPE_MISSION
}

/// Our own header fields (ground station): system 255, component 190 (mission planner).
pub const GCS_SYSTEM_ID: u8 = 255;
/// Component id of the ground station (`MAV_COMP_ID_MISSIONPLANNER`).
pub const GCS_COMPONENT_ID: u8 = 190;
