//! MAVLink 2 message signing, as ArduPilot, PX4 and QGroundControl do it
//! (<https://mavlink.io/en/guide/message_signing.html>): a 32-byte secret
//! key shared by both ends, a link id, and a 48-bit timestamp (10 µs units
//! since 2015-01-01) that must grow on every (link id, system, component)
//! stream; the signature is the first 6 bytes of SHA-256 over key, frame,
//! link id and timestamp.
//!
//! The cryptography and the per-stream replay check are the `mavlink`
//! crate's ([`SigningData`]). This module adds what the crate leaves to
//! its user: the key file ([`SigningKey::load`]) and a receive path that
//! says *why* a message was ignored ([`Verdict`], [`IgnoredCounts`]), so
//! that a vehicle signing with another key ends in a clear error instead
//! of a bare timeout.

use std::fmt;
use std::path::Path;

use mavlink::dialects::common::MavMessage;
use mavlink::error::{MessageReadError, MessageWriteError};
use mavlink::{
    MAVLinkMessageRaw, MAVLinkV2MessageRaw, MavConnection, MavHeader, Message, SigningConfig,
    SigningData,
};

use crate::error::{MissionError, Result};

/// Bytes in a MAVLink 2 signing key.
pub const KEY_LEN: usize = 32;

/// The link id we sign with. One ground station process holds one link;
/// the replay check is per (link id, system, component), so two vpctl
/// processes with the same system id talking to one vehicle at once would
/// need distinct ids (not supported: the mission protocol allows one
/// transfer at a time anyway).
pub const LINK_ID: u8 = 0;

/// A secret signing key. Its `Debug` never shows the bytes, so that no log
/// or error message can leak it.
#[derive(Clone, PartialEq, Eq)]
pub struct SigningKey([u8; KEY_LEN]);

impl fmt::Debug for SigningKey {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str("SigningKey(<secret>)")
    }
}

/// A key read from a file, with what the user should be told about it.
#[derive(Debug)]
pub struct LoadedKey {
    /// The key.
    pub key: SigningKey,
    /// A warning for standard error (a key file others can read), if any.
    pub warning: Option<String>,
}

/// Largest key file we read: a key is 64 hex digits and a newline; anything
/// much larger is the wrong file.
const MAX_KEY_FILE: u64 = 1024;

impl SigningKey {
    /// A key from its 32 bytes.
    pub fn from_bytes(bytes: [u8; KEY_LEN]) -> Self {
        SigningKey(bytes)
    }

    /// Parses 64 hexadecimal digits (either case; surrounding whitespace
    /// allowed). The error never quotes the text: it may be a secret.
    pub fn from_hex(text: &str) -> std::result::Result<Self, String> {
        let hex = text.trim();
        if hex.len() != 2 * KEY_LEN || !hex.bytes().all(|b| b.is_ascii_hexdigit()) {
            let what = if hex.bytes().all(|b| b.is_ascii_hexdigit()) {
                format!("{} hex digits", hex.len())
            } else {
                format!("{} characters, not all hex digits", hex.chars().count())
            };
            return Err(format!(
                "expected 64 hexadecimal digits (a 32-byte key) but found {what}"
            ));
        }
        let mut key = [0u8; KEY_LEN];
        for (i, byte) in key.iter_mut().enumerate() {
            // Checked above: two ASCII hex digits.
            *byte = u8::from_str_radix(&hex[2 * i..2 * i + 2], 16).unwrap_or(0);
        }
        Ok(SigningKey(key))
    }

