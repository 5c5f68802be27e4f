//! Progress on stderr, the one way every command reports it.
//!
//! On a terminal: an `indicatif` bar with the count, the rate and the ETA
//! (a spinner with the elapsed time when the total is unknown), redrawn in
//! place and cleared before the command's final output. Without a terminal
//! (a log file, CI, a pipe): timestamped summary lines, at most one per
//! stage per [`LOG_EVERY`] for item counts, never one per item; a stage
//! that goes on longer says where it is at least every [`LOG_EVERY`], so
//! that no stage is silent for longer.
//!
//! Library crates report progress as text through the `&mut dyn
//! FnMut(&str)` callbacks they already take; [`Progress::message`] turns a
//! message ending in `(i/n)` into a count of the current stage and any
//! other into a new stage.

use std::fmt::Write as _;
use std::io::IsTerminal;
use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::{Arc, Mutex, MutexGuard};
use std::thread::JoinHandle;
use std::time::{Duration, Instant};

use indicatif::{ProgressBar, ProgressDrawTarget, ProgressStyle};

/// Longest time between two lines of one stage in a log.
pub const LOG_EVERY: Duration = Duration::from_secs(5);

struct Stage {
    name: String,
    total: Option<u64>,
    done: u64,
    started: Instant,
}

struct State {
    t0: Instant,
    stage: Option<Stage>,
    last_line: Instant,
    bar: Option<ProgressBar>,
}

/// Progress of one command on this process's stderr.
pub struct Progress {
    tty: bool,
    state: Arc<Mutex<State>>,
    stop: Arc<AtomicBool>,
    ticker: Option<JoinHandle<()>>,
}

fn lock(state: &Mutex<State>) -> MutexGuard<'_, State> {
    state
        .lock()
        .unwrap_or_else(std::sync::PoisonError::into_inner)
}

impl State {
    /// `[  12.3 s] stage: 40/100 images, 3.1/s, ETA 19 s`.
    fn status(&self, now: Instant) -> Option<String> {
        let s = self.stage.as_ref()?;
        let mut line = s.name.clone();
        if let Some(total) = s.total {
            let secs = now.duration_since(s.started).as_secs_f64().max(1e-9);
            let rate = s.done as f64 / secs;
            let _ = write!(line, ": {}/{total}", s.done);
            if s.done > 0 && s.done < total {
                let eta = (total - s.done) as f64 / rate.max(1e-9);
                let _ = write!(line, ", {rate:.1}/s, ETA {}", human(eta));
            }
        } else {
            let _ = write!(
                line,
                " ({} so far)",
                human(now.duration_since(s.started).as_secs_f64())
            );
        }
        Some(line)
    }

    fn print(&mut self, now: Instant, line: &str) {
        eprintln!(
            "[{:7.1} s] {line}",
            now.duration_since(self.t0).as_secs_f64()
        );
        self.last_line = now;
    }
}

/// Seconds as `42 s`, `3 min 05 s` or `1 h 02 min`.
fn human(s: f64) -> String {
    let s = s.max(0.0).round() as u64;
    if s < 60 {
        format!("{s} s")
    } else if s < 3600 {
        format!("{} min {:02} s", s / 60, s % 60)
    } else {
        format!("{} h {:02} min", s / 3600, s / 60 % 60)
    }
}

/// A trailing `(i/n)` of a library message: the count and the stage name
/// before it.
fn split_count(m: &str) -> Option<(&str, u64, u64)> {
    let body = m.trim_end().strip_suffix(')')?;
    let open = body.rfind('(')?;
    let (i, n) = body[open + 1..].split_once('/')?;
    let (i, n) = (i.trim().parse().ok()?, n.trim().parse().ok()?);
    Some((body[..open].trim_end(), i, n))
}

/// A leading `[i/n]` (vp-mvs's messages): the count and the stage, named
/// by the first two words after it (`patch match` of `[3/10] patch match
/// img3 against 4 source(s)`), and the rest.
fn split_leading(m: &str) -> Option<(String, u64, u64, &str)> {
    let body = m.trim_start().strip_prefix('[')?;
    let (count, text) = body.split_once(']')?;
    let (i, n) = count.split_once('/')?;
    let (i, n) = (i.trim().parse().ok()?, n.trim().parse().ok()?);
    let words: Vec<&str> = text.split_whitespace().collect();
    let name = words.iter().take(2).copied().collect::<Vec<_>>().join(" ");
    Some((name, i, n, text.trim()))
}

impl Progress {
    /// Progress on stderr: a bar on a terminal, log lines otherwise.
    pub fn new() -> Self {
        Self::with_terminal(std::io::stderr().is_terminal())
    }

