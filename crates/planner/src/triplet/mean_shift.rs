//! M3's orientation of a surrogate: weighted mean shift over the unit
//! rays of its links [vpctl] (docs/design.md#m3-best-triplet), and the plain version the
//! memoised one is tested against.

use std::collections::HashMap;

use nalgebra::Vector3;

use super::Search;

impl Search<'_> {
    /// Weighted mean shift with a flat kernel of angular `radius` over unit
    /// rays; returns the mode whose converged rays carry the largest weight.
    ///
    /// # Performance
    /// A step's result depends only on the set of rays in the window, so
    /// the trajectories of many starts meet after a step or two, bit for
    /// bit, and follow the same path from there. Each point a trajectory
    /// reached is remembered with where the trajectory ended and after how
    /// many more steps; a later trajectory reaching it stops there when the
    /// 100-step cap would not have cut it short. The modes are those of
    /// [`Search::orient_plain`], bit for bit (tested).
    pub fn orient(rays: &[(Vector3<f64>, f64)], radius: f64) -> Option<Vector3<f64>> {
        const MAX_STEPS: usize = 100;
        let key = |v: &Vector3<f64>| [v.x.to_bits(), v.y.to_bits(), v.z.to_bits()];
        let cos_r = radius.cos();
        let merge = (radius / 8.0).cos();
        // Point at the top of a step -> (where its trajectory ended, steps
        // from that point to the end, the last one included).
        let mut ends: HashMap<[u64; 3], (Vector3<f64>, usize)> = HashMap::new();
        let mut path: Vec<[u64; 3]> = Vec::new();
        let mut modes: Vec<(Vector3<f64>, f64)> = Vec::new();
        for &(start, weight) in rays.iter().filter(|r| r.1 > 0.0) {
            let mut m = start;
            path.clear();
            let mut ended = false;
            for step in 0..MAX_STEPS {
                if let Some(&(end, more)) = ends.get(&key(&m)) {
                    if step + more <= MAX_STEPS {
                        m = end;
                        // The points of this path end there too, after
                        // `more` more steps than from m.
                        let n = path.len();
                        for (j, k) in path.drain(..).enumerate() {
                            ends.insert(k, (end, n - j + more));
                        }
                        break;
                    }
                }
                path.push(key(&m));
                let Some(next) = shift(rays, &m, cos_r) else {
                    ended = true;
                    break;
                };
                let moved = (next - m).norm();
                m = next;
                if moved < 1e-9 {
                    ended = true;
                    break;
                }
            }
            if ended {
                let n = path.len();
                for (j, k) in path.drain(..).enumerate() {
                    ends.insert(k, (m, n - j));
                }
            }
            match modes.iter_mut().find(|(c, _)| c.dot(&m) >= merge) {
                Some(mode) => mode.1 += weight,
                None => modes.push((m, weight)),
            }
        }
        strongest_mode(modes)
    }

    /// [`Search::orient`] without its memo: the reference it is tested against.
    #[cfg(test)]
    pub fn orient_plain(rays: &[(Vector3<f64>, f64)], radius: f64) -> Option<Vector3<f64>> {
        let cos_r = radius.cos();
        let merge = (radius / 8.0).cos();
        let mut modes: Vec<(Vector3<f64>, f64)> = Vec::new();
        for &(start, weight) in rays.iter().filter(|r| r.1 > 0.0) {
            let mut m = start;
            for _ in 0..100 {
                let Some(next) = shift(rays, &m, cos_r) else {
                    break;
                };
                let moved = (next - m).norm();
                m = next;
                if moved < 1e-9 {
                    break;
                }
            }
            match modes.iter_mut().find(|(c, _)| c.dot(&m) >= merge) {
                Some(mode) => mode.1 += weight,
                None => modes.push((m, weight)),
            }
        }
        strongest_mode(modes)
    }
}

/// One mean-shift step from `m`: the normalised weighted sum of the rays
/// within the window, `None` when it vanishes.
fn shift(rays: &[(Vector3<f64>, f64)], m: &Vector3<f64>, cos_r: f64) -> Option<Vector3<f64>> {
    let sum: Vector3<f64> = rays
        .iter()
        .filter(|(r, _)| r.dot(m) >= cos_r)
        .map(|(r, w)| r * *w)
        .sum();
    sum.try_normalize(1e-12)
}

/// The mode carrying the largest weight (the first of equals).
fn strongest_mode(modes: Vec<(Vector3<f64>, f64)>) -> Option<Vector3<f64>> {
    modes
        .into_iter()
        .fold(None, |best: Option<(Vector3<f64>, f64)>, m| match best {
            Some(b) if b.1 >= m.1 => Some(b),
            _ => Some(m),
        })
        .map(|m| m.0)
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The memo of `orient` changes no mode: random clusters of weighted
    /// rays (some of weight 0), several radii, bit for bit.
    #[test]
    fn memoised_mean_shift_equals_the_plain_one() {
        use rand::{Rng, SeedableRng};
        let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(31);
        for trial in 0..200 {
            let n = rng.random_range(1..120);
            let centres: Vec<Vector3<f64>> = (0..rng.random_range(1..5))
                .map(|_| {
                    Vector3::new(
                        rng.random_range(-1.0..1.0),
                        rng.random_range(-1.0..1.0),
                        -1.0,
                    )
                })
                .collect();
            let rays: Vec<(Vector3<f64>, f64)> = (0..n)
                .map(|_| {
                    let c = centres[rng.random_range(0..centres.len())];
                    let jitter = Vector3::new(
                        rng.random_range(-0.2..0.2),
                        rng.random_range(-0.2..0.2),
                        rng.random_range(-0.2..0.2),
                    );
                    let w = if rng.random_bool(0.1) {
                        0.0
                    } else {
                        rng.random_range(0.0..2.0)
                    };
                    ((c + jitter).normalize(), w)
                })
                .collect();
            let radius = [0.05, 0.2, 0.5][trial % 3];
            let want = Search::orient_plain(&rays, radius);
            let got = Search::orient(&rays, radius);
            assert_eq!(
                got.map(|v| v.map(f64::to_bits)),
                want.map(|v| v.map(f64::to_bits)),
                "trial {trial}"
            );
        }
    }

    #[test]
    fn mean_shift_picks_the_heavier_cluster() {
        let dir = |x: f64, y: f64| Vector3::new(x, y, -1.0).normalize();
        let rays = vec![
            (dir(0.0, 0.0), 1.0),
            (dir(0.05, 0.0), 1.0),
            (dir(2.0, 0.0), 1.5),
            (dir(2.05, 0.02), 1.5),
        ];
        let m = Search::orient(&rays, 0.2).unwrap();
        assert!(m.dot(&dir(2.02, 0.01)) > 0.999, "{m:?}");
    }
}
