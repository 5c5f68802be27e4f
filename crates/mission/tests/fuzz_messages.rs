//! Mutation fuzzing of the MAVLink messages that arrive on the mission link:
//! valid mission-protocol messages are serialised, their payload bytes
//! mutated, parsed back as the wire parser would, and fed to
//! - the simulated vehicle's mission server (what a ground station sends),
//! - the ground's upload and download (what a vehicle sends back), through a
//!   virtual-time link that answers with fuzzed messages and then goes quiet.
//!
//! Invariants: no panic; the ground's operations end, with a result or a
//! clear error, and give up by their own deadline once the link is quiet.
//! `VP_FUZZ_CASES` sets the cases (default 2000 per target).

use std::panic::{catch_unwind, AssertUnwindSafe};
use std::time::Duration;

use mavlink::dialects::common::{
    MavCmd, MavFrame, MavMessage, MavMissionResult, MavMissionType, MISSION_ACK_DATA,
    MISSION_CLEAR_ALL_DATA, MISSION_COUNT_DATA, MISSION_ITEM_INT_DATA, MISSION_REQUEST_INT_DATA,
    MISSION_REQUEST_LIST_DATA,
};
use mavlink::{MavHeader, MavlinkVersion, Message};
use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;
use vp_mission::protocol::{download, upload, ProtocolConfig, Target};
use vp_mission::sim_vehicle::{MissionServer, VehicleConfig};
use vp_mission::{Autopilot, Link, MissionItem};

const TARGET: Target = Target {
    system: 1,
    component: 1,
};

fn cases() -> usize {
    std::env::var("VP_FUZZ_CASES")
        .ok()
        .and_then(|v| v.parse().ok())
        .unwrap_or(2000)
}

fn mission_type(rng: &mut ChaCha8Rng) -> MavMissionType {
    if rng.random_bool(0.9) {
        MavMissionType::MAV_MISSION_TYPE_MISSION
    } else {
        MavMissionType::MAV_MISSION_TYPE_FENCE
    }
}

fn small_or_any(rng: &mut ChaCha8Rng, around: u16) -> u16 {
    match rng.random_range(0..4) {
        0 => rng.random(),
        1 => [0, 1, u16::MAX, u16::MAX - 1][rng.random_range(0..4)],
        _ => around
            .saturating_add(rng.random_range(0..3))
            .saturating_sub(1),
    }
}

fn item(seq: u16, target: (u8, u8)) -> MISSION_ITEM_INT_DATA {
    MISSION_ITEM_INT_DATA {
        param1: 2.0,
        param2: 1.0,
        param3: 0.0,
        param4: 90.0,
        x: 460_500_000 + i32::from(seq),
        y: 103_200_000,
        z: 40.0,
        seq,
        command: MavCmd::MAV_CMD_NAV_WAYPOINT,
        target_system: target.0,
        target_component: target.1,
        frame: MavFrame::MAV_FRAME_GLOBAL_RELATIVE_ALT,
        current: 0,
        autocontinue: 1,
        mission_type: MavMissionType::MAV_MISSION_TYPE_MISSION,
    }
}

/// The message, its payload bytes mutated, parsed back (None when the
/// parser refuses it, as the link then drops the frame).
fn mutated(rng: &mut ChaCha8Rng, msg: &MavMessage) -> Option<MavMessage> {
    if rng.random_bool(0.3) {
        return Some(msg.clone());
    }
    let mut buf = [0u8; 255];
    let n = msg.ser(MavlinkVersion::V2, &mut buf);
    let mut payload = buf[..n].to_vec();
    for _ in 0..rng.random_range(1..5) {
        match rng.random_range(0..5) {
            0 if !payload.is_empty() => {
                let i = rng.random_range(0..payload.len());
                payload[i] = rng.random();
            }
            1 if payload.len() >= 2 => {
                let i = rng.random_range(0..payload.len() - 1);
                let v: u16 = [0, 1, 0x7fff, 0x8000, 0xffff][rng.random_range(0..5)];
                payload[i..i + 2].copy_from_slice(&v.to_le_bytes());
            }
            2 => payload.truncate(rng.random_range(0..=payload.len())),
            3 => {
                let len = rng.random_range(payload.len()..=255);
                payload.resize(len, 0xff);
            }
            _ if !payload.is_empty() => {
                let i = rng.random_range(0..payload.len());
                payload[i] ^= 1 << rng.random_range(0..8);
            }
            _ => {}
        }
    }
    MavMessage::parse(MavlinkVersion::V2, msg.message_id(), &payload).ok()
}

