use super::*;
use crate::sgm::tests::{cameras, views};

/// Skipping the propagation candidates of neighbours that did not change
/// gives the same hypotheses bit for bit, in the photometric pass (with a
/// coarse level) and in the geometric pass that starts from it: with two
/// sources, and with four of which each pixel chooses two (view selection
/// at the coarsest level, carried down).
#[test]
fn skipping_unchanged_neighbours_changes_no_bit() {
    skipping_changes_no_bit(3, MvsParams::default());
    skipping_changes_no_bit(
        5,
        MvsParams {
            top_k_sources: 2,
            seeded_sources: 2,
            ..MvsParams::default()
        },
    );
}

fn skipping_changes_no_bit(n_views: usize, params: MvsParams) {
    let cams = cameras(n_views, 8.0, (96, 72));
    let (views, _) = views(&cams);
    // Any change counts, and every neighbour's plane is scored (with a
    // threshold, or fewer `fine_neighbours`, an unchanged neighbour's plane
    // may not have been scored before: the skip is no longer exact).
    let params = MvsParams {
        coarse_levels: 2,
        coarse_min_size: 32,
        settle_cost: 0.0,
        fine_neighbours: 4,
        ..params
    };
    let bits = |r: &RawState| -> Vec<[u32; 6]> {
        r.hyps
            .iter()
            .map(|h| [h.d, h.n[0], h.n[1], h.n[2], h.cost, h.photo].map(f32::to_bits))
            .collect()
    };
    let photometric = |skip: bool| -> Vec<Option<RawState>> {
        (0..n_views)
            .map(|r| {
                let sources: Vec<usize> = (0..n_views).filter(|&s| s != r).collect();
                Some(patch_match_raw_with(&views, (r, &sources), &params, None, skip).unwrap())
            })
            .collect()
    };
    let (skipped, plain) = (photometric(true), photometric(false));
    for (a, b) in skipped.iter().zip(&plain) {
        let (a, b) = (a.as_ref().unwrap(), b.as_ref().unwrap());
        assert!(bits(a) == bits(b));
        // With more sources than it keeps, the pass chose them.
        assert_eq!(a.sources.is_some(), n_views - 1 > params.seeded_sources);
    }
    let maps: Vec<Option<DepthNormalMap>> = plain
        .iter()
        .map(|r| r.as_ref().map(RawState::unfiltered))
        .collect();
    let geometric = |skip: bool| {
        let sources: Vec<usize> = (1..n_views).collect();
        patch_match_raw_with(
            &views,
            (0, &sources),
            &params,
            Some(Photometric {
                maps: &maps,
                same_sources: true,
            }),
            skip,
        )
        .unwrap()
    };
    assert!(bits(&geometric(true)) == bits(&geometric(false)));
    // The fixture is not trivial: most pixels hold a depth in range.
    let found = plain[0]
        .as_ref()
        .unwrap()
        .hyps
        .iter()
        .filter(|h| h.cost < MAX_COST)
        .count();
    assert!(found > 96 * 72 / 2, "{found}");
}

/// The geometric pass's seed from the photometric pass's costs (a triplet:
/// every source averaged) scores like the seed scored window by window:
/// the same photometric costs bit for bit, ranking costs equal up to the
/// order of the additions. `geom_iterations` 0 keeps the seed as it is.
#[test]
fn the_geometric_seed_from_photometric_costs_scores_like_the_windows() {
    let cams = cameras(3, 8.0, (96, 72));
    let (views, _) = views(&cams);
    let params = MvsParams {
        geom_iterations: 0,
        ..MvsParams::default()
    };
    let maps: Vec<Option<DepthNormalMap>> = (0..3)
        .map(|r| {
            let sources: Vec<usize> = (0..3).filter(|&s| s != r).collect();
            Some(
                patch_match_raw(&views, r, &sources, &params, None)
                    .unwrap()
                    .unfiltered(),
            )
        })
        .collect();
    let seed = |same_sources| {
        let previous = Photometric {
            maps: &maps,
            same_sources,
        };
        patch_match_raw(&views, 0, &[1, 2], &params, Some(previous)).unwrap()
    };
    let (known, scored) = (seed(true), seed(false));
    let mut differ = 0;
    for (a, b) in known.hyps.iter().zip(&scored.hyps) {
        assert_eq!(a.photo.to_bits(), b.photo.to_bits());
        assert!(
            (a.cost - b.cost).abs() <= 1e-6 * b.cost.abs().max(1.0),
            "{a:?} vs {b:?}"
        );
        differ += usize::from(a.cost.to_bits() != b.cost.to_bits());
    }
    // Most seeds have a geometric term to add.
    let scorable = scored.hyps.iter().filter(|h| h.photo < 1.0).count();
    assert!(
        scorable > scored.hyps.len() / 2,
        "{scorable} scorable seeds"
    );
    eprintln!(
        "{differ} of {} ranking costs differ in their last bits",
        known.hyps.len()
    );
}

/// The geometric pass settles a pixel by the geometric filter's own test
/// (`geom_settled_px`): `agrees`, in f32 on the pass's relative poses,
/// decides as `geometric::consistent_pixel`, in f64 on the cameras, on every
/// pixel of a triplet's photometric map against both sources, up to
/// rounding at the bounds; and both answers are common.
#[test]
fn settling_agrees_with_the_geometric_filter() {
    use crate::geom_term::agrees;
    use crate::geometric::consistent_pixel;
    use crate::view::pixel_ray;
    let cams = cameras(3, 8.0, (96, 72));
    let (views, _) = views(&cams);
    let params = MvsParams::default();
    let maps: Vec<DepthNormalMap> = (0..3)
        .map(|r| {
            let sources: Vec<usize> = (0..3).filter(|&s| s != r).collect();
            patch_match_raw(&views, r, &sources, &params, None)
                .unwrap()
                .unfiltered()
        })
        .collect();
    let k = k_of(&views[0].camera);
    let bounds = (params.max_reproj_error_px, params.max_depth_diff);
    let (mut yes, mut no, mut differ) = (0, 0, 0);
    for s in [1, 2] {
        let rel = Relative::new(&views[0].camera, &views[s].camera);
        let g = GeomSource {
            depth: &maps[s].depth,
            normal: &maps[s].normal,
            width: maps[s].width as usize,
            height: maps[s].height as usize,
            rot_back: std::array::from_fn(|i| std::array::from_fn(|j| rel.rot[j][i])),
        };
        for (i, &d) in maps[0].depth.iter().enumerate() {
            let (x, y) = (i % 96, i / 96);
            let ray = pixel_ray(&k, x, y);
            let ours = agrees(&k, bounds, &rel, &g, (x, y), &ray, d);
            let filter = consistent_pixel(&views[0], &views[s], &maps[s], x, y, d, &params);
            differ += usize::from(ours != filter.is_some());
            if ours {
                yes += 1;
            } else {
                no += 1;
            }
        }
    }
    let n = 2 * 96 * 72;
    assert!(differ * 200 <= n, "{differ} of {n} decisions differ");
    assert!(yes * 10 >= n && no * 20 >= n, "{yes} agree, {no} do not");
    eprintln!("{differ} of {n} decisions differ; {yes} agree, {no} do not");
}
