//! Verification of an upload: the mission read back against the one sent.

use super::{float_frame, Autopilot, MissionItem};
use crate::error::{MissionError, Result};

/// Compares an uploaded mission with the one read back, item by item.
///
/// Integers (command, lat/lon, raw param5/6) must match exactly; floats
/// match bit for bit or within 1e-4 relative (NaN equals NaN); altitudes
/// within 1 cm (ArduPilot stores centimetres). Frames compare by their float
/// synonym, and only for positional items (vehicles report DO items in
/// various frames). With ArduPilot, seq 0 (home, rewritten by the vehicle)
/// is skipped and params of positional items are not compared (ArduCopter
/// does not store waypoint params 2-4).
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
    let skip = usize::from(autopilot == Autopilot::ArduPilot);
    for (seq, (a, b)) in sent.iter().zip(got).enumerate().skip(skip) {
        let mismatch = |detail: String| Err(MissionError::VerifyMismatch { seq, detail });
        if a.command != b.command {
            return mismatch(format!("command {:?} vs {:?}", a.command, b.command));
        }
        if a.is_positional() && float_frame(a.frame) != float_frame(b.frame) {
            return mismatch(format!("frame {:?} vs {:?}", a.frame, b.frame));
        }
        if a.x != b.x || a.y != b.y {
            return mismatch(format!("x/y ({}, {}) vs ({}, {})", a.x, a.y, b.x, b.y));
        }
        let z_ok = if a.is_positional() {
            (a.z - b.z).abs() <= 0.01
        } else {
            same_f32(a.z, b.z)
        };
        if !z_ok {
            return mismatch(format!("z {} vs {}", a.z, b.z));
        }
        let check_params = !(autopilot == Autopilot::ArduPilot && a.is_positional());
        if check_params {
            for k in 0..4 {
                if !same_f32(a.params[k], b.params[k]) {
                    return mismatch(format!("param{} {} vs {}", k + 1, a.params[k], b.params[k]));
                }
            }
        }
    }
    Ok(())
}

fn same_f32(a: f32, b: f32) -> bool {
    (a.is_nan() && b.is_nan()) || (a - b).abs() <= 1e-4 * a.abs().max(1.0)
}
