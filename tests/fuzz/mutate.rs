//! A seeded byte- and text-level mutator (AFL's havoc stage, in miniature):
//! bit flips, interesting integers and numbers, deleted, duplicated and
//! spliced ranges, swapped lines. Same seed, same sequence of inputs.

/// SplitMix64: tiny, fast and good enough to drive mutations.
pub struct Rng(u64);

impl Rng {
    pub fn new(seed: u64) -> Self {
        Rng(seed)
    }

    pub fn next_u64(&mut self) -> u64 {
        self.0 = self.0.wrapping_add(0x9e37_79b9_7f4a_7c15);
        let mut z = self.0;
        z = (z ^ (z >> 30)).wrapping_mul(0xbf58_476d_1ce4_e5b9);
        z = (z ^ (z >> 27)).wrapping_mul(0x94d0_49bb_1331_11eb);
        z ^ (z >> 31)
    }

    /// Uniform in `0..n` (`n > 0`).
    pub fn below(&mut self, n: usize) -> usize {
        (self.next_u64() % n as u64) as usize
    }

    pub fn chance(&mut self, percent: u64) -> bool {
        self.next_u64() % 100 < percent
    }
}

const BYTES: &[u8] = &[
    0, 1, 0x7f, 0x80, 0xff, b'-', b'9', b'0', b'\n', b'\r', b' ', b'\t', b'&', b'.', b'e', b'#',
    b'"', b'[', b'{', b'=',
];
const U32S: &[u32] = &[
    0,
    1,
    2,
    3,
    0xff,
    0xffff,
    0x1_0000,
    0x7fff_ffff,
    0x8000_0000,
    0xffff_ffff,
    0xffff_fffe,
    1_000_000,
    0x4000_0000,
];
const U64S: &[u64] = &[
    0,
    u64::MAX,
    1 << 32,
    1 << 40,
    1 << 62,
    0x7ff8_0000_0000_0000, // f64 NaN
    0x7ff0_0000_0000_0000, // f64 +inf
    0xfff0_0000_0000_0000, // f64 -inf
    0x7fc0_0000_7fc0_0000, // two f32 NaN
    0x7f80_0000_ff80_0000, // f32 +inf, -inf
];
const NUMBERS: &[&str] = &[
    "-1",
    "0",
    "1",
    "-0",
    "2147483648",
    "4294967295",
    "4294967296",
    "18446744073709551615",
    "18446744073709551616",
    "99999999999999999999999",
    "1e309",
    "-1e309",
    "1e-320",
    "nan",
    "NaN",
    "inf",
    "-inf",
    "0x10",
    "1.5",
    "",
    "true",
    "\"x\"",
];

/// Inputs never grow past this, so a run's memory stays bounded.
pub const MAX_LEN: usize = 1 << 21;

/// Applies 1 to 8 random mutations (occasionally up to 32) to `data`;
/// `text` adds the token- and line-level ones; `others` are the seeds to
/// splice from.
pub fn mutate(rng: &mut Rng, data: &mut Vec<u8>, others: &[Vec<u8>], text: bool) {
    let n = if rng.chance(10) {
        1 + rng.below(32)
    } else {
        1 + rng.below(8)
    };
    for _ in 0..n {
        let ops = if text { 14 } else { 11 };
        match rng.below(ops) {
            0..=5 => point(rng, data),
            6 => {
                if !data.is_empty() {
                    let (a, b) = range(rng, data.len());
                    data.drain(a..b);
                }
            }
            7 => {
                if !data.is_empty() && data.len() < MAX_LEN {
                    let (a, b) = range(rng, data.len());
                    let chunk = data[a..b].to_vec();
                    let at = rng.below(data.len() + 1);
                    data.splice(at..at, chunk);
                }
            }
            8 => {
                let k = 1 + rng.below(16);
                let at = rng.below(data.len() + 1);
                let bytes: Vec<u8> = (0..k).map(|_| rng.next_u64() as u8).collect();
                data.splice(at..at, bytes);
            }
            9 => {
                if !data.is_empty() {
                    let cut = rng.below(data.len());
                    data.truncate(cut);
                }
            }
            10 => {
                if let Some(other) = others.get(rng.below(others.len().max(1))) {
                    if !other.is_empty() {
                        let (a, b) = range(rng, other.len());
                        let at = rng.below(data.len() + 1);
                        let end = (at + (b - a)).min(data.len());
                        data.splice(at..end, other[a..b].iter().copied());
                    }
                }
            }
            11 => replace_number(rng, data),
            12 => line_op(rng, data),
            _ => {
                // Insert a token: a number, or a separator.
                let at = rng.below(data.len() + 1);
                let t = NUMBERS[rng.below(NUMBERS.len())];
                data.splice(at..at, t.bytes());
            }
        }
        data.truncate(MAX_LEN);
    }
}

