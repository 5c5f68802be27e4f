//! What a real ArduPilot does with the mission (issue 39, item 7), against
//! the simulated vehicle taught those habits (`sim_vehicle::ardupilot`):
//! the heading, centimetre heights, one-byte camera numbers, items written
//! as they arrive, a full vehicle, NaN params. Each test failed on the code
//! before this change.

use std::time::Duration;

use mavlink::dialects::common::{MavCmd, MavMessage};
use mavlink::MavHeader;
use vp_mission::protocol::{ProtocolConfig, Target};
use vp_mission::sim_vehicle::{ardupilot, Impairment, MissionServer, SimLink, VehicleConfig};
use vp_mission::{
    build_mission, compare_items, upload_over, Autopilot, CameraTrigger, GimbalCommand, Link,
    Mission, MissionError, MissionItem, MissionOptions,
};
use vp_scene::plan::Plan;
use vp_test_support::plans;

const TARGET: Target = Target {
    system: 1,
    component: 1,
};

fn plan(n_views: usize, seed: u64) -> Plan {
    let mut p = plans::plan_at(plans::ALPS);
    for i in 0..n_views {
        let k = (i as u64 * 7 + seed) as f64;
        p.waypoints.push(plans::photo(
            [
                k * 7.3 % 400.0 - 200.0,
                k * 13.1 % 300.0 - 150.0,
                // Heights on the centimetre grid and off it.
                8.0 + (k * 0.37) % 30.0,
            ],
            k * 37.0 % 360.0,
            -(k * 11.0 % 90.0),
            None,
        ));
    }
    p
}

fn ardupilot_mission(n_views: usize) -> Mission {
    build_mission(
        &plan(n_views, 1),
        &MissionOptions::for_autopilot(Autopilot::ArduPilot),
    )
    .unwrap()
}

fn ardupilot_vehicle(capacity: usize) -> MissionServer {
    MissionServer::new(VehicleConfig {
        autopilot: Autopilot::ArduPilot,
        capacity,
        heartbeat: None,
        ..VehicleConfig::default()
    })
}

fn upload(link: &mut dyn Link, m: &Mission) -> Result<vp_mission::TransferReport, MissionError> {
    upload_over(
        link,
        TARGET,
        m,
        &ProtocolConfig::default(),
        true,
        &mut |_| {},
    )
}

#[test]
fn ardupilot_mission_turns_to_each_heading_with_condition_yaw_before_the_waypoint() {
    let m = ardupilot_mission(6);
    let headings: Vec<f32> = m
        .items
        .windows(2)
        .filter(|w| w[1].command == MavCmd::MAV_CMD_NAV_WAYPOINT && w[1].frame != m.items[0].frame)
        .map(|w| {
            assert_eq!(w[0].command, MavCmd::MAV_CMD_CONDITION_YAW, "{w:?}");
            // Absolute heading, default rate, shortest turn.
            assert_eq!(&w[0].params[1..], &[0.0, 0.0, 0.0]);
            assert!(
                (w[0].params[0] - w[1].params[3]).abs() < 1e-3,
                "the waypoint's heading"
            );
            w[0].params[0]
        })
        .collect();
    assert_eq!(headings.len(), 6);
    assert!(
        headings.iter().all(|h| (0.0..360.0).contains(h)),
        "{headings:?}"
    );
    // Verified against a vehicle that drops the waypoint's yaw.
    let mut link = SimLink::new(ardupilot_vehicle(700), Impairment::default(), 1);
    let r = upload(&mut link, &m).unwrap();
    assert!(r.verified);
    let stored_wp = link
        .vehicle
        .mission()
        .iter()
        .skip(1)
        .find(|i| i.command == MavCmd::MAV_CMD_NAV_WAYPOINT)
        .copied()
        .unwrap();
    assert_eq!(
        &stored_wp.params[1..],
        &[0.0, 0.0, 0.0],
        "yaw and radius dropped"
    );
}

#[test]
fn verification_on_ardupilot_catches_a_wrong_heading_and_gimbal_pitch() {
    let m = ardupilot_mission(3);
    let yaw = m
        .items
        .iter()
        .position(|i| i.command == MavCmd::MAV_CMD_CONDITION_YAW)
        .expect("a CONDITION_YAW item");
    let mut got = m.items.clone();
    got[yaw].params[0] += 45.0;
    let e = compare_items(&m.items, &got, Autopilot::ArduPilot).unwrap_err();
    assert!(e.to_string().contains("heading"), "{e}");
    let mut got = m.items.clone();
    got[yaw - 1].params[0] += 10.0;
    let e = compare_items(&m.items, &got, Autopilot::ArduPilot).unwrap_err();
    assert!(e.to_string().contains("gimbal pitch"), "{e}");
}

