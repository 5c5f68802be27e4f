//! Real MAVLink connections (through the `mavlink` crate) as a [`Link`],
//! and the heartbeat handshake that finds the vehicle.
//!
//! URLs: `udpin:HOST:PORT` (listen; the vehicle must speak first),
//! `udpout:HOST:PORT` (send to a vehicle listening there), `tcpout:HOST:PORT`,
//! `serial:DEVICE:BAUD`. Every read has a short timeout so that no call
//! blocks forever (the crate's `recv` would otherwise wait for a packet).
//!
//! With a signing key ([`MavLink::open_signed`]) everything sent is signed
//! and only messages signed with the key are received (see
//! [`crate::signing`]).

use std::net::{TcpStream, ToSocketAddrs};
use std::time::{Duration, Instant};

use mavlink::dialects::common::{
    MavAutopilot, MavMessage, MavModeFlag, MavState, MavType, HEARTBEAT_DATA,
};
use mavlink::error::MessageReadError;
use mavlink::{Connectable, MavConnection, MavHeader, SerialConfig, TcpConfig, UdpConfig, UdpMode};

use crate::error::{MissionError, Result};
use crate::items::Autopilot;
use crate::protocol::{Link, Target, GCS_COMPONENT_ID, GCS_SYSTEM_ID};
use crate::signing::{IgnoredCounts, SignedLink, SigningKey, LINK_ID};

/// Granularity of receive timeouts.
const POLL: Duration = Duration::from_millis(5);

/// A ground-station MAVLink connection.
pub struct MavLink {
    conn: Box<dyn MavConnection<MavMessage> + Send + Sync>,
    url: String,
    start: Instant,
    header: MavHeader,
    // Serial reads retry timeouts inside `recv` and `recv_raw`; `try_recv`
    // returns them. So a serial link checks signatures in the crate (which
    // does not say why it dropped a message) and the others in `signed`.
    use_try_recv: bool,
    signed: SignedLink,
}

/// What the vehicle's heartbeat told us.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct VehicleInfo {
    /// System and component id to address.
    pub target: Target,
    /// Autopilot family as reported.
    pub autopilot: MavAutopilot,
    /// Vehicle type as reported.
    pub mav_type: MavType,
}

impl VehicleInfo {
    /// The mission conventions of the reported autopilot, if known.
    pub fn autopilot_family(&self) -> Option<Autopilot> {
        match self.autopilot {
            MavAutopilot::MAV_AUTOPILOT_PX4 => Some(Autopilot::Px4),
            MavAutopilot::MAV_AUTOPILOT_ARDUPILOTMEGA => Some(Autopilot::ArduPilot),
            _ => None,
        }
    }
}

fn bad_url(url: &str, message: impl Into<String>) -> MissionError {
    MissionError::BadUrl {
        url: url.to_string(),
        message: message.into(),
    }
}

fn check_host_port(url: &str, addr: &str) -> Result<std::net::SocketAddr> {
    addr.to_socket_addrs()
        .map_err(|e| bad_url(url, format!("address {addr:?}: {e}")))?
        .next()
        .ok_or_else(|| bad_url(url, format!("address {addr:?} resolves to nothing")))
}

impl MavLink {
    /// Opens a connection (no traffic yet).
    pub fn open(url: &str) -> Result<Self> {
        Self::open_signed(url, None)
    }

    /// Opens a connection that signs what it sends with `key` and ignores
    /// what is not signed with it (no signing when `None`).
    pub fn open_signed(url: &str, key: Option<&SigningKey>) -> Result<Self> {
        let (scheme, rest) = url
            .split_once(':')
            .ok_or_else(|| bad_url(url, "missing transport prefix"))?;
        let io = |e: std::io::Error| MissionError::Connect {
            url: url.to_string(),
            source: e,
        };
        let mut use_try_recv = false;
        let mut conn: Box<dyn MavConnection<MavMessage> + Send + Sync> = match scheme {
            "udpin" | "udpout" => {
                check_host_port(url, rest)?;
                let mode = if scheme == "udpin" {
                    UdpMode::Udpin
                } else {
                    UdpMode::Udpout
                };
                Box::new(
                    UdpConfig::new(rest.to_string(), mode)
                        .read_timeout(POLL)
                        .connect::<MavMessage>()
                        .map_err(io)?,
                )
            }
            "tcpout" => {
                let addr = check_host_port(url, rest)?;
                let stream =
                    TcpStream::connect_timeout(&addr, Duration::from_secs(5)).map_err(io)?;
                stream.set_read_timeout(Some(POLL)).map_err(io)?;
                Box::new(
                    TcpConfig::from_stream(stream)
                        .map_err(io)?
                        .connect::<MavMessage>()
                        .map_err(io)?,
                )
            }
            "serial" => {
                let (dev, baud) = rest
                    .rsplit_once(':')
                    .ok_or_else(|| bad_url(url, "expected serial:DEVICE:BAUD"))?;
                let baud: u32 = baud
                    .parse()
                    .map_err(|_| bad_url(url, format!("baud rate {baud:?} is not a number")))?;
                use_try_recv = true;
                Box::new(
                    SerialConfig::new(dev.to_string(), baud)
                        .timeout(POLL)
                        .connect::<MavMessage>()
                        .map_err(io)?,
                )
            }
            other => return Err(bad_url(url, format!("unknown transport {other:?}"))),
        };
        let signed = if use_try_recv {
            conn.setup_signing(key.map(|k| k.config(LINK_ID)));
            SignedLink::new(None, LINK_ID)
        } else {
            SignedLink::new(key, LINK_ID)
        };
        Ok(MavLink {
            conn,
            url: url.to_string(),
            start: Instant::now(),
            header: MavHeader {
                system_id: u32::from(GCS_SYSTEM_ID),
                component_id: GCS_COMPONENT_ID,
                sequence: 0,
            },
            use_try_recv,
            signed,
        })
    }

