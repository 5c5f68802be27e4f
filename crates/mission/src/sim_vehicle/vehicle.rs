//! A vehicle-side mission server: the autopilot's half of the mission protocol.
//! One state machine in one file (longer than most): its states and
//! transitions are easier to check side by side.
//!
//! [`MissionServer`] is a pure state machine (messages and time in, replies
//! out), so the virtual-time simulator and a UDP thread
//! ([`spawn_udp_vehicle`]) share it. It behaves like PX4's mission manager:
//! it asks for items one by one, asks again every `item_timeout`, gives up
//! after `protocol_timeout` without progress, ignores an item it did not
//! ask for (a duplicate: asking again at once would let a duplicating link
//! double the traffic at every item), answers a repeated last item with its
//! ACK again, serves downloads statelessly, and replaces its mission only
//! when an upload completes. In ArduPilot mode it has ArduPilot's habits
//! ([`super::ardupilot`]): seq 0 is its own home, items are checked and
//! stored as ArduPilot stores them and written as they arrive, a full
//! vehicle says so in a STATUSTEXT.
//!
//! With a signing key the UDP vehicle signs what it sends and ignores what
//! is not signed with the key, as an autopilot with signing enabled does
//! (ArduPilot also accepts unsigned on USB, which we do not mimic).

use std::net::{SocketAddr, UdpSocket};
use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::{Arc, Mutex, PoisonError};
use std::thread::JoinHandle;
use std::time::{Duration, Instant};

#[allow(deprecated)] // MISSION_REQUEST_DATA: see `request`.
use mavlink::dialects::common::{
    MavAutopilot, MavCmd, MavMessage, MavMissionResult, MavMissionType, MavModeFlag, MavResult,
    MavSeverity, MavState, MavType, COMMAND_ACK_DATA, HEARTBEAT_DATA, MISSION_ACK_DATA,
    MISSION_COUNT_DATA, MISSION_REQUEST_DATA, MISSION_REQUEST_INT_DATA, STATUSTEXT_DATA,
};
use mavlink::{Connectable, MavHeader, UdpConfig, UdpMode};
use vp_scene::plan::GeodeticOrigin;

use super::ardupilot;
use crate::error::{MissionError, Result};
use crate::geodesy::deg_to_e7;
use crate::items::{Autopilot, MissionItem};
use crate::protocol::home::{home_position, HOME_POSITION_ID};
use crate::signing::{IgnoredCounts, SignedLink, SigningKey, LINK_ID};

/// How the simulated vehicle behaves.
#[derive(Debug, Clone, PartialEq)]
pub struct VehicleConfig {
    /// Our system id.
    pub system: u8,
    /// Our component id (1 = autopilot).
    pub component: u8,
    /// ArduPilot mode rewrites seq 0 with `home` after each upload.
    pub autopilot: Autopilot,
    /// Home position (ArduPilot mode; HOME_POSITION when `reports_home`),
    /// altitude above mean sea level.
    pub home: GeodeticOrigin,
    /// Answer a request for HOME_POSITION with `home`; false: refuse it,
    /// as a vehicle without a GNSS fix does.
    pub reports_home: bool,
    /// Most items the vehicle stores; more gets MAV_MISSION_NO_SPACE.
    pub capacity: usize,
    /// Answer every MISSION_COUNT with this result instead of accepting.
    pub reject_with: Option<MavMissionResult>,
    /// Ask again for an item after this long.
    pub item_timeout: Duration,
    /// Abandon an upload after this long without progress.
    pub protocol_timeout: Duration,
    /// Ask with the legacy MISSION_REQUEST instead of MISSION_REQUEST_INT.
    pub legacy_requests: bool,
    /// Send a HEARTBEAT this often (`None`: never).
    pub heartbeat: Option<Duration>,
    /// MAVLink 2 signing key of the UDP vehicle ([`spawn_udp_vehicle`]):
    /// sign everything, ignore what is not signed with it. (The
    /// virtual-time [`super::SimLink`] carries decoded messages and has no
    /// signatures.)
    pub signing: Option<SigningKey>,
}