    /// Reads a key file: 64 hexadecimal digits, e.g. from `openssl rand -hex
    /// 32`; for a MAVProxy / Mission Planner / QGroundControl passphrase,
    /// its SHA-256 in hex (`printf %s PASSPHRASE | sha256sum`). Warns, as
    /// ssh does, when group or others may read the file (Unix).
    pub fn load(path: &Path) -> Result<LoadedKey> {
        let err = |message: String| MissionError::SigningKey {
            path: path.to_path_buf(),
            message,
        };
        let meta = std::fs::metadata(path).map_err(|e| err(format!("cannot read it: {e}")))?;
        if !meta.is_file() {
            return Err(err("not a regular file".into()));
        }
        if meta.len() > MAX_KEY_FILE {
            return Err(err(format!(
                "{} bytes is too large for a key file (64 hexadecimal digits)",
                meta.len()
            )));
        }
        let bytes = std::fs::read(path).map_err(|e| err(format!("cannot read it: {e}")))?;
        let text = std::str::from_utf8(&bytes).map_err(|_| {
            err(format!(
                "{} bytes of binary data; expected 64 hexadecimal digits \
                 (`xxd -p -c 32 raw.key` converts 32 raw bytes)",
                bytes.len()
            ))
        })?;
        let key = SigningKey::from_hex(text).map_err(err)?;
        Ok(LoadedKey {
            key,
            warning: permission_warning(path, &meta),
        })
    }

    pub(crate) fn config(&self, link_id: u8) -> SigningConfig {
        // Sign everything we send; accept nothing unsigned.
        SigningConfig::new(self.0, link_id, true, false)
    }
}

#[cfg(unix)]
fn permission_warning(path: &Path, meta: &std::fs::Metadata) -> Option<String> {
    use std::os::unix::fs::PermissionsExt;
    let mode = meta.permissions().mode() & 0o777;
    (mode & 0o077 != 0).then(|| {
        format!(
            "warning: signing key file {} is accessible by others (mode {mode:04o}); \
             anyone who reads it can command the vehicle: chmod 600 {}",
            path.display(),
            path.display()
        )
    })
}

#[cfg(not(unix))]
fn permission_warning(_: &Path, _: &std::fs::Metadata) -> Option<String> {
    None
}

/// Why a received message was accepted or ignored.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Verdict {
    /// Signed with our key, with a fresh timestamp.
    Accepted,
    /// Not signed (MAVLink 1, or MAVLink 2 without the signed flag).
    Unsigned,
    /// Signed, but not with our key (or altered on the way).
    WrongKey,
    /// Signed with our key but with a timestamp not newer than the last one
    /// of its stream (a replay or a duplicate), or a new stream more than a
    /// minute behind our clock.
    Stale,
}

/// Messages ignored for want of a valid signature, by reason.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub struct IgnoredCounts {
    /// Unsigned messages.
    pub unsigned: u64,
    /// Messages signed with another key.
    pub wrong_key: u64,
    /// Replays and duplicates (stale timestamps).
    pub stale: u64,
}

impl IgnoredCounts {
    /// All ignored messages.
    pub fn total(&self) -> u64 {
        self.unsigned + self.wrong_key + self.stale
    }

    /// Messages that no one holding the key sent: unsigned or another
    /// key. (Stale ones were signed with the key; on a lossy link a
    /// duplicated datagram is one, so they alone do not mean a wrong setup.)
    pub fn foreign(&self) -> u64 {
        self.unsigned + self.wrong_key
    }

    fn count(&mut self, v: Verdict) {
        match v {
            Verdict::Accepted => {}
            Verdict::Unsigned => self.unsigned += 1,
            Verdict::WrongKey => self.wrong_key += 1,
            Verdict::Stale => self.stale += 1,
        }
    }
}

impl fmt::Display for IgnoredCounts {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(
            f,
            "{} unsigned, {} signed with another key, {} stale (replayed)",
            self.unsigned, self.wrong_key, self.stale
        )
    }
}

/// Signs with a key and checks what arrives: the crate's [`SigningData`]
/// (one per connection: its clock also orders our own timestamps) and the
/// key again, to tell a wrong key from a replay.
pub struct Signer {
    data: SigningData,
    key: SigningKey,
}

impl Signer {
    /// A signer for `link_id`.
    pub fn new(key: &SigningKey, link_id: u8) -> Self {
        Signer {
            data: SigningData::from_config(key.config(link_id)),
            key: key.clone(),
        }
    }

