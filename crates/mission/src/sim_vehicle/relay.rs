//! A lossy UDP relay between a ground station and a vehicle on loopback:
//! drops, duplicates and reorders datagrams at seeded, configurable rates.
//!
//! The ground connects (`udpout:`) to [`UdpRelay::addr`]; the relay forwards
//! to the vehicle's address and sends the vehicle's answers back to the
//! last ground address it heard from. Each direction runs on its own thread
//! with its own seeded generator; the thread timing makes a run
//! reproducible in distribution, not packet for packet (use
//! [`super::sim::SimLink`] for exact replay).

use std::net::{SocketAddr, UdpSocket};
use std::sync::atomic::{AtomicBool, AtomicU64, Ordering};
use std::sync::{Arc, Mutex, PoisonError};
use std::thread::JoinHandle;
use std::time::{Duration, Instant};

use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;

use crate::error::{MissionError, Result};

/// Per-datagram impairment probabilities, each in [0, 1].
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct Impairment {
    /// Probability that a datagram is lost.
    pub drop: f64,
    /// Probability that a (not lost) datagram is delivered twice.
    pub duplicate: f64,
    /// Probability that a datagram is held back and overtaken by the next one.
    pub reorder: f64,
}

/// What an impairment did (plain numbers).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub struct ImpairmentCounts {
    /// Datagrams the two ends sent into the link (before loss and
    /// duplication): the traffic the protocol itself made.
    pub received: u64,
    /// Datagrams delivered (duplicates included).
    pub passed: u64,
    /// Datagrams lost.
    pub dropped: u64,
    /// Datagrams delivered twice.
    pub duplicated: u64,
    /// Datagrams delivered out of order.
    pub reordered: u64,
}

#[derive(Default)]
struct Counters {
    received: AtomicU64,
    passed: AtomicU64,
    dropped: AtomicU64,
    duplicated: AtomicU64,
    reordered: AtomicU64,
}

/// A running relay; stops when dropped.
pub struct UdpRelay {
    addr: SocketAddr,
    counters: Arc<Counters>,
    stop: Arc<AtomicBool>,
    threads: Vec<JoinHandle<()>>,
}

/// Longest a reordered datagram is held when nothing overtakes it.
const MAX_HOLD: Duration = Duration::from_millis(3);

impl UdpRelay {
    /// Starts a relay on a free loopback port, forwarding to `vehicle`.
    pub fn spawn(vehicle: SocketAddr, impairment: Impairment, seed: u64) -> Result<Self> {
        let io = |e: std::io::Error| MissionError::Link(format!("relay: {e}"));
        let front = UdpSocket::bind("127.0.0.1:0").map_err(io)?;
        let back = UdpSocket::bind("127.0.0.1:0").map_err(io)?;
        back.connect(vehicle).map_err(io)?;
        for s in [&front, &back] {
            s.set_read_timeout(Some(Duration::from_millis(1)))
                .map_err(io)?;
        }
        let addr = front.local_addr().map_err(io)?;
        let counters = Arc::new(Counters::default());
        let stop = Arc::new(AtomicBool::new(false));
        let ground: Arc<Mutex<Option<SocketAddr>>> = Arc::new(Mutex::new(None));
        let mut threads = Vec::new();
        // Ground -> vehicle.
        {
            let (rx, tx) = (
                front.try_clone().map_err(io)?,
                back.try_clone().map_err(io)?,
            );
            let (c, s, g) = (
                Arc::clone(&counters),
                Arc::clone(&stop),
                Arc::clone(&ground),
            );
            threads.push(std::thread::spawn(move || {
                let mut pipe = Pipe::new(impairment, seed, c);
                pipe.run(
                    &s,
                    |buf| {
                        let (n, from) = rx.recv_from(buf)?;
                        *g.lock().unwrap_or_else(PoisonError::into_inner) = Some(from);
                        Ok(n)
                    },
                    |data| {
                        let _ = tx.send(data);
                    },
                );
            }));
        }
        // Vehicle -> ground.
        {
            let (c, s, g) = (
                Arc::clone(&counters),
                Arc::clone(&stop),
                Arc::clone(&ground),
            );
            threads.push(std::thread::spawn(move || {
                let mut pipe = Pipe::new(impairment, seed ^ 0x9e37_79b9_7f4a_7c15, c);
                pipe.run(
                    &s,
                    |buf| back.recv(buf),
                    |data| {
                        if let Some(to) = *g.lock().unwrap_or_else(PoisonError::into_inner) {
                            let _ = front.send_to(data, to);
                        }
                    },
                );
            }));
        }
        Ok(UdpRelay {
            addr,
            counters,
            stop,
            threads,
        })
    }