    /// Messages ignored so far for their signature (always zero on a
    /// serial link, where the `mavlink` crate drops them without a word).
    pub fn ignored(&self) -> IgnoredCounts {
        self.signed.ignored
    }

    /// `e`, with what signing explains about it (see
    /// [`SignedLink::explain`]).
    pub fn explain(&self, e: MissionError) -> MissionError {
        self.signed.explain(e)
    }

    /// The URL this link was opened with.
    pub fn url(&self) -> &str {
        &self.url
    }

    fn heartbeat(&mut self) -> Result<()> {
        self.send(&MavMessage::HEARTBEAT(HEARTBEAT_DATA {
            custom_mode: 0,
            mavtype: MavType::MAV_TYPE_GCS,
            autopilot: MavAutopilot::MAV_AUTOPILOT_INVALID,
            base_mode: MavModeFlag::empty(),
            system_status: MavState::MAV_STATE_ACTIVE,
            mavlink_version: 3,
        }))
    }

    /// Waits for an autopilot's HEARTBEAT (from `system` if given) and
    /// returns its ids. Sends our own heartbeat every 0.5 s meanwhile, so
    /// that a vehicle behind `udpout` learns our address.
    pub fn wait_vehicle(&mut self, timeout: Duration, system: Option<u8>) -> Result<VehicleInfo> {
        let start = Instant::now();
        let mut next_hb = start;
        loop {
            let now = Instant::now();
            if now >= start + timeout {
                return Err(MissionError::NoVehicle {
                    url: self.url.clone(),
                    timeout,
                    target_system: system,
                });
            }
            if now >= next_hb {
                self.heartbeat()?;
                next_hb = now + Duration::from_millis(500);
            }
            let wait = (start + timeout)
                .min(next_hb)
                .saturating_duration_since(now);
            if let Some((h, MavMessage::HEARTBEAT(hb))) = self.recv(wait)? {
                let is_autopilot = hb.autopilot != MavAutopilot::MAV_AUTOPILOT_INVALID
                    && hb.mavtype != MavType::MAV_TYPE_GCS;
                let sys_ok = system.is_none_or(|s| h.system_id == u32::from(s));
                if is_autopilot && sys_ok {
                    if let Ok(sys) = u8::try_from(h.system_id) {
                        return Ok(VehicleInfo {
                            target: Target {
                                system: sys,
                                component: h.component_id,
                            },
                            autopilot: hb.autopilot,
                            mav_type: hb.mavtype,
                        });
                    }
                }
            }
        }
    }
}

impl Link for MavLink {
    fn send(&mut self, msg: &MavMessage) -> Result<()> {
        // Ok(0) means "no peer yet" (udpin before the vehicle spoke): the
        // protocol's timeouts and resends cover it.
        self.signed
            .send(&*self.conn, &self.header, msg)
            .map(|_| ())
            .map_err(|e| MissionError::Link(format!("{}: send failed: {e}", self.url)))
    }

    fn recv(&mut self, timeout: Duration) -> Result<Option<(MavHeader, MavMessage)>> {
        let deadline = Instant::now() + timeout;
        loop {
            let r = if self.use_try_recv {
                self.conn.try_recv().map(Some)
            } else {
                self.signed.recv(&*self.conn)
            };
            match r {
                Ok(Some(m)) => return Ok(Some(m)),
                // Ignored for its signature, a corrupt frame or a message
                // outside the common dialect: skip it.
                Ok(None) | Err(MessageReadError::Parse(_)) => {}
                Err(MessageReadError::Io(e))
                    if matches!(
                        e.kind(),
                        std::io::ErrorKind::WouldBlock | std::io::ErrorKind::TimedOut
                    ) => {}
                Err(MessageReadError::Io(e)) => {
                    return Err(MissionError::Link(format!(
                        "{}: receive failed: {e}",
                        self.url
                    )))
                }
            }
            if Instant::now() >= deadline {
                return Ok(None);
            }
        }
    }

    fn now(&self) -> Duration {
        self.start.elapsed()
    }
}
