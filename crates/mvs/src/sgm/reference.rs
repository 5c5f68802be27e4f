//! The straightforward semi-global matcher the fast one must equal bit for
//! bit (tests only): census with clamped indices per pixel, the cost of
//! each cell on its own, one sweep per path direction adding into one sum,
//! and the uniqueness test against every rival disparity. It is the
//! matcher as Hirschmüller writes it, kept to check the fused passes, the
//! vectorised census and the AVX2 code generation against.

use super::matching::{step, RectifiedPair};
use super::{LeftRight, SgmParams};

const BIG: u16 = 0x4000;

pub(crate) fn census(img: &[f32], w: usize, h: usize, cw: usize, ch: usize) -> Vec<u64> {
    let (rx, ry) = ((cw / 2) as isize, (ch / 2) as isize);
    let mut out = vec![0u64; w * h];
    for y in 0..h {
        for x in 0..w {
            let centre = img[y * w + x];
            let mut k = 0;
            for dy in -ry..=ry {
                let yy = (y as isize + dy).clamp(0, h as isize - 1) as usize;
                for dx in -rx..=rx {
                    if dx == 0 && dy == 0 {
                        continue;
                    }
                    let xx = (x as isize + dx).clamp(0, w as isize - 1) as usize;
                    out[y * w + x] |= u64::from(img[yy * w + xx] < centre) << k;
                    k += 1;
                }
            }
        }
    }
    out
}

pub(crate) fn cost_volume(pair: &RectifiedPair, cw: usize, ch: usize) -> Vec<u8> {
    let (w, h, nd) = (pair.width, pair.height, pair.n_disp);
    let n_bits = (cw * ch - 1) as u8;
    let cl = census(&pair.left, w, h, cw, ch);
    let cr = census(&pair.right, w, h, cw, ch);
    let mut cost = vec![n_bits; w * h * nd];
    for i in 0..w * h {
        if !pair.left_valid[i] {
            continue;
        }
        for k in 0..nd.min(i % w + 1) {
            if pair.right_valid[i - k] {
                cost[i * nd + k] = (cl[i] ^ cr[i - k]).count_ones() as u8;
            }
        }
    }
    cost
}

fn start(cost: &[u8], cur: &mut [u16]) -> u16 {
    for (c, &v) in cur[1..].iter_mut().zip(cost) {
        *c = u16::from(v);
    }
    cur[1..=cost.len()]
        .iter()
        .copied()
        .min()
        .unwrap_or(u16::MAX)
}

/// One sweep per direction (dx, dy); the previous pixel of a path is
/// (x - dx, y - dy).
pub(crate) fn aggregate(
    cost: &[u8],
    w: usize,
    h: usize,
    nd: usize,
    params: &SgmParams,
) -> Vec<u16> {
    let dirs: &[(isize, isize)] = if params.paths == 4 {
        &[(1, 0), (-1, 0), (0, 1), (0, -1)]
    } else {
        &[
            (1, 0),
            (-1, 0),
            (0, 1),
            (0, -1),
            (1, 1),
            (-1, 1),
            (1, -1),
            (-1, -1),
        ]
    };
    let pad = nd + 2;
    let mut sum = vec![0u16; w * h * nd];
    for &(dx, dy) in dirs {
        let mut l = vec![BIG; w * h * pad];
        let mut mins = vec![0u16; w * h];
        // Visit pixels so that each one's predecessor comes first.
        let ys: Vec<usize> = if dy < 0 {
            (0..h).rev().collect()
        } else {
            (0..h).collect()
        };
        let xs: Vec<usize> = if dx < 0 {
            (0..w).rev().collect()
        } else {
            (0..w).collect()
        };
        for &y in &ys {
            for &x in &xs {
                let i = y * w + x;
                let c = &cost[i * nd..(i + 1) * nd];
                let (px, py) = (x as isize - dx, y as isize - dy);
                let inside = px >= 0 && py >= 0 && px < w as isize && py < h as isize;
                let prev = inside.then(|| {
                    let p = py as usize * w + px as usize;
                    (l[p * pad..(p + 1) * pad].to_vec(), mins[p])
                });
                let cell = &mut l[i * pad..(i + 1) * pad];
                mins[i] = match prev {
                    Some((pv, pm)) => step(c, &pv, pm, params.p1, params.p2, cell),
                    None => start(c, cell),
                };
                for k in 0..nd {
                    sum[i * nd + k] += l[i * pad + 1 + k];
                }
            }
        }
    }
    sum
}

pub(crate) fn winners(sum: &[u16], pair: &RectifiedPair, params: &SgmParams) -> Vec<f32> {
    let (w, nd) = (pair.width, pair.n_disp);
    let mut disp = vec![f32::NAN; w * pair.height];
    for y in 0..pair.height {
        let mut offers: Vec<Option<(u32, usize)>> = vec![None; w];
        let row = &sum[y * w * nd..(y + 1) * w * nd];
        let argmin = |s: &mut dyn Iterator<Item = u16>| {
            let mut best = (u16::MAX, 0);
            for (k, v) in s.enumerate() {
                if v < best.0 {
                    best = (v, k);
                }
            }
            best.1
        };
        for x in 0..w {
            if !pair.left_valid[y * w + x] {
                continue;
            }
            let s = &row[x * nd..(x + 1) * nd];
            let best = argmin(&mut s.iter().copied());
            if best > x || !pair.right_valid[y * w + x - best] {
                continue;
            }
            let xr = x - best;
            let rbest = argmin(&mut (0..nd.min(w - xr)).map(|k| row[(xr + k) * nd + k]));
            let min = f32::from(s[best]);
            let unique = s
                .iter()
                .enumerate()
                .all(|(k, &v)| k.abs_diff(best) <= 1 || min <= params.uniqueness * f32::from(v));
            if !unique {
                continue;
            }
            if params.left_right == LeftRight::Opencv {
                // The right pixel's offer: the unique left winner with the
                // smallest sum landing on it, ties to the smaller disparity.
                let offer = (u32::from(s[best]), best);
                offers[xr] = Some(offers[xr].map_or(offer, |o: (u32, usize)| o.min(offer)));
            } else if rbest.abs_diff(best) > params.lr_max_diff as usize {
                continue;
            }
            let mut d = best as f32;
            if best > 0 && best + 1 < nd {
                let (a, b, c) = (f32::from(s[best - 1]), min, f32::from(s[best + 1]));
                let denom = a + c - 2.0 * b;
                if denom > 0.0 {
                    d += (a - c) / (2.0 * denom);
                }
            }
            disp[y * w + x] = d;
        }
        if params.left_right == LeftRight::Opencv {
            let tol = params.lr_max_diff as usize;
            for x in 0..w {
                let d = disp[y * w + x];
                if d.is_nan() {
                    continue;
                }
                let disagrees = |k: usize| match x.checked_sub(k).and_then(|xr| offers.get(xr)) {
                    Some(Some((_, r))) => r.abs_diff(k) > tol,
                    _ => false,
                };
                if disagrees(d.floor() as usize) && disagrees(d.ceil() as usize) {
                    disp[y * w + x] = f32::NAN;
                }
            }
        }
    }
    disp
}
