//! The whole path over real UDP sockets on loopback: mavlink connections,
//! heartbeat handshake, the vehicle-side server on its thread and the lossy
//! relay. Timeouts are scaled down (x0.02) so that loss costs milliseconds.

use std::time::{Duration, Instant};

use mavlink::dialects::common::MavMissionResult;
use vp_mission::sim_vehicle::{spawn_udp_vehicle, Impairment, UdpRelay, VehicleConfig};
use vp_mission::{
    build_mission, connect, download, upload, upload_over, Autopilot, ConnectOptions, Mission,
    MissionError, MissionOptions, ProtocolConfig,
};
use vp_test_support::plans;

const SCALE: f64 = 0.02;

fn mission(n_views: usize, seed: u64) -> Mission {
    let p = plans::scattered_plan(n_views, seed, 7, false);
    build_mission(&p, &MissionOptions::for_autopilot(Autopilot::Px4)).unwrap()
}

fn fast_vehicle() -> VehicleConfig {
    VehicleConfig {
        item_timeout: Duration::from_millis(250).mul_f64(SCALE),
        // Not scaled: a vehicle that gave up after 100 ms without progress
        // failed an upload when the test machine stalled (three attempts
        // cancelled under load); real autopilots wait seconds, and the ground
        // side's own timeouts stay scaled.
        protocol_timeout: Duration::from_secs(1),
        heartbeat: Some(Duration::from_millis(50)),
        ..VehicleConfig::default()
    }
}

fn fast_opts() -> ConnectOptions {
    ConnectOptions {
        heartbeat_timeout: Duration::from_secs(5),
        target_system: None,
        protocol: ProtocolConfig::default().scaled(SCALE),
        signing: None,
        home_check: None,
    }
}

#[test]
fn upload_then_download_identical_over_udp() {
    let v = spawn_udp_vehicle("127.0.0.1:0", fast_vehicle()).unwrap();
    let url = format!("udpout:{}", v.addr());
    let m = mission(6, 1);
    let (r, info) = upload(&url, &m, &fast_opts(), &mut |_| {}).unwrap();
    assert!(r.verified && r.upload.ack_received);
    assert_eq!(info.autopilot_family(), Some(Autopilot::Px4));
    assert_eq!(v.mission(), m.items);
    let (items, _, _) = download(&url, &fast_opts(), &mut |_| {}).unwrap();
    assert_eq!(items, m.items);
}

fn lossy_uploads(n: usize) {
    let v = spawn_udp_vehicle("127.0.0.1:0", fast_vehicle()).unwrap();
    let imp = Impairment {
        drop: 0.2,
        duplicate: 0.1,
        reorder: 0.1,
    };
    let relay = UdpRelay::spawn(v.addr(), imp, 2024).unwrap();
    let (mut link, info) = connect(&format!("udpout:{}", relay.addr()), &fast_opts()).unwrap();
    let cfg = ProtocolConfig::default().scaled(SCALE);
    let (mut times, mut resends, mut restarts) = (Vec::new(), 0, 0);
    for k in 0..n {
        let m = mission(8, k as u64);
        let t0 = Instant::now();
        let r = upload_over(&mut link, info.target, &m, &cfg, true, &mut |_| {})
            .unwrap_or_else(|e| panic!("upload {k} of {n}: {e}"));
        let dt = t0.elapsed();
        assert!(r.verified);
        assert_eq!(v.mission(), m.items, "upload {k}");
        // The protocol enforces this bound itself (it gives up past it).
        assert!(dt <= cfg.deadline(m.items.len()) * 2, "upload {k}: {dt:?}");
        times.push(dt.as_secs_f64() * 1e3);
        resends += r.upload.resends + r.verify.map_or(0, |d| d.resends);
        restarts += r.upload.attempts - 1;
    }
    let mean = times.iter().sum::<f64>() / times.len() as f64;
    let max = times.iter().copied().fold(0.0, f64::max);
    println!(
        "UDP relay, {n} of {n} uploads+verify of 27 items verified at 20% drop, 10% dup, 10% reorder \
         (timeouts x{SCALE}): mean {mean:.0} ms, max {max:.0} ms, ground resends {resends}, \
         restarted uploads {restarts}, relay {:?}",
        relay.counts()
    );
    let c = relay.counts();
    assert!(c.dropped > 0 && c.duplicated > 0 && c.reordered > 0);
}

#[test]
fn lossy_relay_20_uploads_verified() {
    lossy_uploads(20);
}

#[test]
#[ignore = "about 20-30 s; run with --ignored (CI long step)"]
fn lossy_relay_100_uploads_verified() {
    lossy_uploads(100);
}

#[test]
fn no_vehicle_is_a_clear_timeout() {
    // A bound port that never answers.
    let silent = std::net::UdpSocket::bind("127.0.0.1:0").unwrap();
    let url = format!("udpout:{}", silent.local_addr().unwrap());
    let opts = ConnectOptions {
        heartbeat_timeout: Duration::from_millis(300),
        ..fast_opts()
    };
    let t0 = Instant::now();
    let e = upload(&url, &mission(2, 0), &opts, &mut |_| {}).unwrap_err();
    assert!(matches!(e, MissionError::NoVehicle { .. }), "{e}");
    let msg = e.to_string();
    assert!(
        msg.contains(&url) && msg.contains("no vehicle answered"),
        "{msg}"
    );
    assert!(t0.elapsed() < Duration::from_secs(5));
}

#[test]
fn rejecting_vehicle_is_reported_by_name_over_udp() {
    let v = spawn_udp_vehicle(
        "127.0.0.1:0",
        VehicleConfig {
            reject_with: Some(MavMissionResult::MAV_MISSION_NO_SPACE),
            ..fast_vehicle()
        },
    )
    .unwrap();
    let e = upload(
        &format!("udpout:{}", v.addr()),
        &mission(3, 0),
        &fast_opts(),
        &mut |_| {},
    )
    .unwrap_err();
    assert!(e.to_string().contains("MAV_MISSION_NO_SPACE"), "{e}");
}

#[test]
fn mission_for_the_wrong_autopilot_is_refused() {
    let v = spawn_udp_vehicle(
        "127.0.0.1:0",
        VehicleConfig {
            autopilot: Autopilot::ArduPilot,
            ..fast_vehicle()
        },
    )
    .unwrap();
    let e = upload(
        &format!("udpout:{}", v.addr()),
        &mission(2, 0),
        &fast_opts(),
        &mut |_| {},
    )
    .unwrap_err();
    assert!(e.to_string().contains("built for Px4"), "{e}");
    assert!(v.mission().is_empty(), "nothing was uploaded");
}

#[test]
fn bad_url_names_the_problem() {
    let e = upload(
        "carrier-pigeon:1",
        &mission(1, 0),
        &fast_opts(),
        &mut |_| {},
    )
    .unwrap_err();
    assert!(e.to_string().contains("unknown transport"), "{e}");
    let e = upload("udpout:nohost", &mission(1, 0), &fast_opts(), &mut |_| {}).unwrap_err();
    assert!(matches!(e, MissionError::BadUrl { .. }), "{e}");
}
