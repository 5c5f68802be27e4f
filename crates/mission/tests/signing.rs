//! MAVLink 2 signing on loopback: our ground side against the simulated
//! vehicle over real UDP, each with or without a key. "Verified" must come
//! only from a vehicle that signs with our key; a vehicle with a key must
//! act only on messages signed with it, once.

use std::net::UdpSocket;
use std::time::Duration;

use mavlink::dialects::common::{MavMessage, MavMissionType, MISSION_REQUEST_INT_DATA};
use mavlink::{MAVLinkMessageRaw, MavHeader, MavlinkReader, MavlinkVersion};
use vp_mission::signing::{SignedLink, Signer, LINK_ID};
use vp_mission::sim_vehicle::{spawn_udp_vehicle, Impairment, UdpRelay, UdpVehicle, VehicleConfig};
use vp_mission::{
    build_mission, connect, download, upload, upload_over, Autopilot, ConnectOptions, Mission,
    MissionError, MissionOptions, ProtocolConfig, SigningKey,
};
use vp_scene::plan::GeodeticOrigin;
use vp_test_support::plans;

const SCALE: f64 = 0.02;

fn key(byte: u8) -> SigningKey {
    SigningKey::from_bytes([byte; 32])
}

fn mission() -> Mission {
    let mut p = plans::plan_at(GeodeticOrigin::default());
    for i in 0..4 {
        let k = f64::from(i);
        p.waypoints.push(plans::photo(
            [k * 10.0, 5.0 - k, 30.0 + k],
            k * 40.0,
            -30.0,
            None,
        ));
    }
    build_mission(&p, &MissionOptions::for_autopilot(Autopilot::Px4)).unwrap()
}

fn vehicle(signing: Option<SigningKey>) -> UdpVehicle {
    spawn_udp_vehicle(
        "127.0.0.1:0",
        VehicleConfig {
            item_timeout: Duration::from_millis(250).mul_f64(SCALE),
            protocol_timeout: Duration::from_secs(5).mul_f64(SCALE),
            heartbeat: Some(Duration::from_millis(50)),
            signing,
            ..VehicleConfig::default()
        },
    )
    .unwrap()
}

fn opts(signing: Option<SigningKey>) -> ConnectOptions {
    ConnectOptions {
        heartbeat_timeout: Duration::from_secs(1),
        target_system: None,
        protocol: ProtocolConfig::default().scaled(SCALE),
        signing,
        home_check: None,
    }
}

fn url(v: &UdpVehicle) -> String {
    format!("udpout:{}", v.addr())
}

#[test]
fn signed_upload_to_a_signing_vehicle_verifies() {
    let v = vehicle(Some(key(1)));
    let m = mission();
    let (r, _) = upload(&url(&v), &m, &opts(Some(key(1))), &mut |_| {}).unwrap();
    assert!(r.verified && r.upload.ack_received);
    assert_eq!(v.mission(), m.items);
    assert_eq!(v.ignored().foreign(), 0, "{}", v.ignored());
    let (items, _, _) = download(&url(&v), &opts(Some(key(1))), &mut |_| {}).unwrap();
    assert_eq!(items, m.items);
}

#[test]
fn signed_uploads_through_a_lossy_relay_verify() {
    // Duplicated and overtaken datagrams arrive with stale timestamps and
    // are dropped as replays: to the protocol that is more loss.
    let v = vehicle(Some(key(1)));
    let imp = Impairment {
        drop: 0.1,
        duplicate: 0.2,
        reorder: 0.1,
    };
    let relay = UdpRelay::spawn(v.addr(), imp, 7).unwrap();
    let o = opts(Some(key(1)));
    let (mut link, info) = connect(&format!("udpout:{}", relay.addr()), &o).unwrap();
    let m = mission();
    for k in 0..5 {
        let r = upload_over(&mut link, info.target, &m, &o.protocol, true, &mut |_| {})
            .unwrap_or_else(|e| panic!("upload {k}: {e}"));
        assert!(r.verified);
    }
    assert_eq!(v.mission(), m.items);
    let (ours, theirs) = (link.ignored(), v.ignored());
    assert_eq!(ours.foreign() + theirs.foreign(), 0, "{ours} / {theirs}");
    assert!(
        ours.stale + theirs.stale > 0,
        "duplicates were dropped as stale"
    );
}

