//! Local ENU <-> WGS84, on the ellipsoid (through ECEF, not a flat-earth shortcut).
//!
//! Here at the bottom because the planner (a home projected onto the mesh),
//! the mission crate (waypoints) and `colmap align` (positions) all convert.
//!
//! The scene's world frame is the ENU tangent frame at a [`GeodeticOrigin`].
//! A point 10 km east of the origin at ENU height 0 lies about 7.8 m above
//! the ellipsoid: the tangent plane lifts off the curved earth, and this
//! module keeps that (the mesh and the cameras are real 3D points in the
//! tangent frame). Conversions go through ECEF with `map_3d` (WGS84).

use crate::error::Result;
use crate::plan::GeodeticOrigin;
use map_3d::Ellipsoid;

/// The local ENU tangent frame at a geodetic origin.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct LocalFrame {
    origin: GeodeticOrigin,
    lat0: f64,
    lon0: f64,
}

impl LocalFrame {
    /// The frame at `origin` (checked for range).
    pub fn new(origin: GeodeticOrigin) -> Result<Self> {
        origin.validate()?;
        Ok(LocalFrame {
            origin,
            lat0: origin.lat_deg.to_radians(),
            lon0: origin.lon_deg.to_radians(),
        })
    }

    /// The origin of the frame.
    pub fn origin(&self) -> GeodeticOrigin {
        self.origin
    }

    /// WGS84 position of a local ENU point (metres).
    pub fn to_geodetic(&self, enu: [f64; 3]) -> GeodeticOrigin {
        let (lat, lon, alt) = map_3d::enu2geodetic(
            enu[0],
            enu[1],
            enu[2],
            self.lat0,
            self.lon0,
            self.origin.alt_m,
            Ellipsoid::WGS84,
        );
        GeodeticOrigin {
            lat_deg: lat.to_degrees(),
            lon_deg: wrap_lon_deg(lon.to_degrees()),
            alt_m: alt,
        }
    }

    /// Local ENU coordinates (metres) of a WGS84 position.
    pub fn to_enu(&self, geo: GeodeticOrigin) -> [f64; 3] {
        let (e, n, u) = map_3d::geodetic2enu(
            geo.lat_deg.to_radians(),
            geo.lon_deg.to_radians(),
            geo.alt_m,
            self.lat0,
            self.lon0,
            self.origin.alt_m,
            Ellipsoid::WGS84,
        );
        [e, n, u]
    }

    /// Compass heading (degrees clockwise from true north at `enu`, in
    /// [0, 360)) of the horizontal direction `yaw_deg` (degrees
    /// counter-clockwise from the origin's east axis).
    ///
    /// Away from the origin, true north turns against the frame's north
    /// (meridian convergence, about 0.1 deg at 10 km east at 46 deg N);
    /// the direction is carried through ECEF into the local frame at the
    /// point so the heading is exact there.
    pub fn compass_heading_deg(&self, enu: [f64; 3], yaw_deg: f64) -> f64 {
        let (s, c) = yaw_deg.to_radians().sin_cos();
        let ecef_dir = map_3d::enu2uvw(c, s, 0.0, self.lat0, self.lon0);
        let here = self.to_geodetic(enu);
        let (e, n, _) = map_3d::uvw2enu(
            ecef_dir.0,
            ecef_dir.1,
            ecef_dir.2,
            here.lat_deg.to_radians(),
            here.lon_deg.to_radians(),
        );
        e.atan2(n).to_degrees().rem_euclid(360.0)
    }
}

/// Wraps a longitude into [-180, 180).
fn wrap_lon_deg(lon: f64) -> f64 {
    (lon + 180.0).rem_euclid(360.0) - 180.0
}

/// Compass heading (clockwise from north) of an ENU yaw (counter-clockwise
/// from east), both degrees, result in [0, 360). Flat-frame version of
/// [`LocalFrame::compass_heading_deg`].
pub fn compass_from_enu_yaw_deg(yaw_deg: f64) -> f64 {
    (90.0 - yaw_deg).rem_euclid(360.0)
}

#[cfg(test)]
mod tests {
    use super::*;
    use proptest::prelude::*;

