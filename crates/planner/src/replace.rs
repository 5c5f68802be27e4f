//! Dropped triplets replaced: k is what the user asked for.
//!
//! M4 leaves out a triplet whose view is unsafe or that no safe route
//! reaches ([`crate::flight_path::Path::dropped`]). Its cameras still raised
//! f(t) during M3, so the later triplets were chosen as if it would be
//! flown. Here the triplets that are kept are replayed on f(t) as it was
//! before M3 (the iteration figures then count only what is flown), M3
//! searches the missing ones away from the dropped ones, and M4 routes
//! them after the path already built ([`PathContext::build_after`]: a
//! replacement never reorders, and so never costs, a triplet that can be
//! flown; re-building the whole path did, in the quick demo); until
//! nothing is dropped, nothing is found, the time budget is spent or
//! [`MAX_ROUNDS`] rounds have passed.

use std::collections::VecDeque;
use std::time::Instant;

use nalgebra::Point3;
use vp_scene::plan::{DroppedTriplet, IterationStatistics, PlannedView, Role};
use vp_scene::raycast::RayCaster;
use vp_scene::Camera;

use crate::flight_path::{Path, PathContext};
use crate::fulfillment::Fulfillment;
use crate::triplet::Candidate;

/// Most rounds of replacement searches. Each costs an M3 search per
/// missing triplet and an M4 build; a site where every replacement is
/// unreachable too (a region behind an unclimbable wall) stops here and
/// reports the triplets it could not replace.
pub(crate) const MAX_ROUNDS: usize = 4;

/// A triplet M3 chose.
#[derive(Debug, Clone)]
pub(crate) struct Chosen {
    /// Its id: the M3 iteration that chose it.
    pub(crate) id: u32,
    /// The cameras, g(c3) when chosen, bin and surrogate.
    pub(crate) best: Candidate,
    /// Wall time of the M3 search that chose it, seconds.
    pub(crate) m3_s: f64,
}

/// The views of `chosen`, in planning order.
pub(crate) fn views_of(chosen: &[Chosen]) -> Vec<PlannedView> {
    chosen
        .iter()
        .flat_map(|c| {
            c.best.cameras.iter().map(move |cam| {
                let mut v = PlannedView::from_camera(cam, Role::TripletMember);
                v.triplet_id = Some(c.id);
                v.expected_gain = Some(c.best.gain);
                v.angle_bin_deg = Some(c.best.angle_deg);
                v
            })
        })
        .collect()
}

/// Adds the cameras of `c` to `ful`; its iteration figures.
pub(crate) fn add(ful: &mut Fulfillment, c: &Chosen, caster: &RayCaster) -> IterationStatistics {
    let f_before = ful.mean_f();
    for cam in &c.best.cameras {
        ful.add_planned(cam, caster);
    }
    let mut stats = IterationStatistics {
        iteration: c.id,
        f_before,
        f_after: ful.mean_f(),
        coverage: ful.coverage(),
        time_s: std::collections::BTreeMap::default(),
    };
    stats.time_s.insert("m3".into(), c.m3_s);
    stats
}

/// Marks the surrogates within the radius of `dropped` around its own
/// surrogate: a triplet built around one of them would stand where the
/// dropped one stood, and most likely be unreachable the same way.
fn ban_around(banned: &mut [bool], surrogates: &[Point3<f64>], dropped: &Candidate) {
    let Some(&centre) = surrogates.get(dropped.surrogate) else {
        return;
    };
    let radius = dropped
        .cameras
        .iter()
        .map(|c: &Camera| (c.center() - centre).norm())
        .fold(0.0, f64::max);
    for (b, s) in banned.iter_mut().zip(surrogates) {
        if (s - centre).norm() <= radius {
            *b = true;
        }
    }
    if let Some(b) = banned.get_mut(dropped.surrogate) {
        *b = true;
    }
}

