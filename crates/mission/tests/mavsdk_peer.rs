//! Against an independent implementation: MAVSDK (PyPI `mavsdk` >= 4) as
//! the vehicle (MissionRawServer) and as a QGC `.plan` importer.
//!
//! Needs a Python with `mavsdk` installed: set `VP_MAVSDK_PYTHON` to its
//! interpreter (e.g. a venv's `bin/python`). Without it the tests print why
//! they did not run and pass; set `VP_REQUIRE_MAVSDK=1` (CI) to make a
//! missing MAVSDK a failure instead.

use std::io::{BufRead, BufReader};
use std::path::PathBuf;
use std::process::{Child, Command, Stdio};
use std::time::Duration;

use serde_json::Value;
use vp_mission::{
    build_mission, connect, qgc, upload_over, Autopilot, ConnectOptions, Mission, MissionOptions,
    ProtocolConfig,
};
use vp_scene::plan::Plan;
use vp_test_support::mission_json::items_from_json;
use vp_test_support::plans;
use vp_test_support::python::mavsdk_python;

fn script() -> PathBuf {
    PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("tests/mavsdk/mavsdk_peer.py")
}

fn plan() -> Plan {
    let mut p = plans::plan_at(plans::ZURICH);
    for i in 0..5 {
        let k = f64::from(i);
        p.waypoints.push(plans::photo(
            [k * 15.0, 10.0 - k * 3.0, 35.0 + k],
            k * 70.0,
            -20.0 - k * 10.0,
            Some(i as u32 / 3),
        ));
    }
    p.geofence = Some(vec![[-200.0, -200.0], [200.0, -200.0], [200.0, 200.0]]);
    p
}

fn mission() -> Mission {
    let mut opts = MissionOptions::for_autopilot(Autopilot::Px4);
    opts.speed_m_s = Some(5.0);
    build_mission(&plan(), &opts).unwrap()
}

struct Peer(Child);

impl Drop for Peer {
    fn drop(&mut self) {
        let _ = self.0.kill();
        let _ = self.0.wait();
    }
}

#[test]
fn upload_to_mavsdk_mission_raw_server() {
    let Some(py) = mavsdk_python() else {
        return;
    };
    let port = std::net::UdpSocket::bind("127.0.0.1:0")
        .unwrap()
        .local_addr()
        .unwrap()
        .port();
    let mut child = Peer(
        Command::new(&py)
            .arg(script())
            .args(["vehicle", &port.to_string(), "20", "0.5"])
            .stdout(Stdio::piped())
            .stderr(Stdio::null())
            .spawn()
            .unwrap(),
    );
    let mut out = BufReader::new(child.0.stdout.take().unwrap()).lines();
    assert_eq!(out.next().unwrap().unwrap(), "READY");

    let m = mission();
    let opts = ConnectOptions {
        heartbeat_timeout: Duration::from_secs(10),
        ..ConnectOptions::default()
    };
    let (mut link, info) = connect(&format!("udpout:127.0.0.1:{port}"), &opts).unwrap();
    let cfg = ProtocolConfig::default();
    let report = upload_over(&mut link, info.target, &m, &cfg, true, &mut |_| {}).unwrap();
    assert!(
        report.upload.ack_received && report.verified,
        "read back from MAVSDK and compared"
    );
    let line = out.next().unwrap().unwrap();
    let v: Value = serde_json::from_str(&line).unwrap();
    assert_eq!(v["result"], "SUCCESS", "{line}");
    let got = items_from_json(&v["items"]);
    vp_mission::compare_items(&m.items, &got, Autopilot::Px4).unwrap();
    println!(
        "MAVSDK MissionRawServer accepted {} items in {:?} ({} resends)",
        got.len(),
        report.upload.elapsed,
        report.upload.resends
    );
}

#[test]
fn mavsdk_imports_the_qgc_plan() {
    let Some(py) = mavsdk_python() else {
        return;
    };
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("mission.plan");
    let text = qgc::export_qgc(
        &plan(),
        &MissionOptions::for_autopilot(Autopilot::Px4),
        &qgc::QgcOptions::default(),
    )
    .unwrap();
    std::fs::write(&path, &text).unwrap();
    let out = Command::new(&py)
        .arg(script())
        .arg("import")
        .arg(&path)
        .stderr(Stdio::null())
        .output()
        .unwrap();
    let stdout = String::from_utf8_lossy(&out.stdout);
    assert!(out.status.success(), "importer failed: {stdout}");
    let line = stdout.lines().last().unwrap();
    let v: Value = serde_json::from_str(line).unwrap();
    let got = items_from_json(&v["items"]);
    let m = build_mission(&plan(), &MissionOptions::for_autopilot(Autopilot::Px4)).unwrap();
    // MAVSDK adds nothing and drops nothing: same commands, positions, params.
    vp_mission::compare_items(&m.items, &got, Autopilot::Px4).unwrap();
    println!("MAVSDK imported {} items from the .plan", got.len());
}
