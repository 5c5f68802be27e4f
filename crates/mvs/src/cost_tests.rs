//! Tests of cost.rs: the homography, view selection, the fast window sums
//! against the per-sample path and the reference loop, and the lower bound.

use super::*;
use crate::view::Relative;
use crate::warp::{plane_row, PairWarp};
use nalgebra::{Isometry3, Point3, Translation3, UnitQuaternion};
use vp_scene::{Camera, Intrinsics};

/// A reference camera at the origin and a source camera moved by `t`
/// and turned by the Euler angles `r`.
fn pair(k: Intrinsics, t: [f64; 3], r: [f64; 3]) -> (Camera, Camera) {
    let pose = Isometry3::from_parts(
        Translation3::new(t[0], t[1], t[2]),
        UnitQuaternion::from_euler_angles(r[0], r[1], r[2]),
    );
    (Camera::new(k, Isometry3::identity()), Camera::new(k, pose))
}

#[test]
fn homography_maps_plane_points_like_projection() {
    let k = Intrinsics {
        width: 100,
        height: 80,
        fx: 90.0,
        fy: 95.0,
        cx: 50.0,
        cy: 40.0,
    };
    let (reference, source) = pair(k, [1.0, -0.3, 0.2], [0.05, -0.1, 0.02]);
    let rel = Relative::new(&reference, &source);
    let kr = crate::view::k_of(&reference);
    // Plane through depth 10 at pixel (30, 20), tilted.
    let n = nalgebra::Vector3::new(0.2, -0.3, -1.0).normalize();
    let nf = [n.x as f32, n.y as f32, n.z as f32];
    let ray = crate::view::pixel_ray(&kr, 30, 20);
    let h = PairWarp::new(&rel, &kr).homography(&plane_row(&kr, 10.0, &nf, &ray).unwrap());
    let x0 = nalgebra::Vector3::new(f64::from(ray[0]), f64::from(ray[1]), 1.0) * 10.0;
    // Another pixel: intersect its ray with the plane, project it.
    let (u, v) = (70.5f64, 60.5f64);
    let r2 = nalgebra::Vector3::new((u - k.cx) / k.fx, (v - k.cy) / k.fy, 1.0);
    let t = n.dot(&x0) / n.dot(&r2);
    let p = Point3::from(r2 * t);
    let expected = source.project(&p).unwrap();
    let z = h[6] * u as f32 + h[7] * v as f32 + h[8];
    let got = (
        (h[0] * u as f32 + h[1] * v as f32 + h[2]) / z,
        (h[3] * u as f32 + h[4] * v as f32 + h[5]) / z,
    );
    assert!(
        (f64::from(got.0) - expected.x).abs() < 1e-2,
        "{got:?} {expected}"
    );
    assert!(
        (f64::from(got.1) - expected.y).abs() < 1e-2,
        "{got:?} {expected}"
    );
}

#[test]
fn aggregate_averages_the_best_k() {
    assert_eq!(
        aggregate(&mut [(0.5, 0.5), (0.1, 0.0), (2.0, 1.0)], 2),
        (0.3, 0.25)
    );
    assert_eq!(aggregate(&mut [(0.5, 0.2)], 3), (0.5, 0.2));
}

/// A textured image: smooth random-looking intensities.
fn texture(w: u32, h: u32) -> GreyImage {
    let data = (0..w * h)
        .map(|i| {
            let (x, y) = ((i % w) as f32, (i / w) as f32);
            0.5 + 0.2 * (0.37 * x + 0.11 * y).sin() + 0.2 * (0.05 * x * y).cos() * (0.23 * y).sin()
        })
        .collect();
    GreyImage {
        width: w,
        height: h,
        data,
    }
}