#[test]
fn heights_truncated_to_whole_centimetres_verify() {
    // The case: "item 333 differs after upload: z 9.11 vs 9.099999".
    let sent = MissionItem {
        z: 9.11,
        ..ardupilot_mission(1).items[4]
    };
    assert_eq!(sent.command, MavCmd::MAV_CMD_NAV_WAYPOINT);
    let got = MissionItem {
        z: 910_f32 / 100.0,
        params: [sent.params[0], 0.0, 0.0, 0.0],
        ..sent
    };
    let home = ardupilot_mission(1).items[0];
    compare_items(&[home, sent], &[home, got], Autopilot::ArduPilot).unwrap();
    // A real centimetre off is still caught.
    let wrong = MissionItem { z: 9.08, ..got };
    assert!(compare_items(&[home, sent], &[home, wrong], Autopilot::ArduPilot).is_err());
    // Every height of a 400-photo plan through the truncating vehicle.
    let m = ardupilot_mission(400);
    let mut link = SimLink::new(ardupilot_vehicle(2000), Impairment::default(), 1);
    assert!(upload(&mut link, &m).unwrap().verified);
    let truncated = link
        .vehicle
        .mission()
        .iter()
        .zip(&m.items)
        .skip(1)
        .filter(|(a, b)| b.is_positional() && a.z.to_bits() != b.z.to_bits())
        .count();
    assert!(truncated > 100, "the vehicle truncated {truncated} heights");
}

#[test]
#[allow(deprecated)] // DIGICAM_CONTROL is ArduPilot's trigger.
fn more_than_255_photos_verify_although_the_camera_number_wraps() {
    let m = ardupilot_mission(300);
    let last = m
        .items
        .iter()
        .rev()
        .find(|i| i.command == MavCmd::MAV_CMD_DO_DIGICAM_CONTROL)
        .unwrap();
    assert_eq!(last.y, 300);
    let mut link = SimLink::new(ardupilot_vehicle(2000), Impairment::default(), 1);
    let r = upload(&mut link, &m).unwrap();
    assert!(r.verified);
    let stored_last = link
        .vehicle
        .mission()
        .iter()
        .rev()
        .find(|i| i.command == MavCmd::MAV_CMD_DO_DIGICAM_CONTROL)
        .unwrap();
    assert_eq!(stored_last.y, 300 % 256, "kept in one byte");
}

#[test]
fn gimbal_manager_item_carries_no_nan_and_ardupilot_keeps_both_px4_items() {
    let mut opts = MissionOptions::for_autopilot(Autopilot::ArduPilot);
    opts.gimbal = GimbalCommand::GimbalManager;
    opts.trigger = CameraTrigger::ImageStartCapture;
    let m = build_mission(&plan(5, 2), &opts).unwrap();
    let px4 = build_mission(&plan(5, 2), &MissionOptions::for_autopilot(Autopilot::Px4)).unwrap();
    for item in m.items.iter().chain(&px4.items) {
        if item.command == MavCmd::MAV_CMD_DO_GIMBAL_MANAGER_PITCHYAW {
            assert!(item.params.iter().all(|p| !p.is_nan()), "{item:?}");
        }
        // ArduPilot's own check of params (NaN only in param4 of NAV items).
        assert_eq!(ardupilot::check(item), Ok(()), "{item:?}");
    }
    let mut link = SimLink::new(ardupilot_vehicle(700), Impairment::default(), 1);
    assert!(upload(&mut link, &m).unwrap().verified);
}

/// A link that goes dead for good after `cut_after` items went out.
struct CutLink {
    sim: SimLink,
    items_sent: u32,
    cut_after: u32,
}

impl Link for CutLink {
    fn send(&mut self, msg: &MavMessage) -> vp_mission::Result<()> {
        if matches!(msg, MavMessage::MISSION_ITEM_INT(_)) {
            self.items_sent += 1;
        }
        if self.items_sent > self.cut_after {
            return Ok(());
        }
        self.sim.send(msg)
    }
    fn recv(&mut self, timeout: Duration) -> vp_mission::Result<Option<(MavHeader, MavMessage)>> {
        let m = self.sim.recv(timeout)?;
        Ok(m.filter(|_| self.items_sent <= self.cut_after))
    }
    fn now(&self) -> Duration {
        self.sim.now()
    }
}

#[test]
fn upload_cut_after_50_items_says_the_vehicle_may_hold_a_mix() {
    // The vehicle holds an older, longer mission.
    let old = ardupilot_mission(60);
    let mut sim = SimLink::new(ardupilot_vehicle(700), Impairment::default(), 1);
    assert!(upload(&mut sim, &old).unwrap().verified);
    let new = build_mission(
        &plan(40, 9),
        &MissionOptions::for_autopilot(Autopilot::ArduPilot),
    )
    .unwrap();
    let mut link = CutLink {
        sim,
        items_sent: 0,
        cut_after: 50,
    };
    let e = upload(&mut link, &new).unwrap_err();
    let text = e.to_string();
    assert_eq!(e.exit_code(), 4, "{text}");
    assert!(
        text.contains("may now hold the first items of this mission followed by the rest of its previous mission")
            && text.contains("Do not fly AUTO"),
        "{text}"
    );
    // And it does: the first 50 new items over the old mission's rest.
    let held = link.sim.vehicle.mission();
    assert_eq!(held.len(), new.items.len(), "truncated to the new count");
    assert_eq!(held[40], ardupilot::stored(&new.items[40]));
    assert_eq!(held[100], ardupilot::stored(&old.items[100]));
}