/// One changed byte or word: a flipped bit, a random or interesting byte,
/// an interesting 32- or 64-bit integer, a byte off by a little.
fn point(rng: &mut Rng, data: &mut [u8]) {
    match rng.below(6) {
        0 => {
            if !data.is_empty() {
                let i = rng.below(data.len());
                data[i] ^= 1 << rng.below(8);
            }
        }
        1 => {
            if !data.is_empty() {
                let i = rng.below(data.len());
                data[i] = rng.next_u64() as u8;
            }
        }
        2 => {
            if !data.is_empty() {
                let i = rng.below(data.len());
                data[i] = BYTES[rng.below(BYTES.len())];
            }
        }
        3 => {
            if data.len() >= 4 {
                let i = rng.below(data.len() - 3);
                let v = U32S[rng.below(U32S.len())];
                let b = if rng.chance(50) {
                    v.to_le_bytes()
                } else {
                    v.to_be_bytes()
                };
                data[i..i + 4].copy_from_slice(&b);
            }
        }
        4 => {
            if data.len() >= 8 {
                let i = rng.below(data.len() - 7);
                let v = U64S[rng.below(U64S.len())];
                data[i..i + 8].copy_from_slice(&v.to_le_bytes());
            }
        }
        _ => {
            // Add or subtract a small amount to a byte (counts off by one).
            if !data.is_empty() {
                let i = rng.below(data.len());
                let d = 1 + rng.below(16) as u8;
                data[i] = if rng.chance(50) {
                    data[i].wrapping_add(d)
                } else {
                    data[i].wrapping_sub(d)
                };
            }
        }
    }
}

/// A random range of at most 1/8 of the input (often a few bytes).
fn range(rng: &mut Rng, len: usize) -> (usize, usize) {
    let max = if rng.chance(70) { 8 } else { len / 8 + 1 };
    let k = 1 + rng.below(max.min(len));
    let a = rng.below(len - k + 1);
    (a, a + k)
}

/// Replaces a run of digits (a number in a text file) with an
/// interesting number.
fn replace_number(rng: &mut Rng, data: &mut Vec<u8>) {
    if data.is_empty() {
        return;
    }
    let start = rng.below(data.len());
    let Some(a) = data[start..].iter().position(u8::is_ascii_digit) else {
        return;
    };
    let a = start + a;
    let mut b = a;
    while b < data.len() && (data[b].is_ascii_digit() || data[b] == b'.') {
        b += 1;
    }
    let a = if a > 0 && data[a - 1] == b'-' {
        a - 1
    } else {
        a
    };
    let t = NUMBERS[rng.below(NUMBERS.len())];
    data.splice(a..b, t.bytes());
}

/// Deletes, duplicates or swaps whole lines.
fn line_op(rng: &mut Rng, data: &mut Vec<u8>) {
    let starts: Vec<usize> = std::iter::once(0)
        .chain(
            data.iter()
                .enumerate()
                .filter(|(_, &c)| c == b'\n')
                .map(|(i, _)| i + 1),
        )
        .filter(|&i| i < data.len())
        .collect();
    if starts.is_empty() {
        return;
    }
    let line = |i: usize| {
        let s = starts[i];
        let e = starts.get(i + 1).copied().unwrap_or(data.len());
        (s, e)
    };
    let (s, e) = line(rng.below(starts.len()));
    match rng.below(3) {
        0 => {
            data.drain(s..e);
        }
        1 => {
            if data.len() < MAX_LEN {
                let l = data[s..e].to_vec();
                let times = if rng.chance(20) { 1 + rng.below(64) } else { 1 };
                for _ in 0..times {
                    data.splice(s..s, l.iter().copied());
                }
            }
        }
        _ => {
            let (s2, e2) = line(rng.below(starts.len()));
            if e <= s2 || e2 <= s {
                let (first, second) = if s < s2 {
                    ((s, e), (s2, e2))
                } else {
                    ((s2, e2), (s, e))
                };
                let mut out = data[..first.0].to_vec();
                out.extend_from_slice(&data[second.0..second.1]);
                out.extend_from_slice(&data[first.1..second.0]);
                out.extend_from_slice(&data[first.0..first.1]);
                out.extend_from_slice(&data[second.1..]);
                *data = out;
            }
        }
    }
}