/// The two window-sum tests' scene: a textured reference image of `w` x
/// `h` pixels, its source (the same texture, scaled by `gain` and shifted
/// by `offset`: another exposure), and a camera pair with focal length
/// `f` and the principal point at the centre whose source is moved by `t`
/// and turned by `r`: the pair's relative pose and the reference's
/// intrinsics.
fn textured_pair(
    (w, h): (u32, u32),
    f: f64,
    (gain, offset): (f32, f32),
    (t, r): ([f64; 3], [f64; 3]),
) -> (GreyImage, GreyImage, Relative, [f32; 4]) {
    let img = texture(w, h);
    let src = GreyImage {
        data: img.data.iter().map(|v| gain * v + offset).collect(),
        ..img.clone()
    };
    let k = Intrinsics {
        width: w,
        height: h,
        fx: f,
        fy: f,
        cx: f64::from(w) / 2.0,
        cy: f64::from(h) / 2.0,
    };
    let (reference, source) = pair(k, t, r);
    let rel = Relative::new(&reference, &source);
    (img, src, rel, crate::view::k_of(&reference))
}

#[test]
fn fast_path_scores_like_the_per_sample_path() {
    // Same window, one scored by the corner test + chunked homography,
    // one by the per-sample path: the costs agree to rounding, and both
    // refuse a window that leaves the source.
    let img = texture(64, 48);
    let hs = [
        [1.02f32, 0.03, -1.5, -0.02, 0.98, 2.0, 1e-4, -2e-4, 1.0],
        [0.9, -0.1, 4.0, 0.05, 1.1, -3.0, -3e-4, 1e-4, 1.01],
        [1.0, 0.0, 30.0, 0.0, 1.0, 0.0, 0.0, 0.0, 1.0], // leaves the image
    ];
    // The default window (6 samples a row) and one wider than a chunk.
    for (radius, step) in [(5, 2), (9, 1)] {
        let params = MvsParams {
            window_radius: radius,
            window_step: step,
            ..MvsParams::default()
        };
        let win = Window::new(&params);
        let mut patch = RefPatch::default();
        patch.build(&img, 30, 20, &win);
        assert!(patch.full && patch.textured());
        let mut slow = RefPatch::default();
        patch_clone_partial(&patch, &win, &mut slow);
        for h in hs {
            let fast = source_cost(&patch, &win, 30.5, 20.5, &h, &img);
            let reference = source_cost(&slow, &win, 30.5, 20.5, &h, &img);
            assert!((fast - reference).abs() < 1e-4, "{fast} vs {reference}");
        }
        assert!(source_cost(&patch, &win, 30.5, 20.5, &hs[2], &img) >= MAX_COST);
        assert!(source_cost(&patch, &win, 30.5, 20.5, &hs[0], &img) < 1.0);
    }
}

#[test]
fn floor_small_is_the_truncating_cast_below_its_limit() {
    // Every 61st float of [0, 2^22), and the integers with their
    // neighbours and halves, where rounding to nearest goes up.
    let limit = (FLOOR_SMALL_LIMIT as f32).to_bits();
    let spread = (0..limit).step_by(61).map(f32::from_bits);
    let near = (0..FLOOR_SMALL_LIMIT).step_by(997).flat_map(|i| {
        let f = i as f32;
        [
            f,
            f + 0.5,
            f - 0.5,
            f * (1.0 + f32::EPSILON),
            f * (1.0 - f32::EPSILON),
        ]
    });
    for x in spread
        .chain(near)
        .filter(|x| (0.0..FLOOR_SMALL_LIMIT as f32).contains(x))
    {
        let (f, i) = floor_small(x);
        assert_eq!(
            (f.to_bits(), i),
            (((x as usize) as f32).to_bits(), x as i32),
            "{x}"
        );
    }
}

