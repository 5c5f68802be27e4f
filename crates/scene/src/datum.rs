//! Vertical datums and the take-off (home) position.
//!
//! An altitude means nothing without its datum. GNSS receivers compute
//! heights above the WGS84 ellipsoid; most drones write height above mean
//! sea level (the EGM96 geoid) into a photo's EXIF; autopilots fly missions
//! in heights relative to the take-off point (`MAV_FRAME_GLOBAL_RELATIVE_ALT`).
//! The geoid lies up to about ±100 m from the ellipsoid, so mixing them puts
//! a drone tens of metres too low. A plan therefore records the datum of its
//! altitudes ([`VerticalDatum`]) and where the vehicle takes off ([`Home`]):
//! relative altitudes are then altitudes above that point, not above the
//! plan's origin, which `vpctl colmap align` puts at the first photo (in the air).
//!
//! Ellipsoid <-> EGM96 uses the `egm96` crate's spherical-harmonic model of
//! the geoid (degree 360, computed offline from the coefficients it ships;
//! no raster download).

use serde::{Deserialize, Serialize};

use crate::error::{Result, SceneError};
use crate::plan::GeodeticOrigin;

/// What an altitude is measured from.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum VerticalDatum {
    /// Height above the WGS84 ellipsoid (what a GNSS receiver computes).
    Ellipsoid,
    /// Height above mean sea level, the EGM96 geoid (EXIF `GPSAltitude` on
    /// most drones, MAVLink's "AMSL").
    Egm96,
    /// Height above the take-off point (a flight log's or DJI's relative
    /// altitude): the home's altitude is 0 by definition, and the absolute
    /// height of nothing is known.
    Takeoff,
}

impl VerticalDatum {
    /// The name used in files and on the command line.
    pub fn name(self) -> &'static str {
        match self {
            VerticalDatum::Ellipsoid => "ellipsoid",
            VerticalDatum::Egm96 => "egm96",
            VerticalDatum::Takeoff => "takeoff",
        }
    }

    /// Converts an altitude at (`lat_deg`, `lon_deg`) from this datum to `to`.
    /// Between the ellipsoid and the geoid: h = H + N (N the geoid height of
    /// EGM96). Heights relative to the take-off point convert to nothing but
    /// themselves: the error says what is missing.
    pub fn convert(self, alt_m: f64, lat_deg: f64, lon_deg: f64, to: VerticalDatum) -> Result<f64> {
        use VerticalDatum::{Egm96, Ellipsoid, Takeoff};
        match (self, to) {
            (a, b) if a == b => Ok(alt_m),
            (Egm96, Ellipsoid) => Ok(alt_m + geoid_height_m(lat_deg, lon_deg)),
            (Ellipsoid, Egm96) => Ok(alt_m - geoid_height_m(lat_deg, lon_deg)),
            (a, b) => {
                debug_assert!(a == Takeoff || b == Takeoff);
                Err(SceneError::InvalidArgument(format!(
                    "cannot convert an altitude from datum {} to {}: heights relative to the \
                     take-off point have no absolute reference; give both in the same datum",
                    a.name(),
                    b.name()
                )))
            }
        }
    }
}

impl std::str::FromStr for VerticalDatum {
    type Err = SceneError;
    fn from_str(s: &str) -> Result<Self> {
        match s.trim().to_ascii_lowercase().as_str() {
            "ellipsoid" | "wgs84" | "hae" => Ok(VerticalDatum::Ellipsoid),
            "egm96" | "amsl" | "msl" => Ok(VerticalDatum::Egm96),
            "takeoff" | "relative" => Ok(VerticalDatum::Takeoff),
            other => Err(SceneError::InvalidArgument(format!(
                "unknown vertical datum {other:?}: expected ellipsoid (WGS84), egm96 (above \
                 mean sea level) or takeoff (relative to the take-off point)"
            ))),
        }
    }
}

/// Height of the EGM96 geoid above the WGS84 ellipsoid at a position, metres.
pub fn geoid_height_m(lat_deg: f64, lon_deg: f64) -> f64 {
    egm96::egm96_compute_altitude_offset(lat_deg, lon_deg)
}

