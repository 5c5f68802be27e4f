//! The mission protocol against the simulated vehicle in virtual time:
//! exact, seeded and fast (no sleeping, no sockets).

use std::time::Duration;

use mavlink::dialects::common::MavMissionResult;
use vp_mission::protocol::{self, ProtocolConfig, Target};
use vp_mission::sim_vehicle::{ardupilot, Impairment, MissionServer, SimLink, VehicleConfig};
use vp_mission::{
    build_mission, upload_over, Autopilot, Link, Mission, MissionError, MissionOptions,
};
use vp_test_support::plans;

const TARGET: Target = Target {
    system: 1,
    component: 1,
};

/// Uploads `m` with the default protocol settings and reads it back.
fn upload_verified(
    link: &mut SimLink,
    m: &Mission,
) -> Result<vp_mission::TransferReport, MissionError> {
    upload_over(
        link,
        TARGET,
        m,
        &ProtocolConfig::default(),
        true,
        &mut |_| {},
    )
}

fn mission(n_views: usize, autopilot: Autopilot, seed: u64) -> Mission {
    let p = plans::scattered_plan(n_views, seed, 1, true);
    let mut opts = MissionOptions::for_autopilot(autopilot);
    opts.speed_m_s = Some(4.0);
    build_mission(&p, &opts).unwrap()
}

fn vehicle(autopilot: Autopilot) -> MissionServer {
    MissionServer::new(VehicleConfig {
        autopilot,
        heartbeat: None,
        ..VehicleConfig::default()
    })
}

#[test]
fn upload_download_identical_without_loss() {
    let m = mission(12, Autopilot::Px4, 0);
    let mut link = SimLink::new(vehicle(Autopilot::Px4), Impairment::default(), 1);
    let cfg = ProtocolConfig::default();
    let mut events = 0;
    let r = upload_over(&mut link, TARGET, &m, &cfg, true, &mut |_| events += 1).unwrap();
    assert!(r.verified && r.upload.ack_received);
    assert_eq!(r.upload.attempts, 1);
    assert_eq!(r.upload.resends, 0);
    assert_eq!(
        link.vehicle.mission(),
        &m.items[..],
        "bit-identical on the vehicle"
    );
    assert_eq!(events, 2 * m.items.len());
    let (got, _) = protocol::download(&mut link, TARGET, &cfg, &mut |_| {}).unwrap();
    assert_eq!(got, m.items);
}

#[test]
fn lossy_link_100_of_100_uploads_verified() {
    // 20 % loss in each direction, 10 % duplicates, 10 % reordered.
    let imp = Impairment {
        drop: 0.2,
        duplicate: 0.1,
        reorder: 0.1,
    };
    let cfg = ProtocolConfig::default();
    let mut link = SimLink::new(vehicle(Autopilot::Px4), imp, 42);
    let mut times = Vec::new();
    let (mut resends, mut attempts_over_1, mut repeated) = (0, 0, 0);
    for k in 0..100 {
        let m = mission(8 + k % 8, Autopilot::Px4, k as u64);
        let t0 = link.now();
        let r = upload_over(&mut link, TARGET, &m, &cfg, true, &mut |_| {})
            .unwrap_or_else(|e| panic!("upload {k}: {e}"));
        let dt = link.now().saturating_sub(t0);
        assert!(r.verified);
        assert!(
            dt <= cfg.deadline(m.items.len()) * 2,
            "upload {k} took {dt:?}, beyond the bound"
        );
        assert_eq!(link.vehicle.mission(), &m.items[..]);
        times.push(dt.as_secs_f64());
        resends += r.upload.resends + r.verify.as_ref().map_or(0, |v| v.resends);
        repeated += r.upload.repeated_requests;
        attempts_over_1 += u32::from(r.upload.attempts > 1);
    }
    let mean = times.iter().sum::<f64>() / times.len() as f64;
    let max = times.iter().copied().fold(0.0, f64::max);
    println!(
        "virtual time, 100 uploads+verify of 27-48 items at 20% drop: mean {mean:.2} s, max {max:.2} s, \
         ground resends {resends}, repeated vehicle requests {repeated}, restarted uploads {attempts_over_1}, \
         link {:?}",
        link.counts
    );
    assert!(
        link.counts.dropped > 1000 && link.counts.duplicated > 300 && link.counts.reordered > 300
    );
}

