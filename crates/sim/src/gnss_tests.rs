use super::*;
use vp_scene::gnss::GnssSigmas;
use vp_scene::Intrinsics;

/// A 1 km straight line of waypoints 10 m apart.
fn line() -> Vec<Point3<f64>> {
    (0..100)
        .map(|i| Point3::new(10.0 * f64::from(i), 0.0, 30.0))
        .collect()
}

/// Truth minus plan of the first waypoint over `n` flights: its horizontal
/// and vertical RMS.
fn rms_over_flights(e: &FlightError, n: u64) -> (f64, f64) {
    let plan = line();
    let (mut h2, mut v2) = (0.0, 0.0);
    for seed in 0..n {
        let f = e.fly(&plan, 5.0, 2.0, seed);
        let d = f.truth[0] - plan[0];
        h2 += d.x * d.x + d.y * d.y;
        v2 += d.z * d.z;
    }
    ((h2 / n as f64).sqrt(), (v2 / n as f64).sqrt())
}

#[test]
fn standard_gnss_is_off_by_its_class_over_many_flights() {
    let e = FlightError {
        tracking_m: 0.0,
        ..FlightError::default()
    };
    let (h, v) = rms_over_flights(&e, 4000);
    // The bias carries sqrt(1 - 0.2^2) of the class's sigma; 4000 draws:
    // the RMS is within about 2 % of its expectation.
    let k = (1.0f64 - 0.04).sqrt();
    assert!((h - 1.5 * k).abs() < 0.06, "horizontal RMS {h}");
    assert!((v - 3.0 * k).abs() < 0.12, "vertical RMS {v}");
    let rtk = FlightError {
        gnss: GnssClass::Rtk,
        ..e
    };
    let (h, v) = rms_over_flights(&rtk, 4000);
    assert!((h - 0.02 * k).abs() < 0.001, "RTK horizontal RMS {h}");
    assert!((v - 0.03 * k).abs() < 0.0015, "RTK vertical RMS {v}");
}

#[test]
fn the_bias_varies_slowly_within_a_flight_and_not_between_flights() {
    let e = FlightError {
        tracking_m: 0.0,
        white_share: 0.0,
        ..FlightError::default()
    };
    let plan = line();
    let (mut next, mut far, mut between) = (0.0, 0.0, 0.0);
    let n: u64 = 2000;
    for seed in 0..n {
        let f = e.fly(&plan, 5.0, 2.0, seed);
        let g = e.fly(&plan, 5.0, 2.0, seed + 1_000_000);
        let err = |p: &FlownPath, i: usize| (p.truth[i] - plan[i]).z;
        next += err(&f, 0) * err(&f, 1);
        far += err(&f, 0) * err(&f, 99);
        between += err(&f, 0) * err(&g, 0);
    }
    let var = 9.0 * n as f64;
    // 4 s between neighbours (10 m at 5 m/s + 2 s hover), 396 s end to end,
    // a 300 s time constant: correlations exp(-4/300) and exp(-396/300).
    let (next, far, between) = (next / var, far / var, between / var);
    assert!((next - (-4.0f64 / 300.0).exp()).abs() < 0.06, "{next}");
    assert!((far - (-396.0f64 / 300.0).exp()).abs() < 0.08, "{far}");
    assert!(between.abs() < 0.08, "{between}");
}

#[test]
fn the_tag_says_where_the_vehicle_thinks_it_is_and_tracking_is_its_sigma() {
    let e = FlightError {
        gnss: GnssClass::Custom(GnssSigmas {
            horizontal_m: 0.0,
            vertical_m: 0.0,
        }),
        ..FlightError::default()
    };
    let plan = line();
    let f = e.fly(&plan, 5.0, 2.0, 7);
    let d2: f64 = f
        .truth
        .iter()
        .zip(&plan)
        .map(|(t, p)| (t - p).norm_squared())
        .sum();
    // 100 waypoints, 3 axes of 0.2 m: RMS per axis within 20 %.
    let rms = (d2 / 300.0).sqrt();
    assert!((rms - 0.2).abs() < 0.04, "{rms}");
    assert_eq!(f.truth, f.tagged, "no GNSS error: the tag is the truth");
    let off = FlightError {
        enabled: false,
        ..FlightError::default()
    };
    assert_eq!(off.fly(&plan, 5.0, 2.0, 7).truth, plan);
}

#[test]
fn same_seed_same_flight() {
    let e = FlightError::default();
    assert_eq!(e.fly(&line(), 5.0, 2.0, 3), e.fly(&line(), 5.0, 2.0, 3));
    assert_ne!(e.fly(&line(), 5.0, 2.0, 3), e.fly(&line(), 5.0, 2.0, 4));
}

/// The georeference of a 4 x 4 nadir grid flown with standard GNSS is off
/// by the flight's bias, which the alignment residuals do not show: the
/// reason the planner's margin counts the class, not only the residuals.
#[test]
fn georeference_carries_the_bias_the_residuals_do_not_show() {
    let k = Intrinsics::new(160, 108, 213.0, 213.0, 80.0, 54.0).unwrap();
    let plan: Vec<Point3<f64>> = (0..16)
        .map(|i| Point3::new(8.0 * f64::from(i % 4), 8.0 * f64::from(i / 4), 50.0))
        .collect();
    let e = FlightError::default();
    let (mut shift2, mut rms2) = (0.0, 0.0);
    let n = 200;
    for seed in 0..n {
        let f = e.fly(&plan, 5.0, 2.0, seed);
        let cams: Vec<Camera> = f
            .truth
            .iter()
            .map(|c| Camera::from_yaw_pitch(k, *c, 0.0, -std::f64::consts::FRAC_PI_2))
            .collect();
        let al = georeference(&cams, &f.tagged, seed).unwrap();
        // Where the model puts the true centre of the grid.
        let centre = Point3::new(12.0, 12.0, 20.0);
        let d = al.sim3.apply(&centre) - centre;
        shift2 += d.norm_squared();
        rms2 += al.rms_m * al.rms_m;
    }
    let shift = (shift2 / n as f64).sqrt();
    let rms = (rms2 / n as f64).sqrt();
    // The class's 3D RMS is sqrt(1.5^2 + 3^2) = 3.35 m, 98 % of it bias.
    assert!(shift > 2.5 && shift < 4.5, "model shift RMS {shift}");
    assert!(rms < 1.0, "alignment residual RMS {rms}");
}