impl Default for VehicleConfig {
    fn default() -> Self {
        VehicleConfig {
            system: 1,
            component: 1,
            autopilot: Autopilot::Px4,
            home: GeodeticOrigin {
                lat_deg: 47.397_742,
                lon_deg: 8.545_594,
                alt_m: 488.0,
            },
            reports_home: false,
            capacity: 2000,
            reject_with: None,
            item_timeout: Duration::from_millis(250),
            protocol_timeout: Duration::from_secs(5),
            legacy_requests: false,
            heartbeat: Some(Duration::from_secs(1)),
            signing: None,
        }
    }
}

#[derive(Debug)]
enum State {
    Idle,
    Receiving {
        count: u16,
        items: Vec<MissionItem>,
        last_request: Duration,
        last_progress: Duration,
    },
}

/// The vehicle's mission store and protocol state.
#[derive(Debug)]
pub struct MissionServer {
    cfg: VehicleConfig,
    mission: Vec<MissionItem>,
    state: State,
    gcs: (u8, u8),
    completed: Option<u16>,
    next_heartbeat: Duration,
    /// Uploads completed (ACK ACCEPTED sent).
    pub uploads: u32,
    /// Uploads abandoned on timeout.
    pub abandoned: u32,
}

impl MissionServer {
    /// A vehicle with an empty mission.
    pub fn new(cfg: VehicleConfig) -> Self {
        MissionServer {
            cfg,
            mission: Vec::new(),
            state: State::Idle,
            gcs: (0, 0),
            completed: None,
            next_heartbeat: Duration::ZERO,
            uploads: 0,
            abandoned: 0,
        }
    }

    /// The stored mission.
    pub fn mission(&self) -> &[MissionItem] {
        &self.mission
    }

    /// The header of our messages.
    pub fn header(&self) -> MavHeader {
        MavHeader {
            system_id: u32::from(self.cfg.system),
            component_id: self.cfg.component,
            sequence: 0,
        }
    }

    /// Next time [`MissionServer::poll`] has something to do.
    pub fn next_wakeup(&self) -> Option<Duration> {
        let timer = match &self.state {
            State::Idle => None,
            State::Receiving {
                last_request,
                last_progress,
                ..
            } => Some(
                (*last_request + self.cfg.item_timeout)
                    .min(*last_progress + self.cfg.protocol_timeout),
            ),
        };
        let hb = self.cfg.heartbeat.map(|_| self.next_heartbeat);
        match (timer, hb) {
            (Some(a), Some(b)) => Some(a.min(b)),
            (a, b) => a.or(b),
        }
    }

    /// Timers: heartbeats, repeated requests, giving up.
    pub fn poll(&mut self, now: Duration) -> Vec<MavMessage> {
        let mut out = Vec::new();
        if let Some(every) = self.cfg.heartbeat {
            if now >= self.next_heartbeat {
                out.push(self.heartbeat());
                self.next_heartbeat = now + every;
            }
        }
        let mut abandon = false;
        if let State::Receiving {
            items,
            last_request,
            last_progress,
            ..
        } = &mut self.state
        {
            if now >= *last_progress + self.cfg.protocol_timeout {
                abandon = true;
            } else if now >= *last_request + self.cfg.item_timeout {
                *last_request = now;
                let seq = items.len() as u16;
                out.push(self.request(seq));
            }
        }
        if abandon {
            self.state = State::Idle;
            self.abandoned += 1;
            out.push(self.ack(MavMissionResult::MAV_MISSION_OPERATION_CANCELLED));
        }
        out
    }

