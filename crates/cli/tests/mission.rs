//! `vpctl mission ...` against a simulated vehicle on loopback.

use std::path::Path;

use vp_mission::sim_vehicle::{spawn_udp_vehicle, VehicleConfig};
use vp_scene::plan::{GeodeticOrigin, Home, Plan, PlannedView, Role};

mod common;
use common::vpctl;

/// A plan of one triplet around a point 20 m above the origin.
fn write_plan(path: &Path) {
    let mut plan = Plan::new(Some(GeodeticOrigin::default()));
    // The simulator's convention: the origin on the ground, the take-off point.
    plan.home = Some(Home {
        position: GeodeticOrigin::default(),
        source: "the origin".into(),
    });
    for (i, (x, y)) in [(10.0, 0.0), (-5.0, 8.66), (-5.0, -8.66)]
        .into_iter()
        .enumerate()
    {
        plan.waypoints.push(PlannedView {
            position: [x, y, 25.0],
            yaw_deg: 30.0 * i as f64,
            pitch_deg: -60.0,
            roll_deg: 0.0,
            role: Role::TripletMember,
            triplet_id: Some(0),
            expected_gain: Some(1.5),
            angle_bin_deg: Some(12.5),
        });
    }
    plan.save(path, false).unwrap();
}

#[test]
fn export_writes_a_qgc_plan_and_wpl_text() {
    let dir = tempfile::tempdir().unwrap();
    let plan = dir.path().join("plan.json");
    write_plan(&plan);
    let qgc = dir.path().join("m.plan");
    let o = vpctl(&[
        "mission",
        "export",
        plan.to_str().unwrap(),
        "--out",
        qgc.to_str().unwrap(),
    ]);
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    let v: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(&qgc).unwrap()).unwrap();
    assert_eq!(v["fileType"], "Plan");
    let items = v["mission"]["items"].as_array().unwrap();
    // Three views of (gimbal, waypoint, photo), plus takeoff and RTL.
    assert_eq!(items.len(), 11);
    assert!(items.iter().all(|i| i["type"] == "SimpleItem"));
    assert_eq!(items.iter().filter(|i| i["command"] == 16).count(), 3);

    // WPL to standard output.
    let o = vpctl(&[
        "mission",
        "export",
        plan.to_str().unwrap(),
        "--format",
        "wpl",
    ]);
    assert!(o.status.success());
    let text = String::from_utf8_lossy(&o.stdout);
    assert!(text.starts_with("QGC WPL 110"));
    assert_eq!(text.lines().count(), 1 + 1 + 11);

    // Refuses to overwrite without --force.
    let o = vpctl(&[
        "mission",
        "export",
        plan.to_str().unwrap(),
        "--out",
        qgc.to_str().unwrap(),
    ]);
    assert_eq!(o.status.code(), Some(2));
}

#[test]
fn upload_then_download_round_trips_through_a_simulated_vehicle() {
    let dir = tempfile::tempdir().unwrap();
    let plan = dir.path().join("plan.json");
    write_plan(&plan);
    let vehicle = spawn_udp_vehicle("127.0.0.1:0", VehicleConfig::default()).unwrap();
    let url = format!("udpout:{}", vehicle.addr());
    let o = vpctl(&["mission", "upload", plan.to_str().unwrap(), "--url", &url]);
    let stdout = String::from_utf8_lossy(&o.stdout);
    assert!(
        o.status.success(),
        "{stdout}\n{}",
        String::from_utf8_lossy(&o.stderr)
    );
    assert!(stdout.contains("verified: yes"), "{stdout}");
    assert_eq!(vehicle.mission().len(), 11);
    // stderr is a pipe here: progress comes as plain lines, not one long
    // line of carriage returns.
    let err = String::from_utf8_lossy(&o.stderr);
    assert!(!err.contains('\r'), "{err:?}");
    assert!(err.lines().count() >= 2, "{err:?}");

    let o = vpctl(&["mission", "download", "--url", &url]);
    assert!(o.status.success());
    let stdout = String::from_utf8_lossy(&o.stdout);
    assert!(stdout.contains("11 items"), "{stdout}");
    assert_eq!(
        stdout
            .lines()
            .filter(|l| l.contains("MAV_CMD_NAV_WAYPOINT"))
            .count(),
        3
    );
}

#[test]
fn no_vehicle_and_bad_inputs_fail_clearly() {
    let dir = tempfile::tempdir().unwrap();
    let plan = dir.path().join("plan.json");
    write_plan(&plan);
    // Nothing listens on this port: a timeout naming the URL, exit 1.
    let socket = std::net::UdpSocket::bind("127.0.0.1:0").unwrap();
    let url = format!("udpout:{}", socket.local_addr().unwrap());
    let o = vpctl(&[
        "mission",
        "download",
        "--url",
        &url,
        "--heartbeat-timeout",
        "0.5",
    ]);
    // No heartbeat: exit code 3, the "no vehicle" outcome.
    assert_eq!(o.status.code(), Some(3));
    let err = String::from_utf8_lossy(&o.stderr);
    assert!(err.contains("127.0.0.1"), "{err}");

    let o = vpctl(&["mission", "download", "--url", "carrier-pigeon:1"]);
    assert_eq!(o.status.code(), Some(2));

    let bad = dir.path().join("bad.json");
    std::fs::write(&bad, "{ \"format_version\": 1, \"waypoints\": [ }").unwrap();
    let o = vpctl(&["mission", "export", bad.to_str().unwrap()]);
    assert_eq!(o.status.code(), Some(2));
    assert!(String::from_utf8_lossy(&o.stderr).contains("bad.json"));
}

