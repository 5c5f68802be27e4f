use super::*;
use crate::sgm::tests::{cameras, views};

/// Fusion that lets each map go once no later view reads it gives the
/// points of fusion over every map, and hands each map over once, whole,
/// when its last reader is done: with a chain of sources (each view
/// against its neighbours) in index order; when view 4 reads view 0 too,
/// view 0's map goes after view 4's fusion, not after view 1's.
#[test]
fn releasing_maps_gives_the_same_points_and_each_map_once() {
    let cams = cameras(5, 8.0, (96, 72));
    let (views, _) = views(&cams);
    let chain: Vec<Vec<usize>> = (0..5usize)
        .map(|r| {
            [r.wrapping_sub(1), r + 1]
                .into_iter()
                .filter(|&s| s < 5)
                .collect()
        })
        .collect();
    let mut loop_back = chain.clone();
    loop_back[4].push(0);
    let params = MvsParams::default();
    for (sources, order) in [(chain, [0, 1, 2, 3, 4]), (loop_back, [1, 2, 0, 3, 4])] {
        let out = crate::reconstruct(&views, &sources, &params, &mut |_| {}).unwrap();
        let whole = fuse(&views, &out.geometric, &sources, &params);
        assert!(whole.len() > 1000, "{} points", whole.len());
        let mut handed: Vec<usize> = Vec::new();
        let mut maps: Vec<Option<DepthNormalMap>> = vec![None; 5];
        let released = fuse_releasing(
            &views,
            out.geometric.clone(),
            &sources,
            &params,
            &mut |r, map| {
                handed.push(r);
                maps[r] = Some(map);
                Ok(())
            },
        )
        .unwrap();
        assert_eq!(released, whole);
        assert_eq!(maps, out.geometric);
        assert_eq!(handed, order);
    }
}