    /// Handles one message from the ground station.
    #[allow(deprecated)] // MISSION_ITEM and MISSION_REQUEST: legacy peers send them.
    pub fn handle(
        &mut self,
        now: Duration,
        header: &MavHeader,
        msg: &MavMessage,
    ) -> Vec<MavMessage> {
        let for_us = |t: u8| t == 0 || t == self.cfg.system;
        let mission_type = |t: MavMissionType| t == MavMissionType::MAV_MISSION_TYPE_MISSION;
        match msg {
            MavMessage::MISSION_COUNT(c)
                if for_us(c.target_system) && mission_type(c.mission_type) =>
            {
                self.gcs = (header.system_id as u8, header.component_id);
                self.on_count(now, c.count)
            }
            MavMessage::MISSION_ITEM_INT(m)
                if for_us(m.target_system) && mission_type(m.mission_type) =>
            {
                self.on_item(now, m.seq, MissionItem::from_mavlink(m))
            }
            MavMessage::MISSION_ITEM(m)
                if for_us(m.target_system) && mission_type(m.mission_type) =>
            {
                self.on_item(now, m.seq, MissionItem::from_mavlink_float(m))
            }
            MavMessage::MISSION_REQUEST_LIST(r)
                if for_us(r.target_system) && mission_type(r.mission_type) =>
            {
                self.gcs = (header.system_id as u8, header.component_id);
                vec![MavMessage::MISSION_COUNT(MISSION_COUNT_DATA {
                    count: self.mission.len() as u16,
                    target_system: self.gcs.0,
                    target_component: self.gcs.1,
                    mission_type: MavMissionType::MAV_MISSION_TYPE_MISSION,
                    opaque_id: 0,
                })]
            }
            MavMessage::MISSION_REQUEST_INT(r)
                if for_us(r.target_system) && mission_type(r.mission_type) =>
            {
                self.serve(r.seq)
            }
            MavMessage::MISSION_REQUEST(r)
                if for_us(r.target_system) && mission_type(r.mission_type) =>
            {
                self.serve(r.seq)
            }
            MavMessage::MISSION_CLEAR_ALL(c)
                if for_us(c.target_system) && mission_type(c.mission_type) =>
            {
                self.gcs = (header.system_id as u8, header.component_id);
                if self.cfg.autopilot == Autopilot::ArduPilot
                    && matches!(self.state, State::Receiving { .. })
                {
                    // ArduPilot refuses to clear during an upload.
                    return vec![self.ack(MavMissionResult::MAV_MISSION_ERROR)];
                }
                self.mission.clear();
                self.state = State::Idle;
                vec![self.ack(MavMissionResult::MAV_MISSION_ACCEPTED)]
            }
            MavMessage::COMMAND_LONG(c)
                if for_us(c.target_system)
                    && c.command == MavCmd::MAV_CMD_REQUEST_MESSAGE
                    && c.param1.round() as u32 == HOME_POSITION_ID =>
            {
                let ack = |result| {
                    MavMessage::COMMAND_ACK(COMMAND_ACK_DATA {
                        command: MavCmd::MAV_CMD_REQUEST_MESSAGE,
                        result,
                        progress: 0,
                        result_param2: 0,
                        target_system: header.system_id as u8,
                        target_component: header.component_id,
                    })
                };
                if self.cfg.reports_home {
                    vec![
                        ack(MavResult::MAV_RESULT_ACCEPTED),
                        MavMessage::HOME_POSITION(home_position(&self.cfg.home)),
                    ]
                } else {
                    vec![ack(MavResult::MAV_RESULT_FAILED)]
                }
            }
            MavMessage::MISSION_ACK(a)
                if for_us(a.target_system)
                    && a.mavtype == MavMissionResult::MAV_MISSION_OPERATION_CANCELLED =>
            {
                self.state = State::Idle;
                Vec::new()
            }
            _ => Vec::new(),
        }
    }

    fn on_count(&mut self, now: Duration, count: u16) -> Vec<MavMessage> {
        if let Some(r) = self.cfg.reject_with {
            return vec![self.ack(r)];
        }
        if usize::from(count) > self.cfg.capacity {
            let mut out = vec![self.ack(MavMissionResult::MAV_MISSION_NO_SPACE)];
            if self.cfg.autopilot == Autopilot::ArduPilot {
                out.push(statustext(&ardupilot::capacity_text(self.cfg.capacity)));
            }
            return out;
        }
        if let State::Receiving {
            count: c,
            items,
            last_request,
            ..
        } = &mut self.state
        {
            if *c == count && !items.is_empty() {
                // A repeated MISSION_COUNT after progress: our request got
                // lost, not the transfer. Ask again rather than restart.
                *last_request = now;
                let seq = items.len() as u16;
                return vec![self.request(seq)];
            }
        }
        self.completed = None;
        if self.cfg.autopilot == Autopilot::ArduPilot {
            // ArduPilot truncates its stored mission to the new count
            // first, then overwrites items as they arrive.
            self.mission.truncate(usize::from(count));
        }
        if count == 0 {
            self.mission.clear();
            self.state = State::Idle;
            self.uploads += 1;
            return vec![self.ack(MavMissionResult::MAV_MISSION_ACCEPTED)];
        }
        self.state = State::Receiving {
            count,
            items: Vec::with_capacity(usize::from(count)),
            last_request: now,
            last_progress: now,
        };
        vec![self.request(0)]
    }

