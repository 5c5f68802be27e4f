//! How much of a mission fits a vehicle that holds a limited number of
//! items, so that a "no space" rejection can say how to split the plan
//! into flights.

use mavlink::dialects::common::MavCmd;

use super::{Autopilot, Mission};

impl Mission {
    /// `(items per photo, other items)`: the other items are those of the
    /// flight itself (ArduPilot's home at seq 0, takeoff, speed, return to
    /// launch), the rest come in equal groups per photo.
    pub fn items_per_photo(&self) -> (usize, usize) {
        let other = self
            .items
            .iter()
            .filter(|i| {
                matches!(
                    i.command,
                    MavCmd::MAV_CMD_NAV_TAKEOFF
                        | MavCmd::MAV_CMD_DO_CHANGE_SPEED
                        | MavCmd::MAV_CMD_NAV_RETURN_TO_LAUNCH
                )
            })
            .count()
            + usize::from(self.autopilot == Autopilot::ArduPilot);
        let per_photo = self
            .items
            .len()
            .saturating_sub(other)
            .checked_div(self.photos)
            .unwrap_or(0);
        (per_photo, other)
    }

    /// For a vehicle that holds `capacity` items: the most photos one
    /// flight can carry and the number of flights the plan needs, or
    /// `None` when not even one photo fits.
    pub fn flights_for(&self, capacity: usize) -> Option<(usize, usize)> {
        let (per_photo, other) = self.items_per_photo();
        let per_flight = capacity.saturating_sub(other).checked_div(per_photo)?;
        if per_flight == 0 {
            return None;
        }
        Some((per_flight, self.photos.div_ceil(per_flight)))
    }
}

/// The item capacity a vehicle states in its own words: ArduPilot's
/// "Only 650 items are supported".
pub fn stated_capacity(said: &[String]) -> Option<usize> {
    said.iter().find_map(|t| {
        let rest = t.strip_prefix("Only ")?;
        let (n, tail) = rest.split_once(' ')?;
        tail.starts_with("items").then(|| n.parse().ok()).flatten()
    })
}
