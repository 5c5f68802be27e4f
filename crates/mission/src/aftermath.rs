//! What a failed upload leaves on the vehicle, and what to do next.
//!
//! ArduPilot writes each item to storage as it arrives (its
//! `MissionItemProtocol` replaces item `seq` in place after truncating the
//! stored mission to the new count): an upload cut after 50 of 123 items
//! leaves the first 50 new items followed by the old mission's rest, a mix
//! that flies. So after a failed upload to ArduPilot we clear the mission
//! and say so, or say plainly that clearing failed and what the vehicle may
//! hold. PX4 receives into a second storage slot and switches only when
//! the upload completes, so it keeps its previous mission. A rejection of
//! the MISSION_COUNT itself (no space, denied) comes before anything is
//! written on both.

use crate::error::MissionError;
use crate::items::{stated_capacity, Autopilot, Mission};
use crate::protocol::{self, result_name, Link, ProtocolConfig, Target};

/// `e` (an upload failure) with what the vehicle holds now and the next step.
pub(crate) fn explain_failed_upload(
    link: &mut dyn Link,
    target: Target,
    mission: &Mission,
    cfg: &ProtocolConfig,
    e: MissionError,
) -> MissionError {
    if e.is_input_error() {
        return e;
    }
    let mut notes = Vec::new();
    if let MissionError::Rejected { result, said, .. } = &e {
        if *result == result_name(mavlink::dialects::common::MavMissionResult::MAV_MISSION_NO_SPACE)
        {
            notes.push(space_advice(mission, said));
        }
    }
    if matches!(&e, MissionError::Rejected { seq: None, .. }) {
        notes.push(
            "the vehicle refused before any item was written: it still holds its previous mission"
                .to_string(),
        );
    } else if mission.autopilot == Autopilot::ArduPilot {
        notes.push(match clear_after_failure(link, target, cfg) {
            Ok(()) => "ArduPilot writes items as they arrive, so the vehicle held the first \
                       items of this mission over the rest of its previous one; vpctl cleared \
                       it: the vehicle holds no mission now. Upload again"
                .to_string(),
            Err(ce) => format!(
                "ArduPilot writes items as they arrive: the vehicle may now hold the first items \
                 of this mission followed by the rest of its previous mission, a mix that would \
                 fly, and clearing it failed ({ce}). Do not fly AUTO: upload again, or clear the \
                 mission from a ground station (MAVProxy: `wp clear`), and check with \
                 `vpctl mission download`"
            ),
        });
    } else {
        notes.push(
            "PX4 replaces its mission only when an upload completes: the vehicle still holds its \
             previous mission (check with `vpctl mission download`)"
                .to_string(),
        );
    }
    MissionError::Explained {
        detail: notes.join("; "),
        source: Box::new(e),
    }
}

/// MISSION_CLEAR_ALL; if ArduPilot refuses it because its half-finished
/// upload is still open (MAV_MISSION_ERROR), an empty upload
/// (MISSION_COUNT 0), which it accepts from the station that started the
/// upload and which leaves no item.
fn clear_after_failure(
    link: &mut dyn Link,
    target: Target,
    cfg: &ProtocolConfig,
) -> Result<(), MissionError> {
    let once = ProtocolConfig {
        attempts: 1,
        ..*cfg
    };
    match protocol::clear(link, target, &once) {
        Ok(_) => Ok(()),
        Err(MissionError::Rejected { .. }) => {
            protocol::upload(link, target, &[], &once, &mut |_| {}).map(|_| ())
        }
        Err(e) => Err(e),
    }
}

/// How to split the plan when the vehicle has no room for it, from the
/// capacity it states ("Only 650 items are supported").
fn space_advice(mission: &Mission, said: &[String]) -> String {
    let (per_photo, other) = mission.items_per_photo();
    let n = mission.items.len();
    let photos = mission.photos;
    let layout = format!("{n} items: {photos} photos x {per_photo} items + {other}");
    match stated_capacity(said) {
        Some(cap) => match mission.flights_for(cap) {
            Some((per_flight, flights)) => format!(
                "the vehicle holds at most {cap} items and this mission has {layout}; at most \
                 {per_flight} photos fit in one flight: split the plan into {flights} flights of \
                 up to {per_flight} photos"
            ),
            None => {
                format!("the vehicle holds at most {cap} items, too few for one photo ({layout})")
            }
        },
        None => format!(
            "the vehicle did not say how many items it holds; this mission has {layout}: split \
             the plan into flights with fewer photos"
        ),
    }
}