#[test]
fn fast_full_window_sums_equal_the_reference_bit_for_bit() {
    // The AVX2 sums (where the CPU has AVX2) and the scalar fast sums
    // against the reference loop. Plane hypotheses of a real camera pair (random depths and
    // normals, as PatchMatch draws them) at every 3rd pixel: the fast
    // sums must be the reference loop's bits, or PatchMatch would pick
    // other winners. Windows of one chunk a row (the default) and of
    // several. The reference patches too: built by the AVX2 copy of
    // `RefPatch::fill` and by the plain one, the same bits.
    let (w, h) = (96u32, 80u32);
    let (img, src, rel, kr) = textured_pair(
        (w, h),
        80.0,
        (0.9, 0.05),
        ([0.8, -0.2, 0.1], [0.02, -0.06, 0.01]),
    );
    let mut rng = crate::rng::PixelRng::new(7, 0, 0, 0);
    let (mut scored, mut refused) = (0, 0);
    // Last chunks with 4 live lanes (36 samples), 1 (361, 81), 5 (the 5 x 5
    // grid without its corners, 21) and 8 (the 6 x 6 one, 32); 361 and 81
    // samples also span several of the AVX2 kernel's groups of 8 chunks
    // (46 chunks: 6 groups, the last of 6; 11 chunks: 2 groups).
    for (radius, step, drop) in [
        (5, 2, false),
        (9, 1, false),
        (4, 1, false),
        (4, 2, true),
        (5, 2, true),
    ] {
        let win = Window::new(&MvsParams {
            window_radius: radius,
            window_step: step,
            window_drop_corners: drop,
            ..MvsParams::default()
        });
        // The same window without the AVX2 sums (the fallback path).
        let scalar_win = Window {
            avx2: None,
            ..win.clone()
        };
        let mut patch = RefPatch::default();
        let mut scalar_patch = RefPatch::default();
        for y in (0..h as usize).step_by(3) {
            for x in (0..w as usize).step_by(3) {
                patch.build(&img, x, y, &win);
                // The patch built by the AVX2 copy and by the scalar one:
                // the same bits, border patches included.
                scalar_patch.build(&img, x, y, &scalar_win);
                let fields = |p: &RefPatch| {
                    let bits = |v: &[f32]| v.iter().map(|f| f.to_bits()).collect::<Vec<_>>();
                    let sums = [p.sum_w, p.var, p.inv_sum_w, p.inv_sd].map(f32::to_bits);
                    (
                        bits(&p.dx),
                        bits(&p.dy),
                        bits(&p.w),
                        bits(&p.wr),
                        sums,
                        p.full,
                    )
                };
                assert_eq!(fields(&patch), fields(&scalar_patch), "patch at ({x}, {y})");
                if !patch.full {
                    continue;
                }
                let ray = crate::view::pixel_ray(&kr, x, y);
                let d = 4.0 + 20.0 * rng.next_f32();
                let n = [0.4 * rng.symmetric(), 0.4 * rng.symmetric(), -1.0];
                let Some(m) = plane_row(&kr, d, &n, &ray) else {
                    continue;
                };
                let hm = PairWarp::new(&rel, &kr).homography(&m);
                let (u, v) = (x as f32 + 0.5, y as f32 + 0.5);
                let fast = sums_full(&patch, &win, u, v, &hm, &src);
                let scalar = sums_full(&patch, &scalar_win, u, v, &hm, &src);
                let slow = sums_full_reference(&patch, &win, u, v, &hm, &src);
                let bits = |s: Option<(f32, f32, f32)>| {
                    s.map(|(a, b, c)| [a.to_bits(), b.to_bits(), c.to_bits()])
                };
                assert_eq!(
                    bits(fast),
                    bits(slow),
                    "pixel ({x}, {y}), window {radius}/{step}"
                );
                assert_eq!(
                    bits(scalar),
                    bits(slow),
                    "scalar path: pixel ({x}, {y}), window {radius}/{step}"
                );
                if fast.is_some() {
                    scored += 1;
                } else {
                    refused += 1;
                }
            }
        }
    }
    // Both outcomes were exercised, and the AVX2 sums where the CPU
    // has AVX2.
    assert!(
        scored > 500 && refused > 20,
        "{scored} scored, {refused} refused"
    );
    #[cfg(target_arch = "x86_64")]
    assert_eq!(
        Avx2::detect().is_some(),
        std::arch::is_x86_feature_detected!("avx2")
    );
}