    const A: f64 = 6_378_137.0;

    fn frame(lat: f64, lon: f64, alt: f64) -> LocalFrame {
        LocalFrame::new(GeodeticOrigin {
            lat_deg: lat,
            lon_deg: lon,
            alt_m: alt,
        })
        .unwrap()
    }

    #[test]
    fn known_points_on_the_equator() {
        // At the equator the ellipsoid's cross-section is a circle of radius a:
        // 10 km east along the tangent plane is at lon = atan(10 km / a) and
        // height sqrt(a^2 + (10 km)^2) - a above the ellipsoid, exactly.
        let f = frame(0.0, 0.0, 0.0);
        let g = f.to_geodetic([10_000.0, 0.0, 0.0]);
        let lon = (10_000.0f64 / A).atan().to_degrees();
        let h = (A * A + 1e8).sqrt() - A;
        assert!(g.lat_deg.abs() < 1e-12, "{g:?}");
        assert!((g.lon_deg - lon).abs() < 1e-11, "{g:?} vs {lon}");
        assert!((g.alt_m - h).abs() < 1e-4, "{} vs {h}", g.alt_m);
        assert!((h - 7.839).abs() < 1e-3);
    }

    #[test]
    fn known_point_north_pole_and_meridian() {
        // Straight up from the origin stays on the same lat/lon.
        let f = frame(46.0, 10.3, 300.0);
        let g = f.to_geodetic([0.0, 0.0, 120.0]);
        assert!((g.lat_deg - 46.0).abs() < 1e-12 && (g.lon_deg - 10.3).abs() < 1e-12);
        assert!((g.alt_m - 420.0).abs() < 1e-6);
        // 44.5 N -> 45.5 N on the meridian: the closed-form ECEF positions
        // (N = a / sqrt(1 - e^2 sin^2 phi), computed independently) are
        // 111,130.367 m apart; the meridian arc itself is 111,131.78 m.
        let f = frame(44.5, 0.0, 0.0);
        let enu = f.to_enu(GeodeticOrigin {
            lat_deg: 45.5,
            lon_deg: 0.0,
            alt_m: 0.0,
        });
        let chord = (enu[1] * enu[1] + enu[2] * enu[2]).sqrt();
        assert!((chord - 111_130.367).abs() < 1e-3, "chord {chord}");
        assert!(enu[0].abs() < 1e-6);
    }

    #[test]
    fn compass_heading_matches_flat_convention_at_origin() {
        let f = frame(46.0, 10.3, 0.0);
        for yaw in [0.0, 90.0, 180.0, 270.0, 33.0] {
            let h = f.compass_heading_deg([0.0, 0.0, 0.0], yaw);
            let flat = compass_from_enu_yaw_deg(yaw);
            let d = (h - flat + 180.0).rem_euclid(360.0) - 180.0;
            assert!(d.abs() < 1e-9, "yaw {yaw}: {h} vs {flat}");
        }
        // East of the origin (northern hemisphere) true north turns west,
        // towards the pole, so the frame's north reads as a heading slightly
        // east of north: convergence ~ dlon * sin(lat).
        let h = f.compass_heading_deg([10_000.0, 0.0, 0.0], 90.0);
        let dlon = f.to_geodetic([10_000.0, 0.0, 0.0]).lon_deg - 10.3;
        let expect = dlon * 46f64.to_radians().sin();
        assert!((h - expect).abs() < 1e-3, "{h} vs {expect}");
    }

    proptest! {
        #![proptest_config(ProptestConfig::with_cases(64))]
        #[test]
        fn round_trip_below_a_millimetre_over_10_km(
            lat in -80.0f64..80.0, lon in -179.0f64..179.0, alt in -100.0f64..3000.0,
            e in -10_000.0f64..10_000.0, n in -10_000.0f64..10_000.0, u in -200.0f64..1500.0,
        ) {
            let f = frame(lat, lon, alt);
            let back = f.to_enu(f.to_geodetic([e, n, u]));
            let err = ((back[0] - e).powi(2) + (back[1] - n).powi(2) + (back[2] - u).powi(2)).sqrt();
            prop_assert!(err < 1e-3, "error {err} m");
        }
    }
}
