//! Mission fault injection, in virtual time on the simulated vehicle: a
//! vehicle that reboots mid-upload, rejections, a link silent for 10 s,
//! duplicated and stale ACKs, items re-requested out of order, a second
//! ground station. Each case ends in one clear outcome: verified (the
//! read-back equals the upload) or an error with its own exit code
//! ([`MissionError::exit_code`]). Plus 1000 uploads at 20 % and 30 % loss
//! with the distribution of their times.

use std::time::Duration;

use mavlink::dialects::common::{
    MavMessage, MavMissionResult, MavMissionType, MISSION_ACK_DATA, MISSION_CLEAR_ALL_DATA,
    MISSION_COUNT_DATA, MISSION_REQUEST_INT_DATA,
};
use mavlink::MavHeader;
use vp_mission::protocol::{ProtocolConfig, Target};
use vp_mission::sim_vehicle::{Impairment, MissionServer, SimLink, VehicleConfig};
use vp_mission::{
    build_mission, upload_over, Autopilot, Link, Mission, MissionError, MissionOptions,
    TransferReport,
};
use vp_test_support::plans;

const TARGET: Target = Target {
    system: 1,
    component: 1,
};

fn mission(n_views: usize, seed: u64) -> Mission {
    let p = plans::scattered_plan(n_views, seed, 1, true);
    build_mission(&p, &MissionOptions::for_autopilot(Autopilot::Px4)).unwrap()
}

fn vehicle(reject_with: Option<MavMissionResult>) -> MissionServer {
    MissionServer::new(VehicleConfig {
        heartbeat: None,
        reject_with,
        ..VehicleConfig::default()
    })
}

/// What a fault does, decided on each message the ground sends or receives.
#[derive(Clone, Copy)]
enum Fault {
    /// After the ground has sent `after` items, the vehicle reboots: its
    /// state is lost and it is deaf and mute for `gap` (heartbeat gap).
    Reboot { after: u32, gap: Duration },
    /// From the `after`-th item on, nothing passes either way for `gap`.
    Silence { after: u32, gap: Duration },
    /// Every request the vehicle sends comes with a stale ACCEPTED ACK and
    /// a stale NO_SPACE ACK of another mission type, every third with a
    /// duplicate. (Duplicating every request makes the exchange grow
    /// exponentially: the ground answers both copies, the simulated vehicle
    /// re-requests on the duplicate item, and so on; a known gap.)
    StaleAcks,
    /// Every request the vehicle sends is followed by a request for an
    /// earlier item (out of order, already served).
    OutOfOrder,
    /// After the ground has sent `after` items, a second ground station
    /// (system 254) starts its own upload of `count` items.
    SecondGcsUpload { after: u32, count: u16 },
    /// Right after the vehicle ACKs the upload, a second ground station
    /// clears the mission (before our read-back).
    SecondGcsClear,
}

struct FaultyLink {
    sim: SimLink,
    fault: Fault,
    items_sent: u32,
    /// Nothing passes before this time (a reboot or a silent link).
    dead_until: Duration,
    fired: bool,
    injected: Vec<(MavHeader, MavMessage)>,
}

impl FaultyLink {
    fn new(fault: Fault, vehicle: MissionServer, seed: u64) -> Self {
        FaultyLink {
            sim: SimLink::new(vehicle, Impairment::default(), seed),
            fault,
            items_sent: 0,
            dead_until: Duration::ZERO,
            fired: false,
            injected: Vec::new(),
        }
    }

    fn other_gcs(&mut self, msg: &MavMessage) {
        let h = MavHeader {
            system_id: 254,
            component_id: 190,
            sequence: 0,
        };
        let now = self.sim.now();
        // Its replies go to system 254, not to us: dropped here.
        let _ = self.sim.vehicle.handle(now, &h, msg);
    }
}

impl Link for FaultyLink {
    fn send(&mut self, msg: &MavMessage) -> vp_mission::Result<()> {
        if matches!(msg, MavMessage::MISSION_ITEM_INT(_)) {
            self.items_sent += 1;
        }
        let now = self.sim.now();
        match self.fault {
            Fault::Reboot { after, gap } if !self.fired && self.items_sent >= after => {
                self.fired = true;
                self.sim.vehicle = vehicle(None);
                self.dead_until = now + gap;
            }
            Fault::Silence { after, gap } if !self.fired && self.items_sent >= after => {
                self.fired = true;
                self.dead_until = now + gap;
            }
            Fault::SecondGcsUpload { after, count } if !self.fired && self.items_sent >= after => {
                self.fired = true;
                self.other_gcs(&MavMessage::MISSION_COUNT(MISSION_COUNT_DATA {
                    count,
                    target_system: 1,
                    target_component: 1,
                    mission_type: MavMissionType::MAV_MISSION_TYPE_MISSION,
                    opaque_id: 0,
                }));
            }
            _ => {}
        }
        if now < self.dead_until {
            return Ok(());
        }
        self.sim.send(msg)
    }

