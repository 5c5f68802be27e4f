//! Small mission plans of triplet photos for the mission tests: the
//! protocol, the simulated vehicles and the peers only need items to move.

use vp_scene::plan::{GeodeticOrigin, Home, Plan, PlannedView, Role};

/// An origin in the Alps (the protocol tests').
pub const ALPS: GeodeticOrigin = GeodeticOrigin {
    lat_deg: 46.05,
    lon_deg: 10.32,
    alt_m: 450.0,
};

/// PX4's SITL default origin near Zurich (the peer tests').
pub const ZURICH: GeodeticOrigin = GeodeticOrigin {
    lat_deg: 47.397_742,
    lon_deg: 8.545_594,
    alt_m: 488.0,
};

/// An empty plan at `origin`, taking off from the origin on the ground.
#[must_use]
pub fn plan_at(origin: GeodeticOrigin) -> Plan {
    let mut p = Plan::new(Some(origin));
    p.home = p.origin.map(Home::origin_on_ground);
    p
}

/// A triplet photo at `position` (ENU metres from the origin).
#[must_use]
pub fn photo(
    position: [f64; 3],
    yaw_deg: f64,
    pitch_deg: f64,
    triplet_id: Option<u32>,
) -> PlannedView {
    PlannedView {
        position,
        yaw_deg,
        pitch_deg,
        roll_deg: 0.0,
        role: Role::TripletMember,
        triplet_id,
        expected_gain: None,
        angle_bin_deg: None,
    }
}

/// `n_views` photos scattered over 400 m x 300 m, 30-50 m up, at [`ALPS`]:
/// photo i from `k = i * stride + seed` (position, yaw and pitch are
/// fixed functions of k). With `triplets`, photos 3j..3j+2 form triplet j.
#[must_use]
pub fn scattered_plan(n_views: usize, seed: u64, stride: u64, triplets: bool) -> Plan {
    let mut p = plan_at(ALPS);
    for i in 0..n_views {
        let k = (i as u64 * stride + seed) as f64;
        p.waypoints.push(photo(
            [
                k * 7.3 % 400.0 - 200.0,
                k * 13.1 % 300.0 - 150.0,
                30.0 + k % 20.0,
            ],
            k * 37.0 % 360.0,
            -(k * 11.0 % 90.0),
            triplets.then_some((i / 3) as u32),
        ));
    }
    p
}