    /// Where the ground station should send (`udpout:ADDR`).
    pub fn addr(&self) -> SocketAddr {
        self.addr
    }

    /// What the relay did so far.
    pub fn counts(&self) -> ImpairmentCounts {
        let c = &self.counters;
        ImpairmentCounts {
            received: c.received.load(Ordering::Relaxed),
            passed: c.passed.load(Ordering::Relaxed),
            dropped: c.dropped.load(Ordering::Relaxed),
            duplicated: c.duplicated.load(Ordering::Relaxed),
            reordered: c.reordered.load(Ordering::Relaxed),
        }
    }
}

impl Drop for UdpRelay {
    fn drop(&mut self) {
        self.stop.store(true, Ordering::Relaxed);
        for t in self.threads.drain(..) {
            let _ = t.join();
        }
    }
}

struct Pipe {
    imp: Impairment,
    rng: ChaCha8Rng,
    counters: Arc<Counters>,
    held: Option<(Vec<u8>, Instant)>,
}

impl Pipe {
    fn new(imp: Impairment, seed: u64, counters: Arc<Counters>) -> Self {
        Pipe {
            imp,
            rng: ChaCha8Rng::seed_from_u64(seed),
            counters,
            held: None,
        }
    }

    fn run(
        &mut self,
        stop: &AtomicBool,
        mut recv: impl FnMut(&mut [u8]) -> std::io::Result<usize>,
        mut send: impl FnMut(&[u8]),
    ) {
        let mut buf = vec![0u8; 65_536];
        while !stop.load(Ordering::Relaxed) {
            // A read timeout falls through to release held data.
            if let Ok(n) = recv(&mut buf) {
                self.forward(&buf[..n], &mut send);
            }
            if self
                .held
                .as_ref()
                .is_some_and(|(_, t)| t.elapsed() >= MAX_HOLD)
            {
                if let Some((data, _)) = self.held.take() {
                    self.counters.passed.fetch_add(1, Ordering::Relaxed);
                    send(&data);
                }
            }
        }
    }

    fn forward(&mut self, data: &[u8], send: &mut impl FnMut(&[u8])) {
        self.counters.received.fetch_add(1, Ordering::Relaxed);
        if self.rng.random::<f64>() < self.imp.drop {
            self.counters.dropped.fetch_add(1, Ordering::Relaxed);
            return;
        }
        let copies = if self.rng.random::<f64>() < self.imp.duplicate {
            self.counters.duplicated.fetch_add(1, Ordering::Relaxed);
            2
        } else {
            1
        };
        for _ in 0..copies {
            if self.held.is_none() && self.rng.random::<f64>() < self.imp.reorder {
                self.counters.reordered.fetch_add(1, Ordering::Relaxed);
                self.held = Some((data.to_vec(), Instant::now()));
                continue;
            }
            self.counters.passed.fetch_add(1, Ordering::Relaxed);
            send(data);
            // The held datagram goes out after the one that overtook it.
            if let Some((held, _)) = self.held.take() {
                self.counters.passed.fetch_add(1, Ordering::Relaxed);
                send(&held);
            }
        }
    }
}
