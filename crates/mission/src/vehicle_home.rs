//! The plan's home against the vehicle's: a mission's relative altitudes
//! are heights above the point where the vehicle set its home, so a
//! vehicle whose home lies metres from (or above) the plan's flies every
//! waypoint that much off. `mission upload` compares them before it
//! touches the vehicle's mission.

use vp_scene::datum::VerticalDatum;
use vp_scene::geodesy::LocalFrame;
use vp_scene::plan::GeodeticOrigin;

use crate::error::{MissionError, Result};

/// Largest horizontal offset accepted without `--accept-home-offset`, metres
/// (standard GNSS wanders about 1.5 m; more means another take-off point).
pub const MAX_HORIZONTAL_OFFSET_M: f64 = 5.0;
/// Largest vertical offset accepted, metres.
pub const MAX_VERTICAL_OFFSET_M: f64 = 2.0;

/// What the comparison found.
#[derive(Debug, Clone, PartialEq)]
pub enum HomeCheck {
    /// The vehicle reported no home (no fix yet, or it does not answer).
    NotReported,
    /// The vehicle's home, and how far it lies from the plan's: horizontal
    /// metres and vertical metres (`None` when the plan's datum cannot be
    /// compared with mean sea level).
    Reported {
        /// The vehicle's home (altitude above mean sea level).
        vehicle: GeodeticOrigin,
        /// Horizontal distance, metres.
        horizontal_m: f64,
        /// Vehicle minus plan altitude, metres, where comparable.
        vertical_m: Option<f64>,
        /// True when the offset exceeds the limits and was accepted.
        accepted_offset: bool,
    },
}

impl std::fmt::Display for HomeCheck {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match self {
            HomeCheck::NotReported => write!(
                f,
                "the vehicle reported no home position (no GNSS fix yet?): the plan's home \
                 could not be checked; check the vehicle's home before take-off"
            ),
            HomeCheck::Reported {
                horizontal_m,
                vertical_m,
                accepted_offset,
                ..
            } => {
                write!(f, "vehicle home {horizontal_m:.1} m from the plan's")?;
                match vertical_m {
                    Some(v) => write!(f, ", {v:+.1} m in height")?,
                    None => write!(
                        f,
                        " (height not comparable: the plan's datum is not above sea level)"
                    )?,
                }
                if *accepted_offset {
                    write!(f, "; offset ACCEPTED by --accept-home-offset")?;
                }
                Ok(())
            }
        }
    }
}

/// [`compare_home`]'s refusal: the vehicle's home lies beyond the limits
/// from the plan's.
#[derive(Debug, Clone, PartialEq)]
pub struct HomeOffset {
    /// The vehicle's home (altitude above mean sea level).
    pub vehicle: GeodeticOrigin,
    /// Horizontal distance from the plan's home, metres.
    pub horizontal_m: f64,
    /// Vehicle minus plan altitude, metres, where comparable.
    pub vertical_m: Option<f64>,
}

impl HomeOffset {
    /// The refusal with the next steps in the caller's words: `home`, how
    /// to give the real home (`--home LAT,LON,ALT` on the command line),
    /// and `accept`, how to accept the offset (`--accept-home-offset`).
    pub fn message(&self, home: &str, accept: &str) -> String {
        let v = &self.vehicle;
        format!(
            "the vehicle's home ({:.7},{:.7}, {:.1} m above sea level) is {:.1} m from the \
             plan's home{}; the mission's heights are above the vehicle's home, so every \
             waypoint would be off by that much. Launch from the plan's home, give the real \
             one ({home}), or pass {accept} if you know why (limits: \
             {MAX_HORIZONTAL_OFFSET_M} m across, {MAX_VERTICAL_OFFSET_M} m in height)",
            v.lat_deg,
            v.lon_deg,
            v.alt_m,
            self.horizontal_m,
            self.vertical_m
                .map_or(String::new(), |d| format!(" and {d:+.1} m in height"))
        )
    }
}

impl std::fmt::Display for HomeOffset {
    /// In the command line's words.
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str(&self.message("--home LAT,LON,ALT", "--accept-home-offset"))
    }
}