    fn with_terminal(tty: bool) -> Self {
        let now = Instant::now();
        let state = Arc::new(Mutex::new(State {
            t0: now,
            stage: None,
            last_line: now,
            bar: None,
        }));
        let stop = Arc::new(AtomicBool::new(false));
        // In a log, a long stage says where it is every LOG_EVERY (a bar
        // ticks on its own on a terminal).
        let ticker = (!tty).then(|| {
            let (state, stop) = (Arc::clone(&state), Arc::clone(&stop));
            std::thread::spawn(move || {
                while !stop.load(Ordering::Relaxed) {
                    std::thread::sleep(Duration::from_millis(200));
                    let mut s = lock(&state);
                    let now = Instant::now();
                    if now.duration_since(s.last_line) >= LOG_EVERY {
                        if let Some(line) = s.status(now) {
                            s.print(now, &line);
                        }
                    }
                }
            })
        });
        Progress {
            tty,
            state,
            stop,
            ticker,
        }
    }

    /// Starts a stage of `total` items (unknown: `None`), ending the previous one.
    pub fn stage(&self, name: &str, total: Option<u64>) {
        let mut s = lock(&self.state);
        let now = Instant::now();
        if let Some(bar) = s.bar.take() {
            bar.finish_and_clear();
        }
        s.stage = Some(Stage {
            name: name.to_string(),
            total,
            done: 0,
            started: now,
        });
        if self.tty {
            let bar = match total {
                Some(n) => ProgressBar::new(n).with_style(
                    ProgressStyle::with_template(
                        "{prefix} {bar:30} {pos}/{len} {per_sec} ETA {eta} {msg}",
                    )
                    .unwrap_or_else(|_| ProgressStyle::default_bar()),
                ),
                None => ProgressBar::new_spinner().with_style(
                    ProgressStyle::with_template("{spinner} {prefix} {elapsed} {msg}")
                        .unwrap_or_else(|_| ProgressStyle::default_spinner()),
                ),
            };
            bar.set_draw_target(ProgressDrawTarget::stderr());
            bar.set_prefix(name.to_string());
            bar.enable_steady_tick(Duration::from_millis(200));
            s.bar = Some(bar);
        } else {
            let line = match total {
                Some(n) => format!("{name}: 0/{n}"),
                None => name.to_string(),
            };
            s.print(now, &line);
        }
    }

    /// `done` items of the current stage are finished.
    pub fn set(&self, done: u64) {
        let mut s = lock(&self.state);
        let now = Instant::now();
        let Some(stage) = s.stage.as_mut() else {
            return;
        };
        stage.done = done;
        let last = stage.total == Some(done);
        if let Some(bar) = &s.bar {
            bar.set_position(done);
        } else if last || now.duration_since(s.last_line) >= LOG_EVERY {
            if let Some(line) = s.status(now) {
                s.print(now, &line);
            }
        }
    }

    /// A library's progress message: `... (i/n)` counts items of the stage
    /// named by the text before it; any other message starts a new stage.
    ///
    /// The stage is named by the text before the first `: ` (`training
    /// site 3` of `training site 3: triplet (4/40)`), else by the first word
    /// (`rendered` of `rendered img7.png (3/40)`), so that per-item names
    /// do not start a stage each; on a terminal the rest shows beside the bar.
    pub fn message(&self, m: &str) {
        let counted = split_count(m)
            .map(|(text, i, n)| {
                let (name, rest) = text
                    .split_once(": ")
                    .or_else(|| text.split_once(' '))
                    .unwrap_or((text, ""));
                (name.to_string(), i, n, rest)
            })
            .or_else(|| split_leading(m));
        if let Some((name, i, n, rest)) = counted {
            let name = name.as_str();
            let same = lock(&self.state)
                .stage
                .as_ref()
                .is_some_and(|s| s.name == name && s.total == Some(n));
            if !same {
                self.stage(name, Some(n));
            }
            if let Some(bar) = &lock(&self.state).bar {
                bar.set_message(rest.to_string());
            }
            self.set(i);
        } else {
            self.stage(m, None);
        }
    }

    /// Clears the bar (nothing on a log): call before the final output.
    pub fn finish(&self) {
        let mut s = lock(&self.state);
        if let Some(bar) = s.bar.take() {
            bar.finish_and_clear();
        }
        s.stage = None;
    }
}

impl Default for Progress {
    fn default() -> Self {
        Progress::new()
    }
}

impl Drop for Progress {
    fn drop(&mut self) {
        self.finish();
        self.stop.store(true, Ordering::Relaxed);
        if let Some(t) = self.ticker.take() {
            let _ = t.join();
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_trailing_count_is_read_and_other_text_is_a_stage() {
        assert_eq!(
            split_count("rendered img7.png (3/40)"),
            Some(("rendered img7.png", 3, 40))
        );
        assert_eq!(split_count("training (forest)"), None);
        assert_eq!(split_count("loading"), None);
        let (name, i, n, rest) =
            split_leading("[3/10] patch match img3 against 4 source(s)").unwrap();
        assert_eq!(
            (name.as_str(), i, n, rest),
            ("patch match", 3, 10, "patch match img3 against 4 source(s)")
        );
        assert_eq!(human(42.4), "42 s");
        assert_eq!(human(185.0), "3 min 05 s");
    }
}
