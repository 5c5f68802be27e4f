//! MAVLink 2 signing against an independent implementation: pymavlink
//! (the signing code of MAVProxy), as a vehicle for our ground side and as
//! a ground station for our simulated vehicle. Each side checks the other's
//! SHA-256 signatures and timestamps with its own code.
//!
//! Needs a Python with pymavlink (`crates/mission/tests/pymavlink/
//! requirements.txt`): `VP_PYMAVLINK_PYTHON`, else the workspace's
//! `.venv/bin/python` (which `scripts/test.sh` fills), else `python3`. A
//! missing pymavlink fails these tests: they do not skip.

use std::io::{BufRead, BufReader, Lines, Write};
use std::path::{Path, PathBuf};
use std::process::{Child, ChildStdin, ChildStdout, Command, Stdio};
use std::time::Duration;

use serde_json::Value;
use vp_mission::sim_vehicle::{spawn_udp_vehicle, VehicleConfig};
use vp_mission::{
    build_mission, upload, Autopilot, ConnectOptions, Mission, MissionError, MissionOptions,
    ProtocolConfig, SigningKey,
};
use vp_test_support::mission_json::items_from_json;
use vp_test_support::plans;

const KEY: &str = "5f0c1e7a9b3d2c4e6f8a1b3c5d7e9f0a2b4c6d8e0f1a3b5c7d9e1f2a4b6c8d0e";
const OTHER_KEY: &str = "0000000000000000000000000000000000000000000000000000000000000001";

fn python() -> String {
    vp_test_support::python::pymavlink_python()
}

fn script() -> PathBuf {
    PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("tests/pymavlink/pymavlink_peer.py")
}

fn key_file(dir: &Path, name: &str, hex: &str) -> PathBuf {
    let p = dir.join(name);
    std::fs::write(&p, format!("{hex}\n")).unwrap();
    p
}

fn free_port() -> u16 {
    std::net::UdpSocket::bind("127.0.0.1:0")
        .unwrap()
        .local_addr()
        .unwrap()
        .port()
}

fn mission() -> Mission {
    let mut p = plans::plan_at(plans::ZURICH);
    for i in 0..3 {
        let k = f64::from(i);
        p.waypoints.push(plans::photo(
            [k * 12.0, 4.0 - k, 30.0 + k],
            k * 50.0,
            -25.0,
            Some(0),
        ));
    }
    build_mission(&p, &MissionOptions::for_autopilot(Autopilot::Px4)).unwrap()
}

/// Protocol timeouts at a fifth of the spec's (the peer is on loopback);
/// the heartbeat wait long enough for Python to start.
fn opts(key: Option<&str>) -> ConnectOptions {
    ConnectOptions {
        heartbeat_timeout: Duration::from_secs(3),
        protocol: ProtocolConfig::default().scaled(0.2),
        signing: key.map(|k| SigningKey::from_hex(k).unwrap()),
        ..ConnectOptions::default()
    }
}

/// The pymavlink vehicle, killed when dropped.
struct PyVehicle {
    child: Child,
    stdin: ChildStdin,
    stdout: Lines<BufReader<ChildStdout>>,
    port: u16,
}

impl PyVehicle {
    fn spawn(key: Option<&Path>) -> Self {
        let port = free_port();
        let mut child = Command::new(python())
            .arg(script())
            .args(["vehicle", &port.to_string()])
            .arg(key.map_or_else(|| "-".into(), |k| k.as_os_str().to_owned()))
            .stdin(Stdio::piped())
            .stdout(Stdio::piped())
            .spawn()
            .unwrap();
        let stdin = child.stdin.take().unwrap();
        let mut stdout = BufReader::new(child.stdout.take().unwrap()).lines();
        assert_eq!(stdout.next().unwrap().unwrap(), "READY");
        PyVehicle {
            child,
            stdin,
            stdout,
            port,
        }
    }

    fn url(&self) -> String {
        format!("udpout:127.0.0.1:{}", self.port)
    }

    fn report(&mut self) -> Value {
        writeln!(self.stdin, "REPORT").unwrap();
        serde_json::from_str(&self.stdout.next().unwrap().unwrap()).unwrap()
    }
}