    /// A signed MAVLink 2 frame of `msg`.
    pub fn sign(&self, header: MavHeader, msg: &MavMessage) -> MAVLinkMessageRaw {
        let mut raw = MAVLinkV2MessageRaw::new();
        raw.serialize_message_for_signing(header, msg);
        self.data.sign_message(&mut raw);
        MAVLinkMessageRaw::V2(raw)
    }

    /// Checks one received frame (and, when accepted, advances its stream's
    /// timestamp so that the same frame is stale next time).
    pub fn check(&self, raw: &MAVLinkMessageRaw) -> Verdict {
        let MAVLinkMessageRaw::V2(m) = raw else {
            return Verdict::Unsigned;
        };
        if m.incompatibility_flags() & mavlink::consts::v2::IFLAG_SIGNED == 0 {
            return Verdict::Unsigned;
        }
        if self.data.verify_signature(m) {
            return Verdict::Accepted;
        }
        let mut sig = [0u8; mavlink::consts::v2::SIGNATURE_VALUE_SIZE];
        m.calculate_signature(&self.key.0, &mut sig);
        if sig == m.signature_value() {
            Verdict::Stale
        } else {
            Verdict::WrongKey
        }
    }
}

/// One end of a connection with optional signing: sends (signed when a key
/// is set), receives (dropping what the key does not vouch for), counts
/// what it dropped, and notices a peer that signs when we do not.
pub struct SignedLink {
    signer: Option<Signer>,
    sequence: u8,
    /// Messages ignored so far.
    pub ignored: IgnoredCounts,
    /// Whether the peer sent signed messages (the hint for a user who
    /// forgot `--signing-key`).
    pub peer_signs: bool,
}

impl SignedLink {
    /// Signing with `key` (on `link_id`), or none.
    pub fn new(key: Option<&SigningKey>, link_id: u8) -> Self {
        SignedLink {
            signer: key.map(|k| Signer::new(k, link_id)),
            sequence: 0,
            ignored: IgnoredCounts::default(),
            peer_signs: false,
        }
    }

    /// Whether we sign and check.
    pub fn is_signing(&self) -> bool {
        self.signer.is_some()
    }

    /// Sends `msg`, signed when a key is set.
    pub fn send(
        &mut self,
        conn: &dyn MavConnection<MavMessage>,
        header: &MavHeader,
        msg: &MavMessage,
    ) -> std::result::Result<usize, MessageWriteError> {
        let Some(signer) = &self.signer else {
            return conn.send(header, msg);
        };
        // `send_raw` does not number frames: the sequence is ours to keep.
        let h = MavHeader {
            sequence: self.sequence,
            ..*header
        };
        self.sequence = self.sequence.wrapping_add(1);
        conn.send_raw(&signer.sign(h, msg))
    }

    /// Receives one frame: `Ok(None)` when it was ignored (signature) or
    /// is not a message we know. Read errors (timeouts) pass through.
    pub fn recv(
        &mut self,
        conn: &dyn MavConnection<MavMessage>,
    ) -> std::result::Result<Option<(MavHeader, MavMessage)>, MessageReadError> {
        let raw = conn.recv_raw()?;
        Ok(self.accept(&raw))
    }

    /// The signature check and decoding of one received frame.
    pub fn accept(&mut self, raw: &MAVLinkMessageRaw) -> Option<(MavHeader, MavMessage)> {
        if let MAVLinkMessageRaw::V2(m) = raw {
            if m.incompatibility_flags() & mavlink::consts::v2::IFLAG_SIGNED != 0 {
                self.peer_signs = true;
            }
        }
        if let Some(signer) = &self.signer {
            let v = signer.check(raw);
            if v != Verdict::Accepted {
                self.ignored.count(v);
                return None;
            }
        }
        let msg = MavMessage::parse(raw.version(), raw.message_id(), raw.payload()).ok()?;
        let header = MavHeader {
            system_id: raw.system_id(),
            component_id: raw.component_id(),
            sequence: raw.sequence(),
        };
        Some((header, msg))
    }

