//! A meadow: a dense carpet of grass blades over a chosen share of the
//! ground around the rock, for worlds "dominated by vegetation" like the
//! paper's site.
//!
//! The tufts of [`super::grass`] are a few thin blades each: no face budget
//! lets them cover the ground. A meadow is geometry, not a texture: its
//! blades stand up to 30 cm tall and hide each other and the soil, so what a
//! camera sees of it changes with the viewing direction the way a real
//! meadow does, and only through the geometry (a texture that changed with
//! the view angle would plant the very effect the world sweep is to test).
//!
//! The meadow lies in patches (a low-frequency noise field thresholded at
//! the quantile that gives the share) within [`MEADOW_MARGIN`] of the
//! rock's footprint box: that is the part of the world the region of
//! interest and the planned views see. Its blades come on top of the
//! site's face budget (about 400 thousand at share 0.9 on the demo's rock).

use rand::Rng;
use rand_chacha::ChaCha8Rng;

use super::grass::Blade;
use super::noise::Fbm;
use super::rock::Rock;

/// The meadow reaches this far beyond the rock's footprint box, metres.
pub(crate) const MEADOW_MARGIN: f64 = 6.0;
/// One blade per cell of this side (about 1100 blades per square metre),
/// each placed at random within its cell.
const SPACING: f64 = 0.03;
/// Step of the grid on which the patch field's quantile is taken, metres.
const FIELD_STEP: f64 = 0.25;

/// Plans a meadow over `share` (0..=1) of the free ground within
/// [`MEADOW_MARGIN`] of the rock's footprint box, clipped to |x|, |y| <=
/// `half` - 0.5. `free` says where ground may carry grass (not under the
/// rock, a trunk or a marker).
pub(crate) fn plan(
    rng: &mut ChaCha8Rng,
    patches: &Fbm,
    rock: &Rock,
    share: f64,
    half: f64,
    free: impl Fn(f64, f64) -> bool,
) -> Vec<Blade> {
    if share <= 0.0 {
        return Vec::new();
    }
    let edge = half - 0.5;
    let inside = |x: f64, y: f64| {
        x.abs() <= edge && y.abs() <= edge && rock.within_box(x, y, MEADOW_MARGIN) && free(x, y)
    };
    let (lo, hi) = rock.box_bounds(MEADOW_MARGIN);
    let threshold = patch_threshold(patches, share, lo, hi, inside);
    let nx = ((hi[0] - lo[0]) / SPACING).ceil() as usize;
    let ny = ((hi[1] - lo[1]) / SPACING).ceil() as usize;
    let mut blades = Vec::new();
    for j in 0..ny {
        for i in 0..nx {
            // Draw every number of a cell before testing it: the blades of a
            // cell do not depend on which earlier cells were kept.
            let x = lo[0] + (i as f64 + rng.random::<f64>()) * SPACING;
            let y = lo[1] + (j as f64 + rng.random::<f64>()) * SPACING;
            let lean_dir = rng.random_range(0.0..std::f64::consts::TAU);
            let lean: f64 = rng.random_range(0.2..1.0); // radians from vertical
            let len = rng.random_range(0.15..0.4);
            let width = rng.random_range(0.02..0.05);
            if patches.get(x, y) >= threshold && inside(x, y) {
                blades.push(Blade::leaning([x, y], lean_dir, lean, len, width));
            }
        }
    }
    blades
}

/// The patch field's value above which `share` of the region's grid points
/// lie (minus infinity for a share of 1).
fn patch_threshold(
    patches: &Fbm,
    share: f64,
    lo: [f64; 2],
    hi: [f64; 2],
    inside: impl Fn(f64, f64) -> bool,
) -> f64 {
    let nx = ((hi[0] - lo[0]) / FIELD_STEP).ceil() as usize;
    let ny = ((hi[1] - lo[1]) / FIELD_STEP).ceil() as usize;
    let mut values: Vec<f64> = (0..ny)
        .flat_map(|j| (0..nx).map(move |i| (i, j)))
        .map(|(i, j)| {
            (
                lo[0] + (i as f64 + 0.5) * FIELD_STEP,
                lo[1] + (j as f64 + 0.5) * FIELD_STEP,
            )
        })
        .filter(|&(x, y)| inside(x, y))
        .map(|(x, y)| patches.get(x, y))
        .collect();
    if share >= 1.0 || values.is_empty() {
        return f64::NEG_INFINITY;
    }
    values.sort_by(f64::total_cmp);
    let k = (((1.0 - share) * values.len() as f64) as usize).min(values.len() - 1);
    values[k]
}

#[cfg(test)]
mod tests {
    use super::*;
    use rand::SeedableRng;

    fn meadow(share: f64) -> (Rock, Vec<Blade>) {
        let rock = Rock::new(3, 12.0, 9.0, 2.5, 0.3);
        let patches = Fbm::new(9, 6.0, 1.0, 2);
        let mut rng = ChaCha8Rng::seed_from_u64(4);
        let blades = plan(&mut rng, &patches, &rock, share, 22.0, |x, y| {
            rock.bump(x, y) < -0.3
        });
        (rock, blades)
    }

    /// Share of a fine grid of the region's free ground with a blade root
    /// within 10 cm: the meadow's patches, measured without its planner.
    fn covered(rock: &Rock, blades: &[Blade]) -> f64 {
        let cell = 0.1;
        let (lo, hi) = rock.box_bounds(MEADOW_MARGIN);
        let nx = ((hi[0] - lo[0]) / cell).ceil() as usize;
        let ny = ((hi[1] - lo[1]) / cell).ceil() as usize;
        let mut hit = vec![false; nx * ny];
        for b in blades {
            let [x, y] = b.root();
            let i = ((x - lo[0]) / cell) as usize;
            let j = ((y - lo[1]) / cell) as usize;
            hit[j.min(ny - 1) * nx + i.min(nx - 1)] = true;
        }
        let (mut n, mut k) = (0, 0);
        for j in 0..ny {
            for i in 0..nx {
                let x = lo[0] + (i as f64 + 0.5) * cell;
                let y = lo[1] + (j as f64 + 0.5) * cell;
                if rock.within_box(x, y, MEADOW_MARGIN) && rock.bump(x, y) < -0.3 {
                    n += 1;
                    k += usize::from(hit[j * nx + i]);
                }
            }
        }
        k as f64 / n as f64
    }

    #[test]
    fn a_meadow_covers_the_share_asked_for_and_nothing_under_the_rock() {
        assert!(meadow(0.0).1.is_empty());
        let mut last = 0.0;
        for share in [0.3, 0.6, 0.9, 1.0] {
            let (rock, blades) = meadow(share);
            let got = covered(&rock, &blades);
            assert!(
                (got - share).abs() < 0.06,
                "share {share}: covered {got:.3}"
            );
            assert!(got > last);
            last = got;
            assert!(blades.iter().all(|b| {
                let [x, y] = b.root();
                rock.bump(x, y) < -0.3 && rock.within_box(x, y, MEADOW_MARGIN)
            }));
        }
    }

    #[test]
    fn the_same_seed_plans_the_same_meadow() {
        let (_, a) = meadow(0.6);
        let (_, b) = meadow(0.6);
        assert_eq!(a.len(), b.len());
        assert!(a
            .iter()
            .zip(&b)
            .all(|(p, q)| p.root().map(f64::to_bits) == q.root().map(f64::to_bits)));
    }
}