/// Compares the vehicle's home (`vehicle`, above mean sea level) with the
/// plan's `home` in `datum`; refuses an offset beyond the limits unless
/// `accept_offset`.
pub fn compare_home(
    home: &GeodeticOrigin,
    datum: Option<VerticalDatum>,
    vehicle: Option<GeodeticOrigin>,
    accept_offset: bool,
) -> Result<HomeCheck> {
    let Some(v) = vehicle else {
        return Ok(HomeCheck::NotReported);
    };
    let e = LocalFrame::new(*home)?.to_enu(v);
    let horizontal_m = e[0].hypot(e[1]);
    let plan_msl = match datum {
        Some(VerticalDatum::Egm96) => Some(home.alt_m),
        Some(d @ VerticalDatum::Ellipsoid) => {
            Some(d.convert(home.alt_m, home.lat_deg, home.lon_deg, VerticalDatum::Egm96)?)
        }
        Some(VerticalDatum::Takeoff) | None => None,
    };
    let vertical_m = plan_msl.map(|p| v.alt_m - p);
    let off = horizontal_m > MAX_HORIZONTAL_OFFSET_M
        || vertical_m.is_some_and(|d| d.abs() > MAX_VERTICAL_OFFSET_M);
    if off && !accept_offset {
        return Err(MissionError::HomeOffset(HomeOffset {
            vehicle: v,
            horizontal_m,
            vertical_m,
        }));
    }
    Ok(HomeCheck::Reported {
        vehicle: v,
        horizontal_m,
        vertical_m,
        accepted_offset: off,
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    const HOME: GeodeticOrigin = GeodeticOrigin {
        lat_deg: 46.03,
        lon_deg: 10.35,
        alt_m: 400.0,
    };

    #[test]
    fn offsets_beyond_the_limits_are_refused_unless_accepted() {
        let near = GeodeticOrigin {
            lat_deg: HOME.lat_deg + 2.0 / 111_000.0,
            alt_m: 401.0,
            ..HOME
        };
        let c = compare_home(&HOME, Some(VerticalDatum::Egm96), Some(near), false).unwrap();
        assert!(
            matches!(
                c,
                HomeCheck::Reported {
                    accepted_offset: false,
                    ..
                }
            ),
            "{c}"
        );
        let far = GeodeticOrigin {
            lat_deg: HOME.lat_deg + 20.0 / 111_000.0,
            ..HOME
        };
        let e = compare_home(&HOME, Some(VerticalDatum::Egm96), Some(far), false)
            .unwrap_err()
            .to_string();
        assert!(
            e.contains("20.0 m") && e.contains("--accept-home-offset"),
            "{e}"
        );
        assert!(compare_home(&HOME, Some(VerticalDatum::Egm96), Some(far), true).is_ok());
        let high = GeodeticOrigin {
            alt_m: 403.5,
            ..HOME
        };
        let e = compare_home(&HOME, Some(VerticalDatum::Egm96), Some(high), false).unwrap_err();
        assert!(e.to_string().contains("+3.5 m in height"), "{e}");
        // A take-off datum has no sea level to compare with: only across.
        let c = compare_home(&HOME, Some(VerticalDatum::Takeoff), Some(high), false).unwrap();
        assert!(c.to_string().contains("not comparable"), "{c}");
        assert_eq!(
            compare_home(&HOME, None, None, false).unwrap(),
            HomeCheck::NotReported
        );
    }

    #[test]
    fn an_ellipsoidal_home_is_compared_above_sea_level() {
        // The geoid lies about 48 m above the ellipsoid near Capo di Ponte.
        let n = vp_scene::datum::geoid_height_m(HOME.lat_deg, HOME.lon_deg);
        let plan = GeodeticOrigin {
            alt_m: 400.0 + n,
            ..HOME
        };
        let vehicle = GeodeticOrigin {
            alt_m: 400.0,
            ..HOME
        };
        let c = compare_home(&plan, Some(VerticalDatum::Ellipsoid), Some(vehicle), false).unwrap();
        match c {
            HomeCheck::Reported {
                vertical_m: Some(v),
                ..
            } => assert!(v.abs() < 0.01, "{v}"),
            other => panic!("{other}"),
        }
    }
}