#[test]
fn item_rejected_mid_upload_clears_the_half_written_mission_and_says_so() {
    let old = ardupilot_mission(60);
    let mut link = SimLink::new(ardupilot_vehicle(700), Impairment::default(), 1);
    assert!(upload(&mut link, &old).unwrap().verified);
    // Item 50 carries NaN in param3 of a DO command: ArduPilot refuses it.
    let mut new = ardupilot_mission(40);
    new.items[50].params[2] = f32::NAN;
    assert!(!new.items[50].is_positional());
    let e = upload(&mut link, &new).unwrap_err();
    let text = e.to_string();
    assert_eq!(e.exit_code(), 5, "{text}");
    assert!(text.contains("MAV_MISSION_INVALID_PARAM3"), "{text}");
    assert!(text.contains("vpctl cleared it"), "{text}");
    assert!(link.vehicle.mission().is_empty(), "no mixed mission left");
}

#[test]
fn full_vehicle_reports_its_own_words_and_the_flights_that_fit() {
    // About 216 photos, as in the issue; the vehicle holds 650 items.
    let m = ardupilot_mission(216);
    let mut link = SimLink::new(ardupilot_vehicle(650), Impairment::default(), 1);
    let e = upload(&mut link, &m).unwrap_err();
    let text = e.to_string();
    assert_eq!(e.exit_code(), 5, "{text}");
    let (per_photo, other) = m.items_per_photo();
    assert_eq!((per_photo, other), (4, 3));
    let per_flight = (650 - other) / per_photo;
    assert!(
        text.contains("MAV_MISSION_NO_SPACE")
            && text.contains("\"Only 650 items are supported\"")
            && text.contains(&format!(
                "split the plan into 2 flights of up to {per_flight} photos"
            ))
            && text.contains("still holds its previous mission"),
        "{text}"
    );
    // The split fits.
    let fits = ardupilot_mission(per_flight);
    assert!(fits.items.len() <= 650);
    let mut link = SimLink::new(ardupilot_vehicle(650), Impairment::default(), 1);
    assert!(upload(&mut link, &fits).unwrap().verified);
}

#[test]
fn px4_failure_says_the_previous_mission_is_kept() {
    let m = build_mission(&plan(10, 3), &MissionOptions::for_autopilot(Autopilot::Px4)).unwrap();
    let v = MissionServer::new(VehicleConfig {
        heartbeat: None,
        ..VehicleConfig::default()
    });
    let sim = SimLink::new(v, Impairment::default(), 1);
    let mut link = CutLink {
        sim,
        items_sent: 0,
        cut_after: 5,
    };
    let e = upload(&mut link, &m).unwrap_err();
    assert!(
        e.to_string()
            .contains("PX4 replaces its mission only when an upload completes"),
        "{e}"
    );
    assert!(
        link.sim.vehicle.mission().is_empty(),
        "nothing half-written"
    );
}

#[test]
fn ardupilot_refuses_clear_during_an_upload_but_takes_an_empty_one() {
    use mavlink::dialects::common::{
        MavMissionResult, MavMissionType, MISSION_CLEAR_ALL_DATA, MISSION_COUNT_DATA,
    };
    // What the clean-up after a failed upload relies on: ArduPilot answers
    // MISSION_CLEAR_ALL with MAV_MISSION_ERROR while its upload is open,
    // and takes MISSION_COUNT 0 from the same station, leaving no item.
    let m = ardupilot_mission(5);
    let mut v = ardupilot_vehicle(700);
    let gcs = MavHeader {
        system_id: 255,
        component_id: 190,
        sequence: 0,
    };
    let count = |n: u16| {
        MavMessage::MISSION_COUNT(MISSION_COUNT_DATA {
            count: n,
            target_system: 1,
            target_component: 1,
            mission_type: MavMissionType::MAV_MISSION_TYPE_MISSION,
            opaque_id: 0,
        })
    };
    let t = Duration::from_millis(1);
    v.handle(t, &gcs, &count(m.items.len() as u16));
    for (seq, item) in m.items.iter().take(6).enumerate() {
        v.handle(
            t,
            &gcs,
            &MavMessage::MISSION_ITEM_INT(item.to_mavlink(seq as u16, (1, 1))),
        );
    }
    assert_eq!(v.mission().len(), 6, "written as they arrived");
    let ack = |out: Vec<MavMessage>| match out.first() {
        Some(MavMessage::MISSION_ACK(a)) => a.mavtype,
        other => panic!("{other:?}"),
    };
    let clear = MavMessage::MISSION_CLEAR_ALL(MISSION_CLEAR_ALL_DATA {
        target_system: 1,
        target_component: 1,
        mission_type: MavMissionType::MAV_MISSION_TYPE_MISSION,
    });
    assert_eq!(
        ack(v.handle(t, &gcs, &clear)),
        MavMissionResult::MAV_MISSION_ERROR
    );
    assert_eq!(v.mission().len(), 6);
    assert_eq!(
        ack(v.handle(t, &gcs, &count(0))),
        MavMissionResult::MAV_MISSION_ACCEPTED
    );
    assert!(v.mission().is_empty());
}
