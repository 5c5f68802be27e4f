//! A [`Link`] to an in-process [`MissionServer`] in virtual time, with
//! seeded loss, duplication and reordering.
//!
//! Nothing sleeps: a receive timeout advances the virtual clock to the
//! next event. The same seed gives the same run, message for message, so
//! protocol behaviour under loss can be tested exactly and fast.

use std::time::Duration;

use mavlink::dialects::common::MavMessage;
use mavlink::MavHeader;
use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;

use super::relay::{Impairment, ImpairmentCounts};
use super::vehicle::MissionServer;
use crate::error::Result;
use crate::protocol::{Link, GCS_COMPONENT_ID, GCS_SYSTEM_ID};

struct InFlight {
    at: Duration,
    order: u64,
    msg: MavMessage,
}

/// The ground's end of a simulated link to a simulated vehicle.
pub struct SimLink {
    /// The vehicle at the other end.
    pub vehicle: MissionServer,
    /// One-way delay of an undisturbed message.
    pub latency: Duration,
    impairment: Impairment,
    rng: ChaCha8Rng,
    now: Duration,
    order: u64,
    to_vehicle: Vec<InFlight>,
    to_ground: Vec<InFlight>,
    /// What the impairment did so far.
    pub counts: ImpairmentCounts,
}

impl SimLink {
    /// A link with 1 ms latency and the given impairment, seeded.
    pub fn new(vehicle: MissionServer, impairment: Impairment, seed: u64) -> Self {
        SimLink {
            vehicle,
            latency: Duration::from_millis(1),
            impairment,
            rng: ChaCha8Rng::seed_from_u64(seed),
            now: Duration::ZERO,
            order: 0,
            to_vehicle: Vec::new(),
            to_ground: Vec::new(),
            counts: ImpairmentCounts::default(),
        }
    }

    fn schedule(&mut self, msg: &MavMessage, to_vehicle: bool) {
        self.counts.received += 1;
        if self.rng.random::<f64>() < self.impairment.drop {
            self.counts.dropped += 1;
            return;
        }
        let copies = if self.rng.random::<f64>() < self.impairment.duplicate {
            self.counts.duplicated += 1;
            2
        } else {
            1
        };
        for _ in 0..copies {
            let mut delay = self.latency;
            if self.rng.random::<f64>() < self.impairment.reorder {
                // Held back long enough for later messages to overtake it.
                self.counts.reordered += 1;
                delay += self.latency * self.rng.random_range(2..6);
            }
            self.order += 1;
            let f = InFlight {
                at: self.now + delay,
                order: self.order,
                msg: msg.clone(),
            };
            self.counts.passed += 1;
            if to_vehicle {
                self.to_vehicle.push(f);
            } else {
                self.to_ground.push(f);
            }
        }
    }

    fn earliest(q: &[InFlight]) -> Option<(usize, Duration)> {
        q.iter()
            .enumerate()
            .min_by_key(|(_, f)| (f.at, f.order))
            .map(|(i, f)| (i, f.at))
    }
}

impl Link for SimLink {
    fn send(&mut self, msg: &MavMessage) -> Result<()> {
        self.schedule(msg, true);
        Ok(())
    }

    fn recv(&mut self, timeout: Duration) -> Result<Option<(MavHeader, MavMessage)>> {
        let end = self.now + timeout;
        let ground = MavHeader {
            system_id: u32::from(GCS_SYSTEM_ID),
            component_id: GCS_COMPONENT_ID,
            sequence: 0,
        };
        loop {
            let g = Self::earliest(&self.to_ground);
            let v = Self::earliest(&self.to_vehicle);
            let w = self.vehicle.next_wakeup();
            let next = [g.map(|x| x.1), v.map(|x| x.1), w]
                .into_iter()
                .flatten()
                .min();
            let Some(t) = next.filter(|&t| t <= end) else {
                self.now = end;
                return Ok(None);
            };
            self.now = self.now.max(t);
            if let Some((i, at)) = g.filter(|&(_, at)| at == t) {
                let _ = at;
                let f = self.to_ground.swap_remove(i);
                return Ok(Some((self.vehicle.header(), f.msg)));
            }
            let out = if let Some((i, _)) = v.filter(|&(_, at)| at == t) {
                let f = self.to_vehicle.swap_remove(i);
                self.vehicle.handle(self.now, &ground, &f.msg)
            } else {
                self.vehicle.poll(self.now)
            };
            for m in out {
                self.schedule(&m, false);
            }
        }
    }

    fn now(&self) -> Duration {
        self.now
    }
}
