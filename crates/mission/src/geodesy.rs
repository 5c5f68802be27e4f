//! MAVLink's integer coordinates (degrees * 1e7); the ENU <-> WGS84
//! conversions live in [`vp_scene::geodesy`] and are re-exported here.

pub use vp_scene::geodesy::{compass_from_enu_yaw_deg, LocalFrame};

use crate::error::{MissionError, Result};

/// Latitude or longitude in degrees as the MAVLink integer (degrees * 1e7).
pub fn deg_to_e7(deg: f64) -> Result<i32> {
    let v = (deg * 1e7).round();
    if v.is_finite() && v.abs() <= f64::from(i32::MAX) {
        Ok(v as i32)
    } else {
        Err(MissionError::InvalidInput(format!(
            "coordinate {deg} deg does not fit the MAVLink degE7 integer"
        )))
    }
}

/// MAVLink integer degrees * 1e7 back to degrees.
pub fn e7_to_deg(v: i32) -> f64 {
    f64::from(v) * 1e-7
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn e7_encoding() {
        assert_eq!(deg_to_e7(46.123_456_78).unwrap(), 461_234_568);
        assert!((e7_to_deg(461_234_568) - 46.123_456_8).abs() < 1e-12);
        assert!(deg_to_e7(f64::NAN).is_err());
    }
}