fn patch_clone_partial(full: &RefPatch, win: &Window, out: &mut RefPatch) {
    for &(ox, oy) in &win.grid {
        out.dx.push(ox as f32);
        out.dy.push(oy as f32);
    }
    out.w.extend_from_slice(&full.w[..win.samples()]);
    out.wr.extend_from_slice(&full.wr[..win.samples()]);
    out.sum_w = full.sum_w;
    out.var = full.var;
    out.inv_sum_w = full.inv_sum_w;
    out.inv_sd = full.inv_sd;
    out.full = false;
}

#[test]
fn lower_bound_never_exceeds_the_aggregate() {
    let all = [(0.7f32, 0.7f32), (0.2, 0.2), (1.5, 1.5), (0.4, 0.4)];
    for k in 1..=4 {
        let want = aggregate(&mut all.clone(), k).0;
        for scored in 1..=4 {
            let mut part = all[..scored].to_vec();
            let lb = aggregate_lower_bound(&mut part, all.len(), k);
            assert!(lb <= want + 1e-6, "k {k}, {scored} scored: {lb} > {want}");
            if scored == all.len() {
                assert!((lb - want).abs() < 1e-6);
            }
        }
    }
}

/// The reference patch of pixel (x, y) by the plainest loop: each lane's
/// intensity (0 on padding; a cut window packs the samples inside the
/// image), weight and mean-free value, each lane's sums over the chunks
/// in order, added up as [`lane_total`] does. Returns (w, wr, sum_w, var).
fn plain_patch(
    img: &GreyImage,
    (x, y): (i32, i32),
    win: &Window,
) -> (Vec<f32>, Vec<f32>, f32, f32) {
    let centre = img.at(x, y).expect("a pixel of the image");
    // (intensity, spatial weight) of each sample inside the image.
    let mut lanes: Vec<(f32, f32)> = win
        .grid
        .iter()
        .zip(&win.spatial)
        .filter_map(|(&(ox, oy), &s)| img.at(x + ox, y + oy).map(|v| (v, s)))
        .collect();
    if lanes.len() == win.samples() {
        lanes.resize(win.lanes(), (0.0, 0.0));
    }
    let w: Vec<f32> = lanes
        .iter()
        .map(|&(v, s)| {
            let dc = v - centre;
            s * crate::fast_exp::exp(-dc * dc * win.inv_color)
        })
        .collect();
    let by_lane = |f: &dyn Fn(usize) -> f32| {
        let mut a = [0.0f32; CHUNK];
        for k in 0..w.len() {
            a[k % CHUNK] += f(k);
        }
        lane_total(a)
    };
    let sw = by_lane(&|k| w[k]);
    let mean = by_lane(&|k| w[k] * lanes[k].0) / sw;
    let var = by_lane(&|k| {
        let r = lanes[k].0 - mean;
        w[k] * r * r
    });
    let wr = (0..w.len()).map(|k| w[k] * (lanes[k].0 - mean)).collect();
    (w, wr, sw, var)
}

