//! Split tests on a 27x27 Lab patch, and gathering patches into a contiguous
//! buffer so that thousands of tests scan them from cache.

use rand::Rng;
use serde::{Deserialize, Serialize};

use crate::lab::LabPlanes;

/// Patch side in pixels (the paper's 27x27).
pub const PATCH: usize = 27;
/// Largest offset from the patch centre.
pub const RADIUS: usize = PATCH / 2;
/// Bytes of one gathered patch: three channels of PATCH x PATCH.
pub const PATCH_LEN: usize = 3 * PATCH * PATCH;
/// Smallest possible response (a difference); responses shifted by this
/// index histograms.
pub const RESPONSE_MIN: i32 = -255;
/// Number of distinct responses over all test types (-255..=510).
pub const RESPONSE_RANGE: usize = 766;

/// How a test combines the channel values v1, v2 at its two offsets.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, Serialize, Deserialize)]
pub enum TestOp {
    /// v1 alone (the second offset is unused).
    Value = 0,
    /// v1 + v2.
    Sum = 1,
    /// v1 - v2.
    Difference = 2,
    /// |v1 - v2|.
    AbsDifference = 3,
}

impl TestOp {
    /// The op from its file code.
    pub fn from_code(code: u8) -> Option<TestOp> {
        match code {
            0 => Some(TestOp::Value),
            1 => Some(TestOp::Sum),
            2 => Some(TestOp::Difference),
            3 => Some(TestOp::AbsDifference),
            _ => None,
        }
    }

    /// Combines two channel values.
    #[inline]
    pub fn apply(self, v1: u8, v2: u8) -> i32 {
        let (a, b) = (i32::from(v1), i32::from(v2));
        match self {
            TestOp::Value => a,
            TestOp::Sum => a + b,
            TestOp::Difference => a - b,
            TestOp::AbsDifference => (a - b).abs(),
        }
    }
}

/// A split test: one Lab channel, one or two offsets from the patch centre,
/// an operation. The sample goes left when its response is <= the node's
/// threshold.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, Serialize, Deserialize)]
pub struct SplitTest {
    /// Channel: 0 L, 1 a, 2 b.
    pub channel: u8,
    /// Combination of the two values.
    pub op: TestOp,
    /// First offset (dx, dy), each in -RADIUS..=RADIUS.
    pub offset1: (i8, i8),
    /// Second offset; (0, 0) and unused for [`TestOp::Value`].
    pub offset2: (i8, i8),
}

impl SplitTest {
    /// A uniformly random test.
    pub fn random<R: Rng>(rng: &mut R) -> SplitTest {
        let r = RADIUS as i8;
        let channel = rng.random_range(0..3u8);
        let op = TestOp::from_code(rng.random_range(0..4u8)).unwrap_or(TestOp::Value);
        let offset1 = (rng.random_range(-r..=r), rng.random_range(-r..=r));
        let mut offset2 = (rng.random_range(-r..=r), rng.random_range(-r..=r));
        if op == TestOp::Value {
            offset2 = (0, 0);
        }
        SplitTest {
            channel,
            op,
            offset1,
            offset2,
        }
    }

    /// Whether channel and offsets are in range (checked when loading models).
    pub fn is_valid(self) -> bool {
        let r = RADIUS as i8;
        let ok = |o: (i8, i8)| (-r..=r).contains(&o.0) && (-r..=r).contains(&o.1);
        self.channel < 3 && ok(self.offset1) && ok(self.offset2)
    }

    /// Index of an offset inside a gathered patch.
    #[inline]
    fn patch_index(self, o: (i8, i8)) -> usize {
        let c = self.channel as usize * PATCH * PATCH;
        c + (o.1 as isize + RADIUS as isize) as usize * PATCH
            + (o.0 as isize + RADIUS as isize) as usize
    }

    /// Indices of the two values inside a gathered patch.
    #[inline]
    pub fn patch_indices(self) -> (usize, usize) {
        (
            self.patch_index(self.offset1),
            self.patch_index(self.offset2),
        )
    }

    /// Offsets of the two values in `planes`' data relative to a sample's
    /// base index (see [`LabPlanes::base`]).
    #[inline]
    pub fn plane_offsets(self, planes: &LabPlanes) -> (isize, isize) {
        self.offsets_in(planes.stride(), planes.plane_len())
    }

    /// [`SplitTest::plane_offsets`] in planes of this row length and plane
    /// length (see [`crate::lab::layout`]), without the planes.
    #[inline]
    pub fn offsets_in(self, stride: usize, plane_len: usize) -> (isize, isize) {
        let c = (self.channel as usize * plane_len) as isize;
        let s = stride as isize;
        let at = |o: (i8, i8)| c + o.1 as isize * s + o.0 as isize;
        (at(self.offset1), at(self.offset2))
    }

    /// Response at the sample with base index `base` in `planes`.
    #[inline]
    pub fn response(self, planes: &LabPlanes, base: usize) -> i32 {
        let (o1, o2) = self.plane_offsets(planes);
        let d = planes.data();
        self.op.apply(
            d[base.wrapping_add_signed(o1)],
            d[base.wrapping_add_signed(o2)],
        )
    }
}