#[test]
fn same_seed_same_run() {
    let imp = Impairment {
        drop: 0.2,
        duplicate: 0.1,
        reorder: 0.1,
    };
    let run = || {
        let m = mission(10, Autopilot::Px4, 3);
        let mut link = SimLink::new(vehicle(Autopilot::Px4), imp, 7);
        let r = upload_verified(&mut link, &m).unwrap();
        (r, link.counts, link.now())
    };
    assert_eq!(run(), run());
}

#[test]
fn ardupilot_home_at_seq_0_is_rewritten_and_verify_passes() {
    let m = mission(5, Autopilot::ArduPilot, 0);
    let mut link = SimLink::new(vehicle(Autopilot::ArduPilot), Impairment::default(), 1);
    let r = upload_verified(&mut link, &m).unwrap();
    assert!(r.verified);
    let stored = link.vehicle.mission();
    assert_ne!(
        stored[0], m.items[0],
        "the vehicle keeps its own home at seq 0"
    );
    // The rest as ArduPilot stores it (whole centimetres, the waypoint's
    // hold only, ...), which verification accepts.
    let kept: Vec<_> = m.items[1..].iter().map(ardupilot::stored).collect();
    assert_eq!(&stored[1..], &kept[..]);
}

#[test]
fn rejection_is_reported_by_name() {
    let m = mission(5, Autopilot::Px4, 0);
    let v = MissionServer::new(VehicleConfig {
        capacity: 4,
        heartbeat: None,
        ..VehicleConfig::default()
    });
    let mut link = SimLink::new(v, Impairment::default(), 1);
    let e = upload_verified(&mut link, &m).unwrap_err();
    assert!(matches!(e.root(), MissionError::Rejected { .. }));
    assert!(e.to_string().contains("MAV_MISSION_NO_SPACE"), "{e}");
    // Permanent: not retried (a retry waits 1.5 s); answered at once, then
    // one item timeout (250 ms) listening for the vehicle's own words.
    assert!(link.now() < Duration::from_millis(300), "{:?}", link.now());

    let v = MissionServer::new(VehicleConfig {
        reject_with: Some(MavMissionResult::MAV_MISSION_DENIED),
        heartbeat: None,
        ..VehicleConfig::default()
    });
    let mut link = SimLink::new(v, Impairment::default(), 1);
    let e = upload_verified(&mut link, &m).unwrap_err();
    assert!(e.to_string().contains("MAV_MISSION_DENIED"), "{e}");
}

#[test]
fn silent_vehicle_times_out_within_the_bound() {
    let m = mission(3, Autopilot::Px4, 0);
    let imp = Impairment {
        drop: 1.0,
        ..Impairment::default()
    };
    let cfg = ProtocolConfig::default();
    let mut link = SimLink::new(vehicle(Autopilot::Px4), imp, 1);
    let e = upload_over(&mut link, TARGET, &m, &cfg, true, &mut |_| {}).unwrap_err();
    assert!(matches!(e.root(), MissionError::Timeout { .. }), "{e}");
    assert!(e.to_string().contains("MISSION_COUNT"), "{e}");
    // 3 attempts x 6 sends x 1.5 s = 27 s, within the deadline.
    let t = link.now();
    assert!(
        t >= Duration::from_secs(27) && t <= cfg.deadline(m.items.len()),
        "{t:?}"
    );
}

#[test]
fn legacy_mission_request_is_answered_with_item_int() {
    let m = mission(4, Autopilot::Px4, 0);
    let v = MissionServer::new(VehicleConfig {
        legacy_requests: true,
        heartbeat: None,
        ..VehicleConfig::default()
    });
    let mut link = SimLink::new(v, Impairment::default(), 1);
    let r = upload_verified(&mut link, &m).unwrap();
    assert!(r.verified);
    assert_eq!(link.vehicle.mission(), &m.items[..]);
}

#[test]
fn clear_empties_the_vehicle() {
    let m = mission(4, Autopilot::Px4, 0);
    let mut link = SimLink::new(vehicle(Autopilot::Px4), Impairment::default(), 1);
    upload_over(
        &mut link,
        TARGET,
        &m,
        &ProtocolConfig::default(),
        false,
        &mut |_| {},
    )
    .unwrap();
    protocol::clear(&mut link, TARGET, &ProtocolConfig::default()).unwrap();
    assert!(link.vehicle.mission().is_empty());
    let (got, _) =
        protocol::download(&mut link, TARGET, &ProtocolConfig::default(), &mut |_| {}).unwrap();
    assert!(got.is_empty());
}