/// A message a ground station may send a vehicle.
fn to_vehicle(rng: &mut ChaCha8Rng, next_seq: u16) -> MavMessage {
    let t = if rng.random_bool(0.9) {
        1
    } else {
        rng.random()
    };
    match rng.random_range(0..7) {
        0 => MavMessage::MISSION_COUNT(MISSION_COUNT_DATA {
            count: small_or_any(rng, 5),
            target_system: t,
            target_component: 1,
            mission_type: mission_type(rng),
            opaque_id: 0,
        }),
        1 | 2 => MavMessage::MISSION_ITEM_INT(MISSION_ITEM_INT_DATA {
            mission_type: mission_type(rng),
            ..item(small_or_any(rng, next_seq), (t, 1))
        }),
        3 => MavMessage::MISSION_REQUEST_LIST(MISSION_REQUEST_LIST_DATA {
            target_system: t,
            target_component: 1,
            mission_type: mission_type(rng),
        }),
        4 => MavMessage::MISSION_REQUEST_INT(MISSION_REQUEST_INT_DATA {
            seq: small_or_any(rng, 2),
            target_system: t,
            target_component: 1,
            mission_type: mission_type(rng),
        }),
        5 => MavMessage::MISSION_CLEAR_ALL(MISSION_CLEAR_ALL_DATA {
            target_system: t,
            target_component: 1,
            mission_type: mission_type(rng),
        }),
        _ => MavMessage::MISSION_ACK(MISSION_ACK_DATA {
            target_system: t,
            target_component: 1,
            mavtype: MavMissionResult::MAV_MISSION_OPERATION_CANCELLED,
            mission_type: mission_type(rng),
            opaque_id: 0,
        }),
    }
}

/// Regression (found by this fuzzing): MISSION_ITEM_INT with seq 65535
/// after an upload overflowed `seq + 1` and killed the simulated vehicle.
#[test]
fn item_seq_65535_after_an_upload_is_ignored_not_a_crash() {
    let mut server = MissionServer::new(VehicleConfig::default());
    let h = MavHeader {
        system_id: 255,
        component_id: 190,
        sequence: 0,
    };
    let t = Duration::ZERO;
    server.handle(t, &h, &to_count(1));
    server.handle(t, &h, &MavMessage::MISSION_ITEM_INT(item(0, (1, 1))));
    assert_eq!(server.mission().len(), 1);
    for seq in [u16::MAX, u16::MAX - 1] {
        let out = server.handle(t, &h, &MavMessage::MISSION_ITEM_INT(item(seq, (1, 1))));
        assert!(out.is_empty(), "{out:?}");
    }
    // Mid-transfer too.
    server.handle(t, &h, &to_count(3));
    let out = server.handle(t, &h, &MavMessage::MISSION_ITEM_INT(item(u16::MAX, (1, 1))));
    assert!(out.is_empty(), "{out:?}");
}

fn to_count(count: u16) -> MavMessage {
    MavMessage::MISSION_COUNT(MISSION_COUNT_DATA {
        count,
        target_system: 1,
        target_component: 1,
        mission_type: MavMissionType::MAV_MISSION_TYPE_MISSION,
        opaque_id: 0,
    })
}

#[test]
fn vehicle_survives_fuzzed_ground_messages() {
    let mut rng = ChaCha8Rng::seed_from_u64(21);
    let mut panics = Vec::new();
    for case in 0..cases() {
        let mut server = MissionServer::new(VehicleConfig {
            autopilot: if rng.random_bool(0.5) {
                Autopilot::Px4
            } else {
                Autopilot::ArduPilot
            },
            capacity: [0, 3, 2000, usize::from(u16::MAX)][rng.random_range(0..4)],
            ..VehicleConfig::default()
        });
        let script: Vec<(MavHeader, Option<MavMessage>, u64)> = (0..rng.random_range(1..40))
            .map(|i| {
                let header = MavHeader {
                    system_id: if rng.random_bool(0.8) {
                        255
                    } else {
                        rng.random()
                    },
                    component_id: rng.random(),
                    sequence: rng.random(),
                };
                let msg = to_vehicle(&mut rng, i);
                (header, mutated(&mut rng, &msg), rng.random_range(0..3000))
            })
            .collect();
        let outcome = catch_unwind(AssertUnwindSafe(|| {
            let mut now = Duration::ZERO;
            for (header, msg, dt) in &script {
                now += Duration::from_millis(*dt);
                if let Some(msg) = msg {
                    server.handle(now, header, msg);
                }
                server.poll(now);
            }
        }));
        if outcome.is_err() {
            let last = &script[script.len().saturating_sub(3)..];
            panics.push(format!("case {case}, its last messages: {last:?}"));
            if panics.len() >= 3 {
                break;
            }
        }
    }
    assert!(panics.is_empty(), "panics:\n{}", panics.join("\n"));
}