    fn recv(&mut self, timeout: Duration) -> vp_mission::Result<Option<(MavHeader, MavMessage)>> {
        if let Some(m) = self.injected.pop() {
            return Ok(Some(m));
        }
        let end = self.sim.now() + timeout;
        loop {
            let left = end.saturating_sub(self.sim.now());
            let Some((h, msg)) = self.sim.recv(left)? else {
                return Ok(None);
            };
            if self.sim.now() < self.dead_until {
                continue;
            }
            let header = h;
            match (&msg, self.fault) {
                (MavMessage::MISSION_REQUEST_INT(r), Fault::StaleAcks) => {
                    let ack = |mavtype, mission_type| {
                        MavMessage::MISSION_ACK(MISSION_ACK_DATA {
                            target_system: 255,
                            target_component: 190,
                            mavtype,
                            mission_type,
                            opaque_id: 0,
                        })
                    };
                    if r.seq % 3 == 0 {
                        self.injected.push((header, msg.clone()));
                    }
                    self.injected.push((
                        header,
                        ack(
                            MavMissionResult::MAV_MISSION_NO_SPACE,
                            MavMissionType::MAV_MISSION_TYPE_FENCE,
                        ),
                    ));
                    if r.seq > 0 {
                        self.injected.push((
                            header,
                            ack(
                                MavMissionResult::MAV_MISSION_ACCEPTED,
                                MavMissionType::MAV_MISSION_TYPE_MISSION,
                            ),
                        ));
                    }
                }
                (MavMessage::MISSION_REQUEST_INT(r), Fault::OutOfOrder) if r.seq > 1 => {
                    self.injected.push((
                        header,
                        MavMessage::MISSION_REQUEST_INT(MISSION_REQUEST_INT_DATA {
                            seq: (r.seq * 7 + 3) % r.seq,
                            ..r.clone()
                        }),
                    ));
                }
                (MavMessage::MISSION_ACK(a), Fault::SecondGcsClear)
                    if !self.fired && a.mavtype == MavMissionResult::MAV_MISSION_ACCEPTED =>
                {
                    self.fired = true;
                    self.other_gcs(&MavMessage::MISSION_CLEAR_ALL(MISSION_CLEAR_ALL_DATA {
                        target_system: 1,
                        target_component: 1,
                        mission_type: MavMissionType::MAV_MISSION_TYPE_MISSION,
                    }));
                }
                _ => {}
            }
            return Ok(Some((header, msg)));
        }
    }

    fn now(&self) -> Duration {
        self.sim.now()
    }
}

/// Runs one upload with verification under `fault`; returns the outcome
/// and the vehicle's mission after it.
fn run(
    fault: Fault,
    reject_with: Option<MavMissionResult>,
) -> (Result<TransferReport, MissionError>, Mission, FaultyLink) {
    let m = mission(10, 3);
    let mut link = FaultyLink::new(fault, vehicle(reject_with), 5);
    let cfg = ProtocolConfig::default();
    let r = upload_over(&mut link, TARGET, &m, &cfg, true, &mut |_| {});
    assert!(
        link.now() <= cfg.deadline(m.items.len()) * 2,
        "took {:?}",
        link.now()
    );
    (r, m, link)
}

/// A verified outcome: the read-back equals the upload, and the vehicle
/// holds it.
fn assert_verified(r: &Result<TransferReport, MissionError>, m: &Mission, link: &FaultyLink) {
    let r = r.as_ref().unwrap_or_else(|e| panic!("not verified: {e}"));
    assert!(r.verified);
    assert_eq!(link.sim.vehicle.mission(), &m.items[..]);
}

#[test]
fn vehicle_reboot_mid_upload_restarts_the_upload_and_verifies() {
    let (r, m, link) = run(
        Fault::Reboot {
            after: 5,
            gap: Duration::from_secs(3),
        },
        None,
    );
    assert_verified(&r, &m, &link);
    let r = r.unwrap();
    assert!(r.upload.attempts >= 2, "{:?}", r.upload);
    println!(
        "reboot after 5 items: verified after {} attempts, {:.1} s",
        r.upload.attempts,
        link.now().as_secs_f64()
    );
}

#[test]
fn each_rejection_is_named_with_exit_code_5() {
    for result in [
        MavMissionResult::MAV_MISSION_DENIED,
        MavMissionResult::MAV_MISSION_NO_SPACE,
        MavMissionResult::MAV_MISSION_INVALID_SEQUENCE,
        MavMissionResult::MAV_MISSION_UNSUPPORTED_FRAME,
    ] {
        let (r, _, link) = run(Fault::StaleAcks, Some(result));
        let e = r.unwrap_err();
        let name = format!("{result:?}");
        assert!(
            matches!(e.root(), MissionError::Rejected { result: got, .. } if *got == name),
            "{e}"
        );
        assert!(e.to_string().contains(&name), "{e}");
        assert_eq!(e.exit_code(), 5);
        assert!(link.sim.vehicle.mission().is_empty());
        println!("{name}: '{e}', exit code 5");
    }
}