#[test]
fn fill_matches_the_plain_loop_bit_for_bit() {
    // Every pixel of a small image, border ones included, with windows of
    // one, several and partly filled chunks; one patch reused throughout,
    // as the passes reuse theirs, and images of two widths, so that its
    // kept tap offsets must follow the image.
    let mut full = 0;
    for (radius, step, drop) in [(5, 2, false), (4, 1, false), (5, 2, true), (9, 1, false)] {
        let win = Window::new(&MvsParams {
            window_radius: radius,
            window_step: step,
            window_drop_corners: drop,
            ..MvsParams::default()
        });
        let mut patch = RefPatch::default();
        for (w, h) in [(40u32, 30u32), (33, 36)] {
            let img = texture(w, h);
            for y in 0..h as i32 {
                for x in 0..w as i32 {
                    patch.build(&img, x as usize, y as usize, &win);
                    let (pw, pwr, sw, var) = plain_patch(&img, (x, y), &win);
                    let bits = |v: &[f32]| v.iter().map(|f| f.to_bits()).collect::<Vec<_>>();
                    let at = format!("({x}, {y}) of {w}x{h}, window {radius}/{step}/{drop}");
                    assert_eq!(bits(&patch.w), bits(&pw), "weights at {at}");
                    assert_eq!(bits(&patch.wr), bits(&pwr), "values at {at}");
                    assert_eq!(
                        [patch.sum_w, patch.var].map(f32::to_bits),
                        [sw, var].map(f32::to_bits),
                        "moments at {at}"
                    );
                    full += usize::from(patch.full);
                }
            }
        }
    }
    assert!(full > 1000, "{full} full windows");
}

#[test]
fn cut_window_sums_equal_the_scalar_loop_bit_for_bit() {
    // Every window cut by the border of a small image, against planes of a
    // real camera pair (some leave the source: both must refuse them) and
    // against the identity and half-pixel shifts, whose samples land on the
    // source's last row and column exactly (the next one weighted 0).
    let (w, h) = (41u32, 29u32);
    let (img, src, rel, kr) = textured_pair(
        (w, h),
        40.0,
        (0.8, 0.1),
        ([0.6, -0.1, 0.05], [0.03, -0.05, 0.02]),
    );
    let mut rng = crate::rng::PixelRng::new(11, 0, 0, 0);
    let (mut scored, mut refused, mut compared_avx2) = (0, 0, 0);
    for (radius, step) in [(5, 2), (4, 1), (9, 1)] {
        let win = Window::new(&MvsParams {
            window_radius: radius,
            window_step: step,
            ..MvsParams::default()
        });
        let mut patch = RefPatch::default();
        for y in 0..h as usize {
            for x in 0..w as usize {
                patch.build(&img, x, y, &win);
                if patch.full || patch.w.is_empty() {
                    continue;
                }
                let ray = crate::view::pixel_ray(&kr, x, y);
                let d = 3.0 + 30.0 * rng.next_f32();
                let n = [0.5 * rng.symmetric(), 0.5 * rng.symmetric(), -1.0];
                let shift = 0.5 * rng.symmetric();
                let mut hs = vec![
                    [1.0, 0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 1.0],
                    [1.0, 0.0, shift, 0.0, 1.0, -shift, 0.0, 0.0, 1.0],
                ];
                if let Some(m) = plane_row(&kr, d, &n, &ray) {
                    hs.push(PairWarp::new(&rel, &kr).homography(&m));
                }
                let (u, v) = (x as f32 + 0.5, y as f32 + 0.5);
                for hm in hs {
                    let hp = [
                        hm[0] * u + hm[1] * v + hm[2],
                        hm[3] * u + hm[4] * v + hm[5],
                        hm[6] * u + hm[7] * v + hm[8],
                    ];
                    let fast = sums_partial(&patch, &win, u, v, &hm, &src);
                    let scalar = sums_partial_scalar(&patch, hp, &hm, &src);
                    let bits = |s: Option<(f32, f32, f32)>| {
                        s.map(|(a, b, c)| [a.to_bits(), b.to_bits(), c.to_bits()])
                    };
                    assert_eq!(
                        bits(fast),
                        bits(scalar),
                        "pixel ({x}, {y}), window {radius}/{step}"
                    );
                    compared_avx2 += usize::from(win.avx2.is_some());
                    if fast.is_some() {
                        scored += 1;
                    } else {
                        refused += 1;
                    }
                }
            }
        }
    }
    assert!(
        scored > 500 && refused > 50,
        "{scored} scored, {refused} refused"
    );
    #[cfg(target_arch = "x86_64")]
    if std::arch::is_x86_feature_detected!("avx2") {
        assert!(compared_avx2 > 0);
    }
}
