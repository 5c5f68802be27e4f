//! Verification of an upload: the mission read back against the one sent,
//! comparing what matters for the photos (position, height, heading, gimbal
//! pitch, the trigger) as each autopilot keeps it.

use mavlink::dialects::common::MavCmd;

use super::{float_frame, Autopilot, MissionItem};
use crate::error::{MissionError, Result};

/// Compares an uploaded mission with the one read back, item by item.
///
/// Everywhere: the same number of items, the same commands; integers
/// (lat/lon, raw param5/6) exactly; floats bit for bit or within 1e-4
/// relative (NaN equals NaN); frames by their float synonym, and only for
/// positional items (vehicles report DO items in various frames).
///
/// PX4 stores items as floats: every param is compared, heights within
/// 1 cm.
///
/// ArduPilot (read from its `AP_Mission.cpp`): seq 0 is its own home and
/// is skipped; a waypoint keeps only its hold (param1), so the heading is
/// verified on the `CONDITION_YAW` that carries it; heights are stored in
/// whole centimetres truncated toward zero (9.11 m comes back as 9.10 m),
/// so a height matches when it is what that truncation gives; the camera
/// command's identity is kept in one byte, so it is compared modulo 256;
/// `DO_MOUNT_CONTROL`'s mode (param7) is not stored and not compared.
pub fn compare_items(
    sent: &[MissionItem],
    got: &[MissionItem],
    autopilot: Autopilot,
) -> Result<()> {
    if sent.len() != got.len() {
        return Err(MissionError::VerifyMismatch {
            seq: sent.len().min(got.len()),
            detail: format!(
                "vehicle holds {} items, {} were uploaded",
                got.len(),
                sent.len()
            ),
        });
    }
    let ardupilot = autopilot == Autopilot::ArduPilot;
    let skip = usize::from(ardupilot);
    for (seq, (a, b)) in sent.iter().zip(got).enumerate().skip(skip) {
        compare_item(a, b, ardupilot)
            .map_err(|detail| MissionError::VerifyMismatch { seq, detail })?;
    }
    Ok(())
}

#[allow(deprecated)] // DO_MOUNT_CONTROL and DIGICAM_CONTROL are ArduPilot's.
fn compare_item(a: &MissionItem, b: &MissionItem, ardupilot: bool) -> Result<(), String> {
    if a.command != b.command {
        return Err(format!("command {:?} vs {:?}", a.command, b.command));
    }
    let positional = a.is_positional();
    if positional && float_frame(a.frame) != float_frame(b.frame) {
        return Err(format!("frame {:?} vs {:?}", a.frame, b.frame));
    }
    let digicam = ardupilot && a.command == MavCmd::MAV_CMD_DO_DIGICAM_CONTROL;
    let (xa, ya, xb, yb) = if digicam {
        // One byte on the vehicle: > 255 photos wrap.
        (a.x & 0xff, a.y & 0xff, b.x & 0xff, b.y & 0xff)
    } else {
        (a.x, a.y, b.x, b.y)
    };
    if xa != xb || ya != yb {
        let what = if positional {
            "position (lat/lon * 1e7)"
        } else {
            "x/y (param5/6)"
        };
        return Err(format!("{what} ({}, {}) vs ({}, {})", a.x, a.y, b.x, b.y));
    }
    let z_ok = if positional {
        (a.z - b.z).abs() <= 0.01 || (ardupilot && same_f32(ardupilot_alt(a.z), b.z))
    } else {
        (ardupilot && a.command == MavCmd::MAV_CMD_DO_MOUNT_CONTROL) || same_f32(a.z, b.z)
    };
    if !z_ok {
        let what = if positional { "height" } else { "z (param7)" };
        return Err(format!("{what} {} vs {}", a.z, b.z));
    }
    // ArduCopter keeps only the hold (param1) of a positional item.
    let params = if ardupilot && positional { 1 } else { 4 };
    for k in 0..params {
        if !same_f32(a.params[k], b.params[k]) {
            return Err(format!(
                "{} {} vs {}",
                param_name(a.command, k),
                a.params[k],
                b.params[k]
            ));
        }
    }
    Ok(())
}

/// What a param means for the photo, in the error a user reads.
#[allow(deprecated)] // DO_MOUNT_CONTROL is ArduPilot's.
fn param_name(c: MavCmd, k: usize) -> String {
    let name = match (c, k) {
        (MavCmd::MAV_CMD_NAV_WAYPOINT, 0) => "hold",
        (MavCmd::MAV_CMD_NAV_WAYPOINT, 3) | (MavCmd::MAV_CMD_CONDITION_YAW, 0) => "heading",
        (MavCmd::MAV_CMD_DO_GIMBAL_MANAGER_PITCHYAW | MavCmd::MAV_CMD_DO_MOUNT_CONTROL, 0) => {
            "gimbal pitch"
        }
        _ => "",
    };
    if name.is_empty() {
        format!("param{}", k + 1)
    } else {
        format!("{name} (param{})", k + 1)
    }
}

/// The height ArduPilot gives back for `z`: whole centimetres, truncated
/// toward zero in single precision (`alt = z * 100.0f` into an integer,
/// read back as `alt / 100.0f`).
pub fn ardupilot_alt(z: f32) -> f32 {
    ((z * 100.0) as i32) as f32 / 100.0
}

fn same_f32(a: f32, b: f32) -> bool {
    (a.is_nan() && b.is_nan()) || (a - b).abs() <= 1e-4 * a.abs().max(1.0)
}
