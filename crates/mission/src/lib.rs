//! `vp-mission`: from a plan to a mission on the autopilot.
//!
//! - [`geodesy`]: local ENU <-> WGS84 on the ellipsoid.
//! - [`items`]: plan -> MISSION_ITEM_INT content ([`build_mission`]), with
//!   PX4 and ArduPilot conventions, and item-by-item comparison.
//! - [`protocol`]: the MAVLink mission protocol, ground side (upload,
//!   download, clear) over the [`protocol::Link`] trait.
//! - [`link`]: real connections (`udpin`, `udpout`, `tcpout`, `serial`) and
//!   the heartbeat handshake.
//! - [`signing`]: MAVLink 2 message signing (key files, checks that say
//!   why a message was ignored).
//! - [`qgc`] and [`wpl`]: QGroundControl `.plan` and `QGC WPL 110` export.
//! - [`wpml`] (and [`wpml_read`]): DJI WPML `.kmz` missions for DJI Pilot 2;
//!   [`litchi`]: Litchi CSV; [`preview`]: a KML preview for Google Earth;
//!   all from the photo points of [`fly::Flight`].
//! - [`sim_vehicle`]: the simulated vehicle (`vpctl mission vehicle`): a vehicle-side mission server, a virtual-time link and a
//!   lossy UDP relay, for tests and the simulator.
//!
//! Entry points for a command line: [`export_qgc`], [`export_wpl`],
//! [`upload`], [`download`], [`clear`].
#![warn(missing_docs, unreachable_pub)]
// A library tells its caller (returned warnings, reports, progress callbacks);
// only the CLI and the Python bindings print (docs/design.md).
#![deny(clippy::print_stderr, clippy::print_stdout)]

mod aftermath;
pub mod error;
pub mod export;
pub mod flights;
pub mod fly;
pub mod geodesy;
pub mod items;
pub mod link;
pub mod litchi;
pub mod preview;
pub mod protocol;
pub mod qgc;
pub mod signing;
pub mod sim_vehicle;
pub mod vehicle_home;
pub mod wpl;
pub mod wpml;
pub mod wpml_read;
pub mod xml;

use std::time::Duration;

pub use error::{MissionError, Result};
pub use export::{export_files, export_text, DjiOptions, ExportFormat};
pub use flights::{export_flights, one_flight, write_flights, ExportedFlight};
pub use items::heights;
pub use items::{
    build_mission, compare_items, Autopilot, CameraTrigger, GimbalCommand, Mission, MissionItem,
    MissionOptions,
};
pub use link::{MavLink, VehicleInfo};
pub use protocol::{DownloadReport, Link, Progress, ProtocolConfig, Target, UploadReport};
pub use qgc::{export_qgc, QgcOptions};
pub use signing::SigningKey;
pub use vehicle_home::HomeCheck;
pub use wpl::{export_wpl, parse_wpl};

/// How to reach the vehicle.
#[derive(Debug, Clone, PartialEq)]
pub struct ConnectOptions {
    /// How long to wait for the vehicle's first HEARTBEAT (default 5 s).
    pub heartbeat_timeout: Duration,
    /// Only talk to this system id (default: the first autopilot heard).
    pub target_system: Option<u8>,
    /// Protocol timing.
    pub protocol: ProtocolConfig,
    /// MAVLink 2 signing key: sign everything sent, ignore whatever is not
    /// signed with it (unsigned, another key, replays).
    pub signing: Option<SigningKey>,
    /// Before uploading, read the vehicle's HOME_POSITION and compare it
    /// with the mission's home (`None`: do not ask).
    pub home_check: Option<HomePolicy>,
}

/// How [`upload`] compares the vehicle's home with the mission's.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct HomePolicy {
    /// The datum of the mission's home altitude (the plan's).
    pub datum: Option<vp_scene::datum::VerticalDatum>,
    /// Upload even when the homes differ beyond the limits.
    pub accept_offset: bool,
}

impl ConnectOptions {
    /// The options a user sets: the heartbeat wait in seconds and a factor
    /// on every protocol timeout (1 = the MAVLink spec's), both positive.
    pub fn from_user(heartbeat_timeout_s: f64, timeout_scale: f64) -> Result<Self> {
        if !(heartbeat_timeout_s.is_finite() && heartbeat_timeout_s > 0.0) {
            return Err(MissionError::InvalidInput(format!(
                "heartbeat timeout = {heartbeat_timeout_s} s must be positive"
            )));
        }
        if !(timeout_scale.is_finite() && timeout_scale > 0.0) {
            return Err(MissionError::InvalidInput(format!(
                "timeout scale = {timeout_scale} must be positive"
            )));
        }
        let d = ConnectOptions::default();
        Ok(ConnectOptions {
            heartbeat_timeout: Duration::from_secs_f64(heartbeat_timeout_s),
            protocol: d.protocol.scaled(timeout_scale),
            ..d
        })
    }
}