    fn on_item(&mut self, now: Duration, seq: u16, item: MissionItem) -> Vec<MavMessage> {
        let State::Receiving {
            count,
            items,
            last_request,
            last_progress,
        } = &mut self.state
        else {
            // A repeated last item after we finished: the ACK got lost.
            // (`seq` comes from the network: 65535 + 1 must not overflow.)
            if self
                .completed
                .is_some_and(|c| seq.checked_add(1) == Some(c))
            {
                return vec![self.ack(MavMissionResult::MAV_MISSION_ACCEPTED)];
            }
            return Vec::new();
        };
        let next = items.len() as u16;
        let ardupilot = self.cfg.autopilot == Autopilot::ArduPilot;
        if seq != next {
            // Not the item asked for: a duplicate or a stale copy. PX4
            // ignores it and asks again when its timer runs out; ArduPilot
            // answers INVALID_SEQUENCE and goes on.
            if ardupilot {
                return vec![self.ack(MavMissionResult::MAV_MISSION_INVALID_SEQUENCE)];
            }
            return Vec::new();
        }
        let item = if ardupilot {
            if let Err(r) = ardupilot::check(&item) {
                // The transfer ends; what was written stays written.
                self.state = State::Idle;
                self.abandoned += 1;
                return vec![self.ack(r)];
            }
            let mut kept = ardupilot::stored(&item);
            if seq == 0 {
                // ArduPilot keeps its own home at seq 0, whatever was uploaded.
                kept.x = deg_to_e7(self.cfg.home.lat_deg).unwrap_or(0);
                kept.y = deg_to_e7(self.cfg.home.lon_deg).unwrap_or(0);
                kept.z = self.cfg.home.alt_m as f32;
            }
            // Written to storage as it arrives.
            match self.mission.get_mut(usize::from(seq)) {
                Some(slot) => *slot = kept,
                None => self.mission.push(kept),
            }
            kept
        } else {
            item
        };
        items.push(item);
        *last_progress = now;
        *last_request = now;
        if items.len() < usize::from(*count) {
            return vec![self.request(next + 1)];
        }
        let count = *count;
        let mission = std::mem::take(items);
        self.state = State::Idle;
        self.mission = mission;
        self.completed = Some(count);
        self.uploads += 1;
        vec![self.ack(MavMissionResult::MAV_MISSION_ACCEPTED)]
    }

    /// Answers MISSION_REQUEST and MISSION_REQUEST_INT alike with
    /// MISSION_ITEM_INT, as the current spec asks.
    fn serve(&self, seq: u16) -> Vec<MavMessage> {
        let Some(item) = self.mission.get(usize::from(seq)) else {
            return vec![self.ack(MavMissionResult::MAV_MISSION_INVALID_SEQUENCE)];
        };
        vec![MavMessage::MISSION_ITEM_INT(item.to_mavlink(seq, self.gcs))]
    }

    #[allow(deprecated)] // MISSION_REQUEST on purpose, to exercise legacy handling.
    fn request(&self, seq: u16) -> MavMessage {
        let (target_system, target_component) = self.gcs;
        let mission_type = MavMissionType::MAV_MISSION_TYPE_MISSION;
        if self.cfg.legacy_requests {
            MavMessage::MISSION_REQUEST(MISSION_REQUEST_DATA {
                seq,
                target_system,
                target_component,
                mission_type,
            })
        } else {
            MavMessage::MISSION_REQUEST_INT(MISSION_REQUEST_INT_DATA {
                seq,
                target_system,
                target_component,
                mission_type,
            })
        }
    }

    fn ack(&self, r: MavMissionResult) -> MavMessage {
        MavMessage::MISSION_ACK(MISSION_ACK_DATA {
            target_system: self.gcs.0,
            target_component: self.gcs.1,
            mavtype: r,
            mission_type: MavMissionType::MAV_MISSION_TYPE_MISSION,
            opaque_id: 0,
        })
    }

    fn heartbeat(&self) -> MavMessage {
        MavMessage::HEARTBEAT(HEARTBEAT_DATA {
            custom_mode: 0,
            mavtype: MavType::MAV_TYPE_QUADROTOR,
            autopilot: match self.cfg.autopilot {
                Autopilot::Px4 => MavAutopilot::MAV_AUTOPILOT_PX4,
                Autopilot::ArduPilot => MavAutopilot::MAV_AUTOPILOT_ARDUPILOTMEGA,
            },
            base_mode: MavModeFlag::empty(),
            system_status: MavState::MAV_STATE_STANDBY,
            mavlink_version: 3,
        })
    }
}