/// What the M3 searches produced: the triplets chosen and their figures.
#[derive(Debug, Default)]
pub(crate) struct M3Loop {
    /// Iteration figures, one per triplet of `chosen`.
    pub(crate) iterations: Vec<IterationStatistics>,
    /// The triplets chosen, in planning order.
    pub(crate) chosen: Vec<Chosen>,
    /// Surrogates visited by each search (dropped triplets' searches too).
    pub(crate) visited: Vec<usize>,
}

/// M3, k times or fewer.
pub(crate) trait Searcher {
    /// Searches up to `n` more triplets on `ful` (adding each to it), the
    /// `banned` surrogates skipped, ids from `next_id`; appends to `out` and
    /// returns why it found fewer than `n`.
    fn search(
        &mut self,
        ful: &mut Fulfillment,
        banned: &[bool],
        n: usize,
        next_id: u32,
        out: &mut M3Loop,
    ) -> Option<String>;
}

/// The outcome of [`Rounds::fly_or_replace`].
pub(crate) struct Flown {
    /// The path of the triplets flown.
    pub(crate) path: Path,
    /// The triplets flown, their figures (replayed when something was
    /// dropped) and the visit counts of every search.
    pub(crate) m3: M3Loop,
    /// Every dropped triplet, in the order it was dropped, with the
    /// replacement flown instead; reasons still to be worded against the
    /// final waypoints ([`PathContext::describe`]).
    pub(crate) dropped: Vec<(crate::flight_path::Dropped, Option<u32>)>,
    /// How many of the triplets M3 chose first were dropped and not
    /// replaced (a dropped replacement waits for none).
    pub(crate) unreplaced: usize,
    /// Why fewer than k triplets are flown, when some drop was not replaced.
    pub(crate) not_replaced: Option<String>,
}

/// Everything fixed during the replacement rounds.
pub(crate) struct Rounds<'a> {
    /// The path builder.
    pub(crate) ctx: &'a PathContext<'a>,
    /// The last acquired camera: where the path starts without a home.
    pub(crate) start: &'a Camera,
    /// The acquired cameras (overlap for bridging).
    pub(crate) captured: &'a [Camera],
    /// f(t) before M3.
    pub(crate) before_m3: &'a Fulfillment,
    /// M2's surrogates.
    pub(crate) surrogates: &'a [Point3<f64>],
    /// k.
    pub(crate) n_triplets: usize,
    /// The time budget's end.
    pub(crate) deadline: Option<Instant>,
}