impl Default for ConnectOptions {
    fn default() -> Self {
        ConnectOptions {
            heartbeat_timeout: Duration::from_secs(5),
            target_system: None,
            protocol: ProtocolConfig::default(),
            signing: None,
            home_check: None,
        }
    }
}

/// Result of an upload with read-back.
#[derive(Debug, Clone, PartialEq)]
pub struct TransferReport {
    /// The upload itself.
    pub upload: UploadReport,
    /// The read-back, when verification ran.
    pub verify: Option<DownloadReport>,
    /// True when the read-back matched item by item.
    pub verified: bool,
    /// The vehicle's home against the mission's, when asked ([`ConnectOptions::home_check`]).
    pub home: Option<HomeCheck>,
}

/// Uploads `mission` over an open link, then (if `verify`) reads it back and
/// compares item by item. A lost final ACK is accepted only when the
/// read-back matches. A failed upload says what the vehicle holds after it
/// ([`MissionError::Explained`]): on ArduPilot, which writes items as they
/// arrive, the half-written mission is cleared first.
pub fn upload_over(
    link: &mut dyn Link,
    target: Target,
    mission: &Mission,
    cfg: &ProtocolConfig,
    verify: bool,
    progress: &mut dyn FnMut(Progress),
) -> Result<TransferReport> {
    let up = match protocol::upload(link, target, &mission.items, cfg, progress) {
        Ok(up) => up,
        Err(e) => {
            return Err(aftermath::explain_failed_upload(
                link, target, mission, cfg, e,
            ))
        }
    };
    if !verify {
        if !up.ack_received {
            return Err(MissionError::Timeout {
                operation: "mission upload",
                stage: "waiting for MISSION_ACK after the last item (verify to check)".into(),
                attempts: cfg.retries + 1,
                elapsed: up.elapsed,
            });
        }
        return Ok(TransferReport {
            upload: up,
            verify: None,
            verified: false,
            home: None,
        });
    }
    let (got, down) = protocol::download(link, target, cfg, progress)?;
    compare_items(&mission.items, &got, mission.autopilot)?;
    Ok(TransferReport {
        upload: up,
        verify: Some(down),
        verified: true,
        home: None,
    })
}

/// Opens `url`, waits for the vehicle's heartbeat and returns the link.
pub fn connect(url: &str, opts: &ConnectOptions) -> Result<(MavLink, VehicleInfo)> {
    let mut link = MavLink::open_signed(url, opts.signing.as_ref())?;
    let info = link
        .wait_vehicle(opts.heartbeat_timeout, opts.target_system)
        .map_err(|e| link.explain(e))?;
    Ok((link, info))
}

/// Connects to `url`, uploads `mission` and verifies it by reading it back.
pub fn upload(
    url: &str,
    mission: &Mission,
    opts: &ConnectOptions,
    progress: &mut dyn FnMut(Progress),
) -> Result<(TransferReport, VehicleInfo)> {
    let (mut link, info) = connect(url, opts)?;
    if let Some(family) = info.autopilot_family() {
        if family != mission.autopilot {
            // ArduPilot would overwrite a PX4 mission's first item with its
            // home: refuse before touching the vehicle's mission.
            return Err(MissionError::InvalidInput(format!(
                "the mission was built for {:?} but the vehicle on {url} reports {:?}; \
                 rebuild it for that autopilot",
                mission.autopilot, family
            )));
        }
    }
    let home = match &opts.home_check {
        Some(policy) => {
            let vehicle = protocol::home::read_home(&mut link, info.target, &opts.protocol)
                .map_err(|e| link.explain(e))?;
            Some(vehicle_home::compare_home(
                &mission.home,
                policy.datum,
                vehicle,
                policy.accept_offset,
            )?)
        }
        None => None,
    };
    let mut report = upload_over(
        &mut link,
        info.target,
        mission,
        &opts.protocol,
        true,
        progress,
    )
    .map_err(|e| link.explain(e))?;
    report.home = home;
    Ok((report, info))
}

/// Connects to `url` and reads the vehicle's mission.
pub fn download(
    url: &str,
    opts: &ConnectOptions,
    progress: &mut dyn FnMut(Progress),
) -> Result<(Vec<MissionItem>, DownloadReport, VehicleInfo)> {
    let (mut link, info) = connect(url, opts)?;
    let (items, report) = protocol::download(&mut link, info.target, &opts.protocol, progress)
        .map_err(|e| link.explain(e))?;
    Ok((items, report, info))
}

/// Connects to `url` and deletes the vehicle's mission.
pub fn clear(url: &str, opts: &ConnectOptions) -> Result<VehicleInfo> {
    let (mut link, info) = connect(url, opts)?;
    protocol::clear(&mut link, info.target, &opts.protocol).map_err(|e| link.explain(e))?;
    Ok(info)
}