    /// Adds what signing explains to a failure: a timeout or a silent
    /// vehicle while foreign messages were being ignored, or while the
    /// vehicle signs and we do not, becomes [`MissionError::Signing`].
    pub fn explain(&self, e: MissionError) -> MissionError {
        if !matches!(
            e.root(),
            MissionError::NoVehicle { .. } | MissionError::Timeout { .. }
        ) {
            return e;
        }
        let detail = if self.is_signing() {
            if self.ignored.foreign() == 0 {
                return e;
            }
            format!(
                "with signing on, messages not signed with the key were ignored ({}): \
                 the vehicle must sign with the same key (MAVLink 2 signing)",
                self.ignored
            )
        } else if self.peer_signs {
            "the vehicle signs its messages (MAVLink 2 signing) and will ignore our unsigned \
             ones: give its key with --signing-key FILE"
                .to_string()
        } else {
            return e;
        };
        MissionError::Signing {
            detail,
            source: Box::new(e),
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use mavlink::dialects::common::{MavMissionType, MISSION_CLEAR_ALL_DATA};

    fn msg() -> MavMessage {
        MavMessage::MISSION_CLEAR_ALL(MISSION_CLEAR_ALL_DATA {
            target_system: 1,
            target_component: 1,
            mission_type: MavMissionType::MAV_MISSION_TYPE_MISSION,
        })
    }

    fn header() -> MavHeader {
        MavHeader {
            system_id: 255,
            component_id: 190,
            sequence: 0,
        }
    }

    #[test]
    fn a_replayed_frame_is_stale_and_another_key_is_wrong() {
        let key = SigningKey::from_bytes([7; KEY_LEN]);
        let sender = Signer::new(&key, 0);
        let receiver = Signer::new(&key, 0);
        let a = sender.sign(header(), &msg());
        let b = sender.sign(header(), &msg());
        assert_eq!(receiver.check(&a), Verdict::Accepted);
        assert_eq!(receiver.check(&a), Verdict::Stale, "same frame again");
        assert_eq!(receiver.check(&b), Verdict::Accepted, "newer timestamp");
        assert_eq!(
            receiver.check(&a),
            Verdict::Stale,
            "older frame after newer"
        );
        let other = Signer::new(&SigningKey::from_bytes([8; KEY_LEN]), 0);
        assert_eq!(
            receiver.check(&other.sign(header(), &msg())),
            Verdict::WrongKey
        );
    }

    #[test]
    fn unsigned_frames_are_counted_and_dropped() {
        let key = SigningKey::from_bytes([7; KEY_LEN]);
        let mut link = SignedLink::new(Some(&key), 0);
        let mut raw = MAVLinkV2MessageRaw::new();
        raw.serialize_message(header(), &msg());
        assert!(link.accept(&MAVLinkMessageRaw::V2(raw)).is_none());
        assert_eq!(link.ignored.unsigned, 1);
        let mut plain = SignedLink::new(None, 0);
        let signed = Signer::new(&key, 0).sign(header(), &msg());
        assert_eq!(plain.accept(&signed).map(|m| m.1), Some(msg()));
        assert!(plain.peer_signs);
    }

    #[test]
    fn hex_keys_parse_and_errors_do_not_quote_the_text() {
        let hex = "00112233445566778899aabbccddeeff00112233445566778899AABBCCDDEEFF\n";
        let k = SigningKey::from_hex(hex).unwrap();
        assert_eq!(k.0[1], 0x11);
        assert_eq!(k.0[31], 0xff);
        assert_eq!(format!("{k:?}"), "SigningKey(<secret>)");
        let e = SigningKey::from_hex("my secret passphrase").unwrap_err();
        assert!(!e.contains("secret passphrase"), "{e}");
        assert!(e.contains("64 hexadecimal digits"), "{e}");
        assert!(SigningKey::from_hex(&hex[..62]).is_err());
    }
}