impl Drop for PyVehicle {
    fn drop(&mut self) {
        let _ = self.child.kill();
        let _ = self.child.wait();
    }
}

#[test]
fn our_signed_upload_verifies_on_a_pymavlink_vehicle_with_the_key() {
    let dir = tempfile::tempdir().unwrap();
    let mut v = PyVehicle::spawn(Some(&key_file(dir.path(), "k", KEY)));
    let m = mission();
    let (r, info) = upload(&v.url(), &m, &opts(Some(KEY)), &mut |_| {}).unwrap();
    assert!(r.verified && r.upload.ack_received);
    assert_eq!(info.target.system, 1);
    let rep = v.report();
    assert_eq!(items_from_json(&rep["items"]), m.items, "{rep}");
    assert_eq!(rep["rejected"], 0, "{rep}");
    assert!(rep["good_signatures"].as_u64().unwrap() > 0, "{rep}");
}

#[test]
fn a_pymavlink_vehicle_with_the_key_rejects_our_unsigned_upload() {
    let dir = tempfile::tempdir().unwrap();
    let mut v = PyVehicle::spawn(Some(&key_file(dir.path(), "k", KEY)));
    let e = upload(&v.url(), &mission(), &opts(None), &mut |_| {}).unwrap_err();
    assert!(matches!(e, MissionError::Signing { .. }), "{e}");
    assert_eq!(e.exit_code(), 9);
    let rep = v.report();
    assert_eq!(rep["items"].as_array().unwrap().len(), 0, "{rep}");
    assert!(rep["rejected"].as_u64().unwrap() > 0, "{rep}");
}

#[test]
fn a_pymavlink_vehicle_with_another_key_is_not_trusted() {
    let dir = tempfile::tempdir().unwrap();
    let mut v = PyVehicle::spawn(Some(&key_file(dir.path(), "k", OTHER_KEY)));
    let e = upload(&v.url(), &mission(), &opts(Some(KEY)), &mut |_| {}).unwrap_err();
    assert_eq!(e.exit_code(), 9, "{e}");
    assert!(e.to_string().contains("signed with another key"), "{e}");
    let rep = v.report();
    assert_eq!(rep["items"].as_array().unwrap().len(), 0, "{rep}");
    assert!(rep["rejected"].as_u64().unwrap() > 0, "{rep}");
}

/// Runs the pymavlink ground station against the vehicle on `port`; its JSON report.
fn py_ground(port: u16, key: Option<&Path>, n_items: usize) -> Value {
    let out = Command::new(python())
        .arg(script())
        .args(["ground", &port.to_string()])
        .arg(key.map_or_else(|| "-".into(), |k| k.as_os_str().to_owned()))
        .arg(n_items.to_string())
        .output()
        .unwrap();
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    serde_json::from_slice(&out.stdout).unwrap()
}

#[test]
fn our_signing_vehicle_takes_a_signed_pymavlink_upload_and_ignores_an_unsigned_one() {
    let dir = tempfile::tempdir().unwrap();
    let key = key_file(dir.path(), "k", KEY);
    let cfg = VehicleConfig {
        signing: Some(SigningKey::from_hex(KEY).unwrap()),
        heartbeat: Some(Duration::from_millis(100)),
        ..VehicleConfig::default()
    };
    let v = spawn_udp_vehicle("127.0.0.1:0", cfg.clone()).unwrap();
    let r = py_ground(v.addr().port(), Some(&key), 4);
    assert_eq!(r["ack"], "MAV_MISSION_ACCEPTED", "{r}");
    // pymavlink checked our vehicle's signatures on every reply it used.
    assert_eq!(r["read_back"], r["sent"], "{r}");
    assert_eq!(v.mission(), items_from_json(&r["sent"]));
    assert_eq!(v.ignored().foreign(), 0, "{}", v.ignored());

    let v = spawn_udp_vehicle("127.0.0.1:0", cfg).unwrap();
    let r = py_ground(v.addr().port(), None, 4);
    assert_eq!(r["heartbeat"], true, "an unsigned ground still hears: {r}");
    assert_eq!(r["ack"], Value::Null, "{r}");
    assert!(v.mission().is_empty());
    assert!(v.ignored().unsigned > 0, "{}", v.ignored());
}