/// Where the vehicle takes off and lands: relative altitudes refer to it.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Home {
    /// Position on the ground; the altitude is in the plan's vertical datum.
    pub position: GeodeticOrigin,
    /// How it was found, for the operator: `--home`, the first image
    /// projected onto the mesh, the origin on the ground, ...
    pub source: String,
}

impl Home {
    /// The plan's origin as the take-off point: for frames whose origin
    /// lies on the ground where the vehicle launches (the simulator's).
    pub fn origin_on_ground(origin: GeodeticOrigin) -> Home {
        Home {
            position: origin,
            source: "the plan's origin, on the ground".into(),
        }
    }

    /// A home given in `datum`, expressed in the plan's datum `plan_datum`
    /// (converted through the geoid where they differ). A datum-less plan
    /// (`None`, files from before datums were recorded) only takes a home in
    /// an unstated datum too: mixing would guess.
    pub fn in_datum(
        position: GeodeticOrigin,
        datum: Option<VerticalDatum>,
        plan_datum: Option<VerticalDatum>,
        source: impl Into<String>,
    ) -> Result<Home> {
        position.validate()?;
        let alt_m = match (datum, plan_datum) {
            (None, _) => position.alt_m,
            (Some(d), Some(p)) => {
                d.convert(position.alt_m, position.lat_deg, position.lon_deg, p)?
            }
            (Some(d), None) => {
                return Err(SceneError::InvalidArgument(format!(
                    "the home's altitude is given in datum {} but the plan does not say which \
                     datum its altitudes use (a plan from before datums were recorded, or an \
                     --origin without --datum): give the home without a datum, in the same \
                     datum as the plan's origin, or plan again with --datum",
                    d.name()
                )))
            }
        };
        Ok(Home {
            position: GeodeticOrigin { alt_m, ..position },
            source: source.into(),
        })
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn geoid_heights_match_nga_egm96_test_points() {
        // The test points NGA publishes with its EGM96 geoid program
        // (OUTINTPT.DAT, interpolated on the 15' grid): the spherical
        // harmonics agree within centimetres.
        let nga = [
            (38.628_155, 269.779_155, -31.628),
            (-14.621_217, 305.021_114, -2.969),
            (46.874_319, 102.448_729, -43.575),
            (-23.617_446, 133.874_712, 15.871),
            (38.625_473, 359.999_500, 50.066),
            (-0.466_744, 0.002_300, 17.329),
        ];
        for (lat, lon, n) in nga {
            let got = geoid_height_m(lat, lon);
            assert!((got - n).abs() < 0.1, "{lat} {lon}: {got} vs {n}");
        }
    }

    #[test]
    fn ellipsoid_and_egm96_convert_both_ways() {
        let amsl = 400.0;
        let h = VerticalDatum::Egm96
            .convert(amsl, 46.03, 10.35, VerticalDatum::Ellipsoid)
            .unwrap();
        assert!((h - amsl - geoid_height_m(46.03, 10.35)).abs() < 1e-9);
        let back = VerticalDatum::Ellipsoid
            .convert(h, 46.03, 10.35, VerticalDatum::Egm96)
            .unwrap();
        assert!((back - amsl).abs() < 1e-9);
    }

    #[test]
    fn takeoff_heights_do_not_convert_to_absolute_ones() {
        let e = VerticalDatum::Takeoff
            .convert(40.0, 46.0, 10.0, VerticalDatum::Egm96)
            .unwrap_err()
            .to_string();
        assert!(e.contains("take-off"), "{e}");
    }

    #[test]
    fn a_home_with_a_datum_refuses_a_datumless_plan() {
        let p = GeodeticOrigin::new(46.0, 10.0, 400.0).unwrap();
        assert!(Home::in_datum(p, Some(VerticalDatum::Egm96), None, "--home").is_err());
        let same = Home::in_datum(p, None, None, "--home").unwrap();
        assert!((same.position.alt_m - 400.0).abs() < 1e-12);
        let conv = Home::in_datum(
            p,
            Some(VerticalDatum::Egm96),
            Some(VerticalDatum::Ellipsoid),
            "--home",
        )
        .unwrap();
        assert!(conv.position.alt_m > 430.0, "{conv:?}");
    }
}