/// A vehicle that answers every receive with a fuzzed message for a while,
/// then falls silent. Virtual time: a receive that times out advances the
/// clock by the whole timeout, a message arrives after part of it.
struct FuzzVehicle {
    rng: ChaCha8Rng,
    now: Duration,
    answers_left: u32,
    n_items: u16,
    recvs: u64,
}

impl FuzzVehicle {
    fn reply(&mut self) -> MavMessage {
        let rng = &mut self.rng;
        let gcs = (255, 190);
        let around = rng.random_range(0..=self.n_items);
        match rng.random_range(0..5) {
            0 | 1 => MavMessage::MISSION_REQUEST_INT(MISSION_REQUEST_INT_DATA {
                seq: small_or_any(rng, around),
                target_system: gcs.0,
                target_component: gcs.1,
                mission_type: mission_type(rng),
            }),
            2 => MavMessage::MISSION_ACK(MISSION_ACK_DATA {
                target_system: gcs.0,
                target_component: gcs.1,
                mavtype: [
                    MavMissionResult::MAV_MISSION_ACCEPTED,
                    MavMissionResult::MAV_MISSION_ERROR,
                    MavMissionResult::MAV_MISSION_NO_SPACE,
                    MavMissionResult::MAV_MISSION_INVALID_SEQUENCE,
                    MavMissionResult::MAV_MISSION_DENIED,
                    MavMissionResult::MAV_MISSION_UNSUPPORTED_FRAME,
                    MavMissionResult::MAV_MISSION_OPERATION_CANCELLED,
                ][rng.random_range(0..7)],
                mission_type: mission_type(rng),
                opaque_id: 0,
            }),
            3 => MavMessage::MISSION_COUNT(MISSION_COUNT_DATA {
                count: small_or_any(rng, self.n_items),
                target_system: gcs.0,
                target_component: gcs.1,
                mission_type: mission_type(rng),
                opaque_id: 0,
            }),
            _ => {
                let seq = small_or_any(rng, around);
                MavMessage::MISSION_ITEM_INT(item(seq, gcs))
            }
        }
    }
}

impl Link for FuzzVehicle {
    fn send(&mut self, _msg: &MavMessage) -> vp_mission::Result<()> {
        Ok(())
    }

    fn recv(&mut self, timeout: Duration) -> vp_mission::Result<Option<(MavHeader, MavMessage)>> {
        self.recvs += 1;
        if self.answers_left == 0 || self.rng.random_bool(0.2) {
            self.now += timeout;
            return Ok(None);
        }
        self.answers_left -= 1;
        self.now += timeout.mul_f64(self.rng.random::<f64>());
        let msg = self.reply();
        let Some(msg) = mutated(&mut self.rng, &msg) else {
            return Ok(None);
        };
        let header = MavHeader {
            system_id: if self.rng.random_bool(0.9) {
                1
            } else {
                self.rng.random()
            },
            component_id: if self.rng.random_bool(0.9) {
                1
            } else {
                self.rng.random()
            },
            sequence: self.rng.random(),
        };
        Ok(Some((header, msg)))
    }

    fn now(&self) -> Duration {
        self.now
    }
}

#[test]
fn ground_survives_fuzzed_vehicle_replies_and_gives_up_in_time() {
    let mut rng = ChaCha8Rng::seed_from_u64(22);
    let cfg = ProtocolConfig::default();
    let mut failures = Vec::new();
    for case in 0..cases() {
        let n_items: u16 = rng.random_range(1..12);
        let items: Vec<MissionItem> = (0..n_items)
            .map(|s| MissionItem::from_mavlink(&item(s, (1, 1))))
            .collect();
        let mut link = FuzzVehicle {
            rng: ChaCha8Rng::seed_from_u64(rng.random()),
            now: Duration::ZERO,
            answers_left: rng.random_range(0..300),
            n_items,
            recvs: 0,
        };
        let is_upload = rng.random_bool(0.5);
        let outcome = catch_unwind(AssertUnwindSafe(|| {
            if is_upload {
                upload(&mut link, TARGET, &items, &cfg, &mut |_| {}).map(drop)
            } else {
                download(&mut link, TARGET, &cfg, &mut |_| {}).map(drop)
            }
        }));
        let bound = if is_upload {
            cfg.deadline(items.len())
        } else {
            cfg.deadline(usize::from(u16::MAX))
        };
        let what = if is_upload { "upload" } else { "download" };
        match outcome {
            Err(_) => failures.push(format!("case {case}: {what} panicked")),
            Ok(_) if link.now > bound + cfg.timeout => failures.push(format!(
                "case {case}: {what} ran {:?}, past its deadline {bound:?}",
                link.now
            )),
            Ok(_) => {}
        }
        if failures.len() >= 3 {
            break;
        }
    }
    assert!(failures.is_empty(), "{}", failures.join("\n"));
}