#[test]
fn link_silent_for_10_s_then_back_verifies() {
    let (r, m, link) = run(
        Fault::Silence {
            after: 4,
            gap: Duration::from_secs(10),
        },
        None,
    );
    assert_verified(&r, &m, &link);
    println!(
        "10 s of silence: verified, {:.1} s in all, {} attempts",
        link.now().as_secs_f64(),
        r.unwrap().upload.attempts
    );
}

#[test]
fn link_silent_for_good_is_a_timeout_with_exit_code_4() {
    let (r, _, _) = run(
        Fault::Silence {
            after: 4,
            gap: Duration::from_secs(100_000),
        },
        None,
    );
    let e = r.unwrap_err();
    assert!(matches!(e.root(), MissionError::Timeout { .. }), "{e}");
    assert_eq!(e.exit_code(), 4);
}

#[test]
fn duplicated_and_stale_acks_are_ignored_and_the_upload_verifies() {
    let (r, m, link) = run(Fault::StaleAcks, None);
    assert_verified(&r, &m, &link);
    let r = r.unwrap();
    assert!(r.upload.ignored >= 9, "{:?}", r.upload);
    assert_eq!(r.upload.attempts, 1);
}

#[test]
fn items_re_requested_out_of_order_are_served_and_verify() {
    let (r, m, link) = run(Fault::OutOfOrder, None);
    assert_verified(&r, &m, &link);
    let r = r.unwrap();
    // Each stale request names an item sent a few ms before: within the
    // duplicate window it is a copy and left unanswered (a vehicle that
    // really lost the item asks again after its own timeout); later, it
    // is served again. Either way the upload verifies in one attempt.
    assert!(
        r.upload.repeated_requests + r.upload.duplicate_requests >= 5,
        "{:?}",
        r.upload
    );
    assert_eq!(r.upload.attempts, 1);
}

#[test]
fn second_ground_station_uploading_mid_transfer_never_reports_verified_wrongly() {
    // The other station's MISSION_COUNT restarts the vehicle's transfer; our
    // ground serves the requests it sees until the read-back decides.
    for (after, count) in [(3, 4), (5, 12), (2, 10)] {
        let (r, m, link) = run(Fault::SecondGcsUpload { after, count }, None);
        match &r {
            Ok(t) => {
                assert!(t.verified);
                assert_eq!(link.sim.vehicle.mission(), &m.items[..]);
                println!("second GCS COUNT {count} after {after} items: verified");
            }
            Err(e) => {
                assert_ne!(link.sim.vehicle.mission(), &m.items[..]);
                assert!(e.exit_code() >= 3, "{e}");
                println!(
                    "second GCS COUNT {count} after {after} items: exit {}: {e}",
                    e.exit_code()
                );
            }
        }
    }
}

#[test]
fn second_ground_station_clearing_before_the_read_back_fails_verification() {
    let (r, _, link) = run(Fault::SecondGcsClear, None);
    let e = r.unwrap_err();
    assert!(matches!(e, MissionError::VerifyMismatch { .. }), "{e}");
    assert_eq!(e.exit_code(), 6);
    assert!(link.sim.vehicle.mission().is_empty());
}

fn percentile(sorted: &[f64], p: f64) -> f64 {
    sorted[((sorted.len() - 1) as f64 * p).round() as usize]
}

fn lossy_uploads(drop: f64, n: usize) -> Vec<f64> {
    let imp = Impairment {
        drop,
        duplicate: 0.05,
        reorder: 0.05,
    };
    let cfg = ProtocolConfig::default();
    let mut link = SimLink::new(vehicle(None), imp, 1000 + (drop * 100.0) as u64);
    let mut times = Vec::new();
    let mut failed = Vec::new();
    let (mut fewest, mut most) = (usize::MAX, 0);
    for k in 0..n {
        let m = mission(8 + k % 8, k as u64);
        fewest = fewest.min(m.items.len());
        most = most.max(m.items.len());
        let t0 = link.now();
        match upload_over(&mut link, TARGET, &m, &cfg, true, &mut |_| {}) {
            Ok(r) => {
                assert!(r.verified);
                assert_eq!(link.vehicle.mission(), &m.items[..]);
                times.push(link.now().saturating_sub(t0).as_secs_f64());
            }
            Err(e) => failed.push(format!("upload {k}: exit {}: {e}", e.exit_code())),
        }
    }
    times.sort_by(f64::total_cmp);
    println!(
        "{n} uploads+verify of {fewest}-{most} items at {:.0} % loss each way: {} verified, \
         {} failed; virtual time p50 {:.1} s, p90 {:.1} s, p99 {:.1} s, max {:.1} s",
        drop * 100.0,
        times.len(),
        failed.len(),
        percentile(&times, 0.5),
        percentile(&times, 0.9),
        percentile(&times, 0.99),
        times.last().copied().unwrap_or(0.0),
    );
    for f in &failed {
        println!("  {f}");
    }
    assert!(failed.is_empty(), "{} of {n} failed", failed.len());
    times
}

#[test]
fn thousand_uploads_at_20_percent_loss_all_verify() {
    lossy_uploads(0.2, 1000);
}

#[test]
fn thousand_uploads_at_30_percent_loss_all_verify() {
    lossy_uploads(0.3, 1000);
}