#[test]
fn unsigned_upload_to_a_signing_vehicle_is_ignored_and_says_why() {
    let v = vehicle(Some(key(1)));
    let e = upload(&url(&v), &mission(), &opts(None), &mut |_| {}).unwrap_err();
    assert!(matches!(e, MissionError::Signing { .. }), "{e}");
    assert_eq!(e.exit_code(), 9);
    assert!(e.to_string().contains("--signing-key"), "{e}");
    assert!(v.mission().is_empty(), "the vehicle stored nothing");
    assert!(v.ignored().unsigned > 0, "{}", v.ignored());
}

#[test]
fn a_vehicle_that_does_not_sign_is_not_trusted() {
    let v = vehicle(None);
    let e = upload(&url(&v), &mission(), &opts(Some(key(1))), &mut |_| {}).unwrap_err();
    assert!(matches!(e, MissionError::Signing { .. }), "{e}");
    assert_eq!(e.exit_code(), 9);
    let msg = e.to_string();
    assert!(
        msg.contains("unsigned") && msg.contains("no vehicle"),
        "{msg}"
    );
    assert!(v.mission().is_empty());
}

#[test]
fn a_vehicle_with_another_key_is_not_trusted_and_trusts_us_not() {
    let v = vehicle(Some(key(2)));
    let e = upload(&url(&v), &mission(), &opts(Some(key(1))), &mut |_| {}).unwrap_err();
    assert_eq!(e.exit_code(), 9, "{e}");
    assert!(e.to_string().contains("signed with another key"), "{e}");
    assert!(v.mission().is_empty());
    assert!(v.ignored().wrong_key > 0, "{}", v.ignored());
}

/// Sends a signed MISSION_REQUEST_INT for `seq` as raw bytes.
fn request(socket: &UdpSocket, signer: &Signer, seq: u16) -> Vec<u8> {
    let frame = signer.sign(
        MavHeader {
            system_id: 255,
            component_id: 191,
            sequence: seq as u8,
        },
        &MavMessage::MISSION_REQUEST_INT(MISSION_REQUEST_INT_DATA {
            seq,
            target_system: 1,
            target_component: 1,
            mission_type: MavMissionType::MAV_MISSION_TYPE_MISSION,
        }),
    );
    let MAVLinkMessageRaw::V2(frame) = frame else {
        panic!("signed frames are MAVLink 2")
    };
    let bytes = frame.raw_bytes().to_vec();
    socket.send(&bytes).unwrap();
    bytes
}

/// The `seq` of the next MISSION_ITEM_INT the vehicle sends us (checked
/// with the key like any message).
fn next_item(socket: &UdpSocket, link: &mut SignedLink) -> u16 {
    let mut buf = [0u8; 512];
    loop {
        let n = socket.recv(&mut buf).expect("the vehicle answers");
        let raw = MavlinkReader::new(&buf[..n])
            .read_raw_message::<MavMessage>(MavlinkVersion::V2)
            .unwrap();
        if let Some((_, MavMessage::MISSION_ITEM_INT(it))) = link.accept(&raw) {
            return it.seq;
        }
    }
}

#[test]
fn a_replayed_message_is_ignored_by_the_vehicle() {
    let v = vehicle(Some(key(1)));
    let m = mission();
    upload(&url(&v), &m, &opts(Some(key(1))), &mut |_| {}).unwrap();
    // A second ground component (its own signing stream), on a bare socket.
    let socket = UdpSocket::bind("127.0.0.1:0").unwrap();
    socket.connect(v.addr()).unwrap();
    socket
        .set_read_timeout(Some(Duration::from_secs(5)))
        .unwrap();
    let signer = Signer::new(&key(1), LINK_ID);
    let mut link = SignedLink::new(Some(&key(1)), LINK_ID);
    let first = request(&socket, &signer, 1);
    assert_eq!(next_item(&socket, &mut link), 1);
    // The same signed bytes again, then a fresh request for item 2: were
    // the replay answered, item 1 would come before item 2.
    socket.send(&first).unwrap();
    request(&socket, &signer, 2);
    assert_eq!(next_item(&socket, &mut link), 2);
    assert_eq!(v.ignored().stale, 1, "{}", v.ignored());
    assert_eq!(v.ignored().foreign(), 0, "{}", v.ignored());
}
