//! One held-out site as the campaign flies it: what every flight on it
//! shares ([`SiteRun`]: the world, the matcher, the configuration, the
//! forest, the measured curves, the shots of the flight under way and the
//! progress sink, passed as one instead of as eight to ten arguments), and
//! the helpers of its flights
//! that the runner (`run.rs`) and the strategies (`strategy_run.rs`) both use.

use nalgebra::Point3;
use vp_forest::Forest;
use vp_scene::plan::Plan;
use vp_scene::Camera;

use super::crash::PathCheck;
use super::curves::CurveAccumulator;
use super::reconstruct::Matcher;
use super::renders::Renders;
use crate::config::CampaignConfig;
use crate::world::World;
use vp_scene::hash::mix64;

/// The context of every flight on one held-out site.
pub(super) struct SiteRun<'a> {
    /// The site.
    pub(super) world: &'a World,
    /// The campaign's MVS.
    pub(super) matcher: &'a Matcher<'a>,
    /// The campaign.
    pub(super) cfg: &'a CampaignConfig,
    /// The forest that predicts confidence (F strategies).
    pub(super) forest: &'a Forest,
    /// The learned and measured confidence curves, added to by every flight.
    pub(super) curves: &'a mut CurveAccumulator,
    /// The shots of the flight under way: made once, for acquiring an
    /// image and for reconstructing it, and cleared when its flight is
    /// acquired and reconstructed.
    pub(super) renders: Renders<'a>,
    /// Hears one line per step.
    pub(super) progress: &'a mut dyn FnMut(&str),
}

impl SiteRun<'_> {
    /// Checks a flown path against the truth and says every violation loudly.
    pub(super) fn check_path(
        &mut self,
        check: &mut PathCheck,
        (start, path): (Option<Point3<f64>>, &[Point3<f64>]),
        label: &str,
    ) {
        let before = check.violations.len();
        let safety_m = self.cfg.planner.safety_distance_m;
        check.add(&self.world.clearance, safety_m, start, path, label);
        for v in &check.violations[before..] {
            (self.progress)(&format!("  SAFETY VIOLATION against the true mesh: {v}"));
        }
    }
}

/// A true surface point counts as in the planning mesh within this, metres.
pub(super) const MESH_TOLERANCE_M: f64 = 0.5;

pub(super) fn image_id(source: u64, index: usize) -> u64 {
    source << 32 | index as u64
}

/// Hash of a name, for seeds.
pub(super) fn name_hash(s: &str) -> u64 {
    s.bytes().fold(0xcbf2_9ce4_8422_2325, |h, b| {
        (h ^ u64::from(b)).wrapping_mul(0x100_0000_01b3)
    })
}

/// `planned` flown with the vehicle's position error (a flight of its
/// own, drawn with `seed`): the true cameras and their GNSS tags.
pub(super) fn fly_with_error(
    cfg: &CampaignConfig,
    planned: &[Camera],
    seed: u64,
) -> (Vec<Camera>, Vec<Point3<f64>>) {
    let path: Vec<Point3<f64>> = planned.iter().map(Camera::center).collect();
    let m = &cfg.planner.mission;
    let flown = cfg
        .flight_error
        .fly(&path, m.cruise_speed_m_s, m.hover_per_photo_s, mix64(seed));
    let cams = planned
        .iter()
        .zip(&flown.truth)
        .map(|(c, t)| crate::gnss::moved_to(c, t))
        .collect();
    (cams, flown.tagged)
}

/// `plan` with the simulated take-off point as its home (the missions of
/// the report are exported from it).
pub(super) fn with_home(plan: Plan, world: &World) -> Plan {
    Plan {
        home: Some(world.home()),
        ..plan
    }
}