/// Copies the 27x27x3 patch around the sample at `base` into `out`
/// (length [`PATCH_LEN`]): channel-major, then rows.
pub fn gather(planes: &LabPlanes, base: usize, out: &mut [u8]) {
    let d = planes.data();
    let s = planes.stride();
    for c in 0..3 {
        let centre = c * planes.plane_len() + base;
        for row in 0..PATCH {
            let start = centre + row * s - RADIUS * s - RADIUS;
            let o = (c * PATCH + row) * PATCH;
            out[o..o + PATCH].copy_from_slice(&d[start..start + PATCH]);
        }
    }
}

/// Samples gathered per block in [`gather_columns`]: a block's patches
/// (32 x 2187 bytes) stay in L1/L2 while they are transposed.
const BLOCK: usize = 32;

/// Gathers the patches of m samples (planes, base index) position-major:
/// byte p of sample s's patch goes to `out[p * m + s]`. A split test then
/// reads two contiguous rows of m bytes instead of touching two cache lines
/// in every patch, which is what makes thousands of tests per node cheap.
pub fn gather_columns(samples: &[(&LabPlanes, usize)], out: &mut Vec<u8>) {
    let m = samples.len();
    out.clear();
    out.resize(m * PATCH_LEN, 0);
    let mut block = vec![0u8; BLOCK * PATCH_LEN];
    for (b, chunk) in samples.chunks(BLOCK).enumerate() {
        for (&(planes, base), patch) in chunk.iter().zip(block.chunks_exact_mut(PATCH_LEN)) {
            gather(planes, base, patch);
        }
        let s0 = b * BLOCK;
        for p in 0..PATCH_LEN {
            let row = &mut out[p * m + s0..p * m + s0 + chunk.len()];
            for (k, o) in row.iter_mut().enumerate() {
                *o = block[k * PATCH_LEN + p];
            }
        }
    }
}

/// Gathers only the patch positions `positions` (indices into a gathered
/// patch) of m samples: byte `positions[r]` of sample s goes to
/// `out[r * m + s]`. A node with few tests reads a few dozen positions, not
/// all 2187, so this keeps gathering from dominating small tests counts.
pub fn gather_rows(samples: &[(&LabPlanes, usize)], positions: &[usize], out: &mut Vec<u8>) {
    let m = samples.len();
    out.clear();
    out.resize(positions.len() * m, 0);
    let coords: Vec<(usize, isize, isize)> = positions
        .iter()
        .map(|&p| {
            let (c, rest) = (p / (PATCH * PATCH), p % (PATCH * PATCH));
            (
                c,
                (rest / PATCH) as isize - RADIUS as isize,
                (rest % PATCH) as isize - RADIUS as isize,
            )
        })
        .collect();
    for (s, &(planes, base)) in samples.iter().enumerate() {
        let d = planes.data();
        let stride = planes.stride() as isize;
        for (r, &(c, dy, dx)) in coords.iter().enumerate() {
            out[r * m + s] =
                d[(c * planes.plane_len() + base).wrapping_add_signed(dy * stride + dx)];
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use rand::SeedableRng;
    use vp_scene::raster::RgbImage;

    #[test]
    fn gathered_patches_and_planes_give_the_same_responses() {
        let img = RgbImage::from_fn(40, 30, |x, y| {
            image::Rgb([(x * 7 + y) as u8, (x * y) as u8, (200 - x - y) as u8])
        });
        let planes = LabPlanes::from_rgb(&img);
        let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(1);
        let mut patch = vec![0u8; PATCH_LEN];
        for &(x, y) in &[(0, 0), (39, 29), (20, 3), (5, 28)] {
            let base = planes.base(x, y);
            gather(&planes, base, &mut patch);
            for _ in 0..200 {
                let t = SplitTest::random(&mut rng);
                assert!(t.is_valid());
                let (i1, i2) = t.patch_indices();
                let expect = t.op.apply(
                    planes.at(
                        i64::from(x) + i64::from(t.offset1.0),
                        i64::from(y) + i64::from(t.offset1.1),
                        t.channel as usize,
                    ),
                    planes.at(
                        i64::from(x) + i64::from(t.offset2.0),
                        i64::from(y) + i64::from(t.offset2.1),
                        t.channel as usize,
                    ),
                );
                assert_eq!(t.op.apply(patch[i1], patch[i2]), expect);
                assert_eq!(t.response(&planes, base), expect);
            }
        }
        // Position-major gathering holds the same bytes, transposed.
        let samples: Vec<(&LabPlanes, usize)> = (0..70)
            .map(|s| (&planes, planes.base(s % 40, s / 3)))
            .collect();
        let mut columns = Vec::new();
        gather_columns(&samples, &mut columns);
        let positions = [5, 700, 729 + 13 * 27 + 13, 2186];
        let mut rows = Vec::new();
        gather_rows(&samples, &positions, &mut rows);
        for (r, &p) in positions.iter().enumerate() {
            assert_eq!(&rows[r * 70..(r + 1) * 70], &columns[p * 70..(p + 1) * 70]);
        }
        for (s, &(p, base)) in samples.iter().enumerate() {
            gather(p, base, &mut patch);
            for (i, v) in patch.iter().enumerate() {
                assert_eq!(columns[i * 70 + s], *v);
            }
        }
    }

    #[test]
    fn responses_stay_in_the_histogram_range() {
        for op in [
            TestOp::Value,
            TestOp::Sum,
            TestOp::Difference,
            TestOp::AbsDifference,
        ] {
            for (a, b) in [(0, 0), (0, 255), (255, 0), (255, 255)] {
                let r = op.apply(a, b) - RESPONSE_MIN;
                assert!((0..RESPONSE_RANGE as i32).contains(&r));
            }
        }
    }
}
