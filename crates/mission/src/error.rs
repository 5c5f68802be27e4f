//! The one error type of `vp-mission`.

use std::time::Duration;

/// Errors of `vp-mission`.
#[derive(Debug, thiserror::Error)]
pub enum MissionError {
    /// A scene-level error: reading or writing a file, a malformed plan.
    #[error(transparent)]
    Scene(#[from] vp_scene::SceneError),
    /// The plan or the options cannot be turned into a mission.
    #[error("invalid mission input: {0}")]
    InvalidInput(String),
    /// A mission or area file (KMZ, WPML, KML, GeoJSON) that is not what
    /// its format says: the file, the element and the problem.
    #[error("{}: {message}", path.display())]
    BadFile {
        /// The file.
        path: std::path::PathBuf,
        /// Where in it and what is wrong.
        message: String,
    },
    /// The vehicle's home lies too far from the plan's: every waypoint
    /// would be off by that much (`mission upload`).
    #[error("invalid mission input: {0}")]
    HomeOffset(crate::vehicle_home::HomeOffset),
    /// The connection URL is malformed or names an unknown transport.
    #[error("connection URL {url:?}: {message} (expected udpin:HOST:PORT, udpout:HOST:PORT, tcpout:HOST:PORT or serial:DEVICE:BAUD)")]
    BadUrl {
        /// The URL as given.
        url: String,
        /// What is wrong with it.
        message: String,
    },
    /// Opening the connection failed at the operating-system level.
    #[error("cannot open {url}: {source}")]
    Connect {
        /// The URL as given.
        url: String,
        /// The underlying error.
        #[source]
        source: std::io::Error,
    },
    /// Sending or receiving on an open link failed.
    #[error("link error: {0}")]
    Link(String),
    /// No vehicle heartbeat arrived in time.
    #[error(
        "no vehicle answered on {url} within {:.1} s (no HEARTBEAT from an autopilot{}); \
         check the URL, that the autopilot is powered and that its MAVLink output reaches this port",
        timeout.as_secs_f64(),
        match target_system { Some(s) => format!(" with system id {s}"), None => String::new() }
    )]
    NoVehicle {
        /// The URL listened on.
        url: String,
        /// How long we waited.
        timeout: Duration,
        /// The system id asked for, if any.
        target_system: Option<u8>,
    },
    /// A protocol step got no answer after all retries.
    #[error("{operation}: timed out {stage} after {attempts} attempt(s) ({} s)", format_secs(*elapsed))]
    Timeout {
        /// Upload, download or clear.
        operation: &'static str,
        /// What we were waiting for, in words.
        stage: String,
        /// How many times the step was tried.
        attempts: u32,
        /// Time spent in the operation.
        elapsed: Duration,
    },
    /// The vehicle answered with a MISSION_ACK other than MAV_MISSION_ACCEPTED.
    #[error(
        "{operation}: vehicle rejected the mission with {result}{}{}",
        match seq { Some(s) => format!(" (after item {s})"), None => String::new() },
        if said.is_empty() { String::new() } else { format!("; the vehicle said: {}", said.iter().map(|t| format!("{t:?}")).collect::<Vec<_>>().join(", ")) }
    )]
    Rejected {
        /// Upload, download or clear.
        operation: &'static str,
        /// The MAV_MISSION_RESULT name, e.g. `MAV_MISSION_NO_SPACE`.
        result: String,
        /// The last item sent before the rejection, if any.
        seq: Option<u16>,
        /// The vehicle's STATUSTEXT messages around the rejection, its own
        /// words (e.g. ArduPilot's "Only 650 items are supported").
        said: Vec<String>,
    },
    /// The mission read back from the vehicle differs from the one uploaded.
    #[error("verify: item {seq} differs after upload: {detail}")]
    VerifyMismatch {
        /// Sequence number of the first differing item.
        seq: usize,
        /// Which field differs, with both values.
        detail: String,
    },
    /// A MAVLink signing key file is missing, unreadable or malformed.
    #[error("signing key file {}: {message}", path.display())]
    SigningKey {
        /// The key file as given.
        path: std::path::PathBuf,
        /// What is wrong (never the file's content).
        message: String,
    },
    /// The vehicle went silent (or never answered) while messages were
    /// ignored for their signature: the two ends do not share a key.
    #[error("{source}; {detail}")]
    Signing {
        /// What was ignored and what to check.
        detail: String,
        /// The timeout or missing vehicle it explains.
        source: Box<MissionError>,
    },
    /// A failed upload, with what the vehicle holds afterwards and what to
    /// do (ArduPilot writes items as they arrive), or how much fits.
    #[error("{source}; {detail}")]
    Explained {
        /// What the vehicle holds now and the next step.
        detail: String,
        /// The failure it explains.
        source: Box<MissionError>,
    },
    /// The vehicle sent something the protocol does not allow.
    #[error("{operation}: protocol error: {message}")]
    Protocol {
        /// Upload, download or clear.
        operation: &'static str,
        /// What happened.
        message: String,
    },
}

impl MissionError {
    /// The failure itself, under the explanations added around it
    /// ([`MissionError::Explained`], [`MissionError::Signing`]).
    pub fn root(&self) -> &MissionError {
        match self {
            MissionError::Explained { source, .. } | MissionError::Signing { source, .. } => {
                source.root()
            }
            other => other,
        }
    }

    /// Whether the user's input is at fault (exit code 2 in `vpctl`): a bad
    /// plan or argument, a malformed connection URL, a missing file. A
    /// vehicle that does not answer, refuses or misbehaves is not.
    pub fn is_input_error(&self) -> bool {
        match self {
            MissionError::Scene(e) => e.is_input_error(),
            MissionError::Explained { source, .. } => source.is_input_error(),
            MissionError::InvalidInput(_)
            | MissionError::HomeOffset(_)
            | MissionError::BadFile { .. }
            | MissionError::BadUrl { .. }
            | MissionError::SigningKey { .. } => true,
            _ => false,
        }
    }
}

impl MissionError {
    /// The exit code of `vpctl mission` for this outcome, one per kind of
    /// failure so that scripts can tell them apart: 2 input (bad plan,
    /// argument or URL), 3 no vehicle (no heartbeat), 4 timeout (the vehicle
    /// stopped answering mid-protocol, after every retry), 5 rejected
    /// (MISSION_ACK with MAV_MISSION_DENIED, NO_SPACE, INVALID_SEQUENCE,
    /// UNSUPPORTED_FRAME, ...), 6 verification failed (the read-back differs
    /// from the upload), 7 protocol violation, 9 signing (the vehicle's
    /// messages are not signed with our key, or it signs and we do not),
    /// 1 anything else (I/O).
    pub fn exit_code(&self) -> u8 {
        if let MissionError::Explained { source, .. } = self {
            return source.exit_code();
        }
        if self.is_input_error() {
            return 2;
        }
        match self {
            MissionError::NoVehicle { .. } => 3,
            MissionError::Timeout { .. } => 4,
            MissionError::Rejected { .. } => 5,
            MissionError::VerifyMismatch { .. } => 6,
            MissionError::Protocol { .. } => 7,
            MissionError::Signing { .. } => 9,
            _ => 1,
        }
    }
}

fn format_secs(d: Duration) -> String {
    format!("{:.2}", d.as_secs_f64())
}

/// Result alias of `vp-mission`.
pub type Result<T, E = MissionError> = std::result::Result<T, E>;
