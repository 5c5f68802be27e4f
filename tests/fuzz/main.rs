//! Mutation fuzzing of every reader a user, a file or the network feeds,
//! on stable Rust from `cargo test`: seeded with the real files of the test
//! data (and files our writers produce), mutated by a seeded havoc stage
//! (`mutate.rs`), each input handed to the reader exactly as a file's bytes
//! would be.
//!
//! Invariants checked on every case:
//! - no panic (caught and reported with the input saved for replay);
//! - memory bounded by the input's size: the peak of live heap bytes the
//!   reader's thread allocates stays under `64 * len + 4 MiB` (a count read
//!   from the file and allocated before it is checked against the file's
//!   size fails this);
//! - every error names the file, and a place in it (line, byte, element,
//!   header, key) unless the file is wrong as a whole;
//! - the unmutated seeds parse.
//!
//! `VP_FUZZ_CASES` sets the cases per reader (default 5000: under a second
//! per reader), `VP_FUZZ_SEED` the seed; `VP_FUZZ_CASES=1000000 cargo test
//! --release --test fuzz -- --nocapture` is the long run. Each reader prints
//! one line: cases, accepted, rejected, the largest peak allocation and the
//! slowest case.
//!
//! This is its own test binary (not a module of `tests/suite`) because it
//! installs a counting global allocator.

// The counting allocator below is the one unsafe item: GlobalAlloc is an
// unsafe trait. It forwards to `System` and only adds bookkeeping.
#![allow(unsafe_code)]

mod mutate;
mod readers;

use std::alloc::{GlobalAlloc, Layout, System};
use std::cell::{Cell, RefCell};
use std::panic::{catch_unwind, AssertUnwindSafe};
use std::path::{Path, PathBuf};
use std::sync::Once;
use std::time::{Duration, Instant};

use mutate::{mutate, Rng};

struct Counting;

thread_local! {
    static LIVE: Cell<isize> = const { Cell::new(0) };
    static PEAK: Cell<isize> = const { Cell::new(0) };
}

fn note(delta: isize) {
    let _ = LIVE.try_with(|live| {
        let v = live.get() + delta;
        live.set(v);
        let _ = PEAK.try_with(|p| {
            if v > p.get() {
                p.set(v);
            }
        });
    });
}

// SAFETY: every method forwards to `System` with the caller's arguments and
// only updates thread-local counters (const-initialised `Cell`s, which
// neither allocate nor run destructors).
unsafe impl GlobalAlloc for Counting {
    unsafe fn alloc(&self, layout: Layout) -> *mut u8 {
        let p = unsafe { System.alloc(layout) };
        if !p.is_null() {
            note(layout.size() as isize);
        }
        p
    }

    unsafe fn alloc_zeroed(&self, layout: Layout) -> *mut u8 {
        let p = unsafe { System.alloc_zeroed(layout) };
        if !p.is_null() {
            note(layout.size() as isize);
        }
        p
    }

    unsafe fn dealloc(&self, ptr: *mut u8, layout: Layout) {
        unsafe { System.dealloc(ptr, layout) };
        note(-(layout.size() as isize));
    }

    unsafe fn realloc(&self, ptr: *mut u8, layout: Layout, new_size: usize) -> *mut u8 {
        let p = unsafe { System.realloc(ptr, layout, new_size) };
        if !p.is_null() {
            note(new_size as isize - layout.size() as isize);
        }
        p
    }
}

#[global_allocator]
static ALLOCATOR: Counting = Counting;

thread_local! {
    static IN_CASE: Cell<bool> = const { Cell::new(false) };
    static LAST_PANIC: RefCell<Option<String>> = const { RefCell::new(None) };
}

/// Panics inside a case are recorded for the report instead of printed.
fn quiet_panics_in_cases() {
    static ONCE: Once = Once::new();
    ONCE.call_once(|| {
        let default = std::panic::take_hook();
        std::panic::set_hook(Box::new(move |info| {
            if IN_CASE.with(Cell::get) {
                LAST_PANIC.with(|p| *p.borrow_mut() = Some(info.to_string()));
            } else {
                default(info);
            }
        }));
    });
}

/// What a reader does with one file: `Ok` if it accepted it, the error's
/// full text (its chain) if not.
pub type Parse = Box<dyn Fn(&[u8], &Path) -> Result<(), String>>;

/// One reader under test.
pub struct Reader {
    /// Name in the report.
    pub name: &'static str,
    /// The file name the reader is told (must appear in every error).
    pub file: &'static str,
    /// Valid inputs to mutate.
    pub seeds: Vec<Vec<u8>>,
    /// Text format: also mutate numbers and lines.
    pub text: bool,
    /// vpctl's checksummed binary frame: recompute the checksum after most
    /// mutations so the body parser is reached.
    pub reseal: bool,
    /// Errors that legitimately have no place (the file is wrong as a
    /// whole, e.g. "no vertices"): substrings that excuse a missing place.
    pub whole_file: &'static [&'static str],
    pub parse: Parse,
}

/// Words that say where in a file a problem is.
const PLACES: &[&str] = &[
    "line ", "byte ", "header", "column ", "element ", "vertex ", "face ", "image ", "camera ",
    "point ", "tree ", "seq ", "item ", "waypoint", "key ", "field ", "index ",
];

pub fn cases() -> usize {
    std::env::var("VP_FUZZ_CASES")
        .ok()
        .and_then(|v| v.parse().ok())
        .unwrap_or(5000)
}

fn base_seed() -> u64 {
    std::env::var("VP_FUZZ_SEED")
        .ok()
        .and_then(|v| v.parse().ok())
        .unwrap_or(2026)
}