/// A STATUSTEXT warning with `text` (cut to the message's 50 bytes).
fn statustext(text: &str) -> MavMessage {
    let mut bytes = [0u8; 50];
    for (b, t) in bytes.iter_mut().zip(text.bytes()) {
        *b = t;
    }
    MavMessage::STATUSTEXT(STATUSTEXT_DATA {
        severity: MavSeverity::MAV_SEVERITY_WARNING,
        text: bytes.into(),
        id: 0,
        chunk_seq: 0,
    })
}

/// A [`MissionServer`] running on a thread behind a MAVLink `udpin` socket.
pub struct UdpVehicle {
    addr: SocketAddr,
    server: Arc<Mutex<MissionServer>>,
    ignored: Arc<Mutex<IgnoredCounts>>,
    stop: Arc<AtomicBool>,
    thread: Option<JoinHandle<()>>,
}

impl UdpVehicle {
    /// Where the vehicle listens (give the ground `udpout:` this address).
    pub fn addr(&self) -> SocketAddr {
        self.addr
    }

    /// A copy of the stored mission.
    pub fn mission(&self) -> Vec<MissionItem> {
        self.server
            .lock()
            .unwrap_or_else(PoisonError::into_inner)
            .mission()
            .to_vec()
    }

    /// Completed and abandoned uploads so far.
    pub fn upload_counts(&self) -> (u32, u32) {
        let s = self.server.lock().unwrap_or_else(PoisonError::into_inner);
        (s.uploads, s.abandoned)
    }

    /// Messages ignored so far for their signature (with a signing key).
    pub fn ignored(&self) -> IgnoredCounts {
        *self.ignored.lock().unwrap_or_else(PoisonError::into_inner)
    }
}

impl Drop for UdpVehicle {
    fn drop(&mut self) {
        self.stop.store(true, Ordering::Relaxed);
        if let Some(t) = self.thread.take() {
            let _ = t.join();
        }
    }
}

/// Starts a vehicle listening on `bind` (e.g. `127.0.0.1:0` for any free port).
pub fn spawn_udp_vehicle(bind: &str, cfg: VehicleConfig) -> Result<UdpVehicle> {
    let io = |e: std::io::Error| MissionError::Connect {
        url: format!("udpin:{bind}"),
        source: e,
    };
    let socket = UdpSocket::bind(bind).map_err(io)?;
    let addr = socket.local_addr().map_err(io)?;
    let conn = UdpConfig::from_socket(socket, UdpMode::Udpin)
        .map_err(io)?
        .read_timeout(Duration::from_millis(2))
        .connect::<MavMessage>()
        .map_err(io)?;
    let mut link = SignedLink::new(cfg.signing.as_ref(), LINK_ID);
    let server = Arc::new(Mutex::new(MissionServer::new(cfg)));
    let ignored = Arc::new(Mutex::new(IgnoredCounts::default()));
    let stop = Arc::new(AtomicBool::new(false));
    let (srv, ign, stp) = (Arc::clone(&server), Arc::clone(&ignored), Arc::clone(&stop));
    let thread = std::thread::spawn(move || {
        let start = Instant::now();
        while !stp.load(Ordering::Relaxed) {
            let received = link.recv(&conn);
            *ign.lock().unwrap_or_else(PoisonError::into_inner) = link.ignored;
            let mut s = srv.lock().unwrap_or_else(PoisonError::into_inner);
            let now = start.elapsed();
            let mut out = match received {
                Ok(Some((h, msg))) => s.handle(now, &h, &msg),
                // Ignored for its signature, a read timeout or a corrupt frame.
                Ok(None) | Err(_) => Vec::new(),
            };
            out.extend(s.poll(now));
            let header = s.header();
            drop(s);
            for m in &out {
                // Before the ground has spoken, udpin has no peer: Ok(0), fine.
                let _ = link.send(&conn, &header, m);
            }
        }
    });
    Ok(UdpVehicle {
        addr,
        server,
        ignored,
        stop,
        thread: Some(thread),
    })
}