/// A key file with `mode`; the key is 64 hex digits.
fn write_key(path: &Path, hex: &str, mode: u32) {
    std::fs::write(path, format!("{hex}\n")).unwrap();
    #[cfg(unix)]
    {
        use std::os::unix::fs::PermissionsExt;
        std::fs::set_permissions(path, std::fs::Permissions::from_mode(mode)).unwrap();
    }
    #[cfg(not(unix))]
    let _ = mode;
}

const KEY: &str = "c0ffee00c0ffee00c0ffee00c0ffee00c0ffee00c0ffee00c0ffee00c0ffee01";

#[test]
fn signed_upload_verifies_and_never_shows_the_key() {
    let dir = tempfile::tempdir().unwrap();
    let plan = dir.path().join("plan.json");
    write_plan(&plan);
    let key = dir.path().join("vehicle.key");
    write_key(&key, KEY, 0o600);
    let vehicle = spawn_udp_vehicle(
        "127.0.0.1:0",
        VehicleConfig {
            signing: Some(vp_mission::SigningKey::from_hex(KEY).unwrap()),
            ..VehicleConfig::default()
        },
    )
    .unwrap();
    let url = format!("udpout:{}", vehicle.addr());
    let args = |k: &Path| {
        vpctl(&[
            "mission",
            "upload",
            plan.to_str().unwrap(),
            "--url",
            &url,
            "--signing-key",
            k.to_str().unwrap(),
        ])
    };
    let o = args(&key);
    let (stdout, stderr) = (
        String::from_utf8_lossy(&o.stdout),
        String::from_utf8_lossy(&o.stderr),
    );
    assert_eq!(o.status.code(), Some(0), "{stdout}\n{stderr}");
    assert!(stdout.contains("verified: yes"), "{stdout}");
    assert!(!stderr.contains("warning"), "mode 600: {stderr}");
    assert_eq!(vehicle.mission().len(), 11);
    assert_eq!(vehicle.ignored().foreign(), 0);

    // Readable by others: a warning as ssh gives, the upload still works.
    #[cfg(unix)]
    {
        write_key(&key, KEY, 0o644);
        let o = args(&key);
        let stderr = String::from_utf8_lossy(&o.stderr);
        assert_eq!(o.status.code(), Some(0), "{stderr}");
        assert!(
            stderr.contains("warning")
                && stderr.contains("vehicle.key")
                && stderr.contains("chmod 600"),
            "{stderr}"
        );
        for text in [&stderr, &String::from_utf8_lossy(&o.stdout)] {
            assert!(
                !text.to_lowercase().contains("c0ffee"),
                "the key leaked: {text}"
            );
        }
    }
}

#[test]
fn a_vehicle_that_does_not_sign_is_refused_with_exit_9() {
    let dir = tempfile::tempdir().unwrap();
    let plan = dir.path().join("plan.json");
    write_plan(&plan);
    let key = dir.path().join("k.hex");
    write_key(&key, KEY, 0o600);
    let vehicle = spawn_udp_vehicle("127.0.0.1:0", VehicleConfig::default()).unwrap();
    let url = format!("udpout:{}", vehicle.addr());
    let o = vpctl(&[
        "mission",
        "upload",
        plan.to_str().unwrap(),
        "--url",
        &url,
        "--signing-key",
        key.to_str().unwrap(),
        "--heartbeat-timeout",
        "1.5",
    ]);
    let (stdout, stderr) = (
        String::from_utf8_lossy(&o.stdout),
        String::from_utf8_lossy(&o.stderr),
    );
    assert_eq!(o.status.code(), Some(9), "{stdout}\n{stderr}");
    assert!(!stdout.contains("verified"), "{stdout}");
    assert!(stderr.contains("unsigned"), "{stderr}");
    assert!(vehicle.mission().is_empty());
}

#[test]
fn bad_key_files_are_input_errors_naming_the_file() {
    let dir = tempfile::tempdir().unwrap();
    let plan = dir.path().join("plan.json");
    write_plan(&plan);
    let short = dir.path().join("short.key");
    write_key(&short, "my secret passphrase", 0o600);
    let missing = dir.path().join("missing.key");
    for (file, expect) in [(&short, "64 hexadecimal digits"), (&missing, "cannot read")] {
        for cmd in [
            vec!["mission", "upload", plan.to_str().unwrap()],
            vec!["mission", "download"],
            vec!["mission", "vehicle", "--seconds", "1"],
        ] {
            let mut args = cmd.clone();
            args.extend(["--signing-key", file.to_str().unwrap()]);
            let o = vpctl(&args);
            let stderr = String::from_utf8_lossy(&o.stderr);
            assert_eq!(o.status.code(), Some(2), "{args:?}: {stderr}");
            assert!(
                stderr.contains(file.file_name().unwrap().to_str().unwrap())
                    && stderr.contains(expect),
                "{args:?}: {stderr}"
            );
            assert!(!stderr.contains("passphrase"), "the key leaked: {stderr}");
        }
    }
}