impl Rounds<'_> {
    /// Builds the path of `chosen` and replaces what it drops (see the
    /// module doc). `ful` holds f(t) with every triplet of `chosen`, and
    /// holds f(t) with the flown ones on return.
    pub(crate) fn fly_or_replace(
        &self,
        ful: &mut Fulfillment,
        mut m3: M3Loop,
        searcher: &mut dyn Searcher,
    ) -> Flown {
        let mut path = self
            .ctx
            .build(self.start, self.captured, views_of(&m3.chosen));
        let mut dropped = Vec::new();
        let mut not_replaced = None;
        let mut banned = vec![false; self.surrogates.len()];
        let mut next_id = m3.chosen.iter().map(|c| c.id + 1).max().unwrap_or(0);
        // Ids from here are replacements: one dropped waits for no other.
        let first_replacement = next_id;
        // Dropped triplets waiting for a replacement (indices into `dropped`).
        let mut waiting: VecDeque<usize> = VecDeque::new();
        let mut round = 0;
        while !path.dropped.is_empty() {
            // `path` is safe without what it dropped.
            for d in std::mem::take(&mut path.dropped) {
                if let Some(c) = m3.chosen.iter().find(|c| c.id == d.triplet_id) {
                    ban_around(&mut banned, self.surrogates, &c.best);
                }
                m3.chosen.retain(|c| c.id != d.triplet_id);
                if d.triplet_id < first_replacement {
                    waiting.push_back(dropped.len());
                }
                dropped.push((d, None));
            }
            // What is kept, on f(t) as it was before M3.
            *ful = self.before_m3.clone();
            m3.iterations = m3
                .chosen
                .iter()
                .map(|c| add(ful, c, self.ctx.caster))
                .collect();
            let missing = self.n_triplets.saturating_sub(m3.chosen.len());
            if missing == 0 {
                break;
            }
            if round == MAX_ROUNDS {
                not_replaced = Some(format!(
                    "the replacements found in {MAX_ROUNDS} rounds could not be flown either"
                ));
                break;
            }
            if self.deadline.is_some_and(|d| Instant::now() >= d) {
                not_replaced = Some("the time budget is spent".into());
                break;
            }
            round += 1;
            let found_from = m3.chosen.len();
            not_replaced = searcher.search(ful, &banned, missing, next_id, &mut m3);
            let found = &m3.chosen[found_from..];
            if found.is_empty() {
                break;
            }
            next_id = found.iter().map(|c| c.id + 1).max().unwrap_or(next_id);
            let more = self.after(&path, views_of(found));
            // Replacements are flown in place of the oldest drops.
            let flown: Vec<u32> = found
                .iter()
                .map(|c| c.id)
                .filter(|id| !more.dropped.iter().any(|d| d.triplet_id == *id))
                .collect();
            for id in flown {
                if let Some(i) = waiting.pop_front() {
                    dropped[i].1 = Some(id);
                }
            }
            path = append(path, more);
        }
        Flown {
            path,
            m3,
            dropped,
            unreplaced: waiting.len(),
            not_replaced,
        }
    }

    /// The path of `views` flown after `path` (from the vehicle's position
    /// when `path` is empty).
    fn after(&self, path: &Path, views: Vec<PlannedView>) -> Path {
        let k = self.ctx.intrinsics;
        let mut captured = self.captured.to_vec();
        captured.extend(path.waypoints.iter().map(|w| w.to_camera(k)));
        match path.waypoints.last() {
            Some(last) => self.ctx.build_after(last, &captured, views),
            None => self.ctx.build(self.start, &captured, views),
        }
    }
}

/// `more` flown after `path`: its waypoints appended, its unbridged
/// indices shifted, its drops kept (for the next round).
fn append(mut path: Path, more: Path) -> Path {
    let n = path.waypoints.len();
    path.unbridged.extend(more.unbridged.iter().map(|i| i + n));
    path.waypoints.extend(more.waypoints);
    path.dropped = more.dropped;
    path.dropped_triplets = more.dropped_triplets;
    path.dropped_reasons = more.dropped_reasons;
    path
}

impl Flown {
    /// Why fewer than `k` triplets are flown (`None` when k are): `cut`,
    /// M3's reason when it stopped early, unless a replacement search
    /// spoke last; with the number of dropped triplets not replaced.
    pub(crate) fn cut_short_reason(&self, cut: Option<String>, k: usize) -> Option<String> {
        if self.m3.chosen.len() >= k {
            return None;
        }
        let why = self
            .not_replaced
            .clone()
            .or(cut)
            .unwrap_or_else(|| "no other triplet was found".into());
        Some(match self.unreplaced {
            0 => why,
            1 => format!("1 dropped triplet not replaced: {why}"),
            n => format!("{n} dropped triplets not replaced: {why}"),
        })
    }
}

/// The reasons of `dropped` with what became of each triplet, for
/// [`crate::PlanResult::dropped_reasons`].
pub(crate) fn reasons(dropped: &[DroppedTriplet]) -> Vec<String> {
    dropped
        .iter()
        .map(|d| match d.replaced_by {
            Some(r) => format!("{}; replaced by triplet {r}", d.reason),
            None => format!("{}; not replaced", d.reason),
        })
        .collect()
}

/// Dropped triplets for the plan file, their reasons worded against the
/// final `waypoints`.
pub(crate) fn for_plan(
    ctx: &PathContext,
    dropped: &[(crate::flight_path::Dropped, Option<u32>)],
    waypoints: &[PlannedView],
) -> Vec<DroppedTriplet> {
    dropped
        .iter()
        .map(|(d, by)| DroppedTriplet {
            triplet_id: d.triplet_id,
            reason: ctx.describe(d, waypoints),
            replaced_by: *by,
        })
        .collect()
}