fn reseal(data: &mut [u8]) {
    if data.len() >= 20 {
        let body = data.len() - 8;
        let sum = vp_scene::binfile::fnv1a64(&data[..body]);
        data[body..].copy_from_slice(&sum.to_le_bytes());
    }
}

/// Readers that take a path get the input as a file: in memory where the
/// system has a tmpfs, so the long run is not bound by the disk.
fn scratch_dir() -> tempfile::TempDir {
    let shm = Path::new("/dev/shm");
    if shm.is_dir() {
        tempfile::tempdir_in(shm)
    } else {
        tempfile::tempdir()
    }
    .unwrap()
}

/// Runs one reader for `cases()` mutated inputs and fails on the first
/// broken invariant of each kind, saving the input under the target dir.
pub fn run(reader: &Reader) {
    quiet_panics_in_cases();
    let n_cases = cases();
    let mut rng = Rng::new(base_seed() ^ vp_scene::binfile::fnv1a64(reader.name.as_bytes()));
    let dir = scratch_dir();
    let path = dir.path().join(reader.file);
    let crash_dir = PathBuf::from(env!("CARGO_TARGET_TMPDIR")).join("fuzz-crashes");
    let mut failures: Vec<String> = Vec::new();
    let (mut accepted, mut rejected) = (0usize, 0usize);
    let (mut peak_max, mut peak_len) = (0isize, 0usize);
    let (mut slowest, mut slowest_len) = (Duration::ZERO, 0usize);
    let started = Instant::now();

    // In a configuration or JSON file, the key names the place.
    let keys = if reader.text {
        keys_of(&reader.seeds)
    } else {
        Vec::new()
    };
    for (i, seed) in reader.seeds.iter().enumerate() {
        if let Err(e) = (reader.parse)(seed, &path) {
            failures.push(format!("seed {i} is rejected: {e}"));
        }
    }
    for case in 0..n_cases {
        let mut data = reader.seeds[rng.below(reader.seeds.len())].clone();
        mutate(&mut rng, &mut data, &reader.seeds, reader.text);
        if reader.reseal && rng.chance(90) {
            reseal(&mut data);
        }
        let base = LIVE.with(Cell::get);
        PEAK.with(|p| p.set(base));
        IN_CASE.with(|c| c.set(true));
        let t0 = Instant::now();
        let outcome = catch_unwind(AssertUnwindSafe(|| (reader.parse)(&data, &path)));
        let took = t0.elapsed();
        IN_CASE.with(|c| c.set(false));
        let peak = PEAK.with(Cell::get) - base;
        if took > slowest {
            (slowest, slowest_len) = (took, data.len());
        }
        if peak > peak_max {
            (peak_max, peak_len) = (peak, data.len());
        }
        let mut broken = |kind: &str, what: String| {
            if failures.iter().any(|f| f.starts_with(kind)) || failures.len() > 8 {
                return;
            }
            let _ = std::fs::create_dir_all(&crash_dir);
            let saved = crash_dir.join(format!("{}-{kind}-case{case}.bin", reader.name));
            let _ = std::fs::write(&saved, &data);
            failures.push(format!(
                "{kind}: case {case}: {what} (input: {})",
                saved.display()
            ));
        };
        let budget = 64 * data.len() as isize + (4 << 20);
        if peak > budget {
            broken(
                "memory",
                format!(
                    "peak {peak} bytes allocated for a {} byte input",
                    data.len()
                ),
            );
        }
        match outcome {
            Err(_) => {
                let msg = LAST_PANIC
                    .with(|p| p.borrow_mut().take())
                    .unwrap_or_default();
                broken("panic", msg);
            }
            Ok(Ok(())) => accepted += 1,
            Ok(Err(e)) => {
                rejected += 1;
                if !e.contains(reader.file) {
                    broken("unnamed-file", e);
                } else if !PLACES.iter().any(|p| e.contains(p))
                    && !reader.whole_file.iter().any(|w| e.contains(w))
                    && !keys.iter().any(|k| e.contains(k.as_str()))
                {
                    broken("no-place", e);
                }
            }
        }
    }
    println!(
        "fuzz {:<18} {n_cases:>8} cases in {:>7.1} s: {accepted} accepted, {rejected} rejected, \
         {} broken invariants; peak alloc {peak_max} B (input {peak_len} B); slowest {:.1} ms \
         (input {slowest_len} B)",
        reader.name,
        started.elapsed().as_secs_f64(),
        failures.len(),
        slowest.as_secs_f64() * 1e3,
    );
    assert!(
        failures.is_empty(),
        "fuzz {}: broken invariants:\n{}",
        reader.name,
        failures.join("\n")
    );
}

/// The keys of `key = value` and `"key": value` lines of text seeds.
fn keys_of(seeds: &[Vec<u8>]) -> Vec<String> {
    let mut keys: Vec<String> = Vec::new();
    for seed in seeds {
        for line in String::from_utf8_lossy(seed).lines() {
            let line = line.trim();
            // `[section.sub]` names its sections, `key = v` / `"key": v` its key.
            let names: Vec<&str> = if let Some(s) = line.strip_prefix('[') {
                s.trim_end_matches(']').split('.').collect()
            } else if let Some(end) = line.find(['=', ':']) {
                vec![line[..end].trim().trim_matches('"')]
            } else {
                continue;
            };
            for k in names {
                let ident = k.len() >= 3
                    && k.chars().all(|c| c.is_ascii_alphanumeric() || c == '_')
                    && k.starts_with(|c: char| c.is_ascii_alphabetic());
                if ident && !keys.iter().any(|x| x == k) {
                    keys.push(k.to_string());
                }
            }
        }
    }
    keys
}

/// The error's text with its chain, as `vpctl` prints it.
pub fn chain(e: impl std::error::Error + Send + Sync + 'static) -> String {
    format!("{:#}", anyhow::Error::from(e))
}
