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
        let mut released = Vec::new();
        fuse_releasing(
            &views,
            out.geometric.clone(),
            &sources,
            &params,
            &mut |r, map| {
                handed.push(r);
                maps[r] = Some(map);
                Ok(())
            },
            &mut |p| released.push(p),
        )
        .unwrap();
        assert_eq!(released, whole);
        assert_eq!(maps, out.geometric);
        assert_eq!(handed, order);
    }
}

/// The cloud kept as `fused.ply`'s records reads back, through vp-scene's
/// PLY reader, as the points fusion made, in order: positions and normals
/// to float precision.
#[test]
fn fused_ply_records_read_back_as_the_points() {
    let cams = cameras(3, 8.0, (96, 72));
    let (views, _) = views(&cams);
    let sources: Vec<Vec<usize>> = (0..3usize)
        .map(|r| (0..3).filter(|&s| s != r).collect())
        .collect();
    let params = MvsParams::default();
    let out = crate::reconstruct(&views, &sources, &params, &mut |_| {}).unwrap();
    let points = fuse(&views, &out.geometric, &sources, &params);
    assert!(points.len() > 1000, "{} points", points.len());
    let mut ply = FusedPly::default();
    for p in &points {
        ply.push(p);
    }
    assert_eq!(ply.len(), points.len());
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("fused.ply");
    ply.write(&path).unwrap();
    let read = vp_scene::io::load_points_with_normals(&path).unwrap();
    let normals = read.normals.expect("fused.ply has vertex normals");
    assert_eq!(read.points.len(), points.len());
    // The bits of the float the file holds, read back as f64.
    let f = |v: f64| f64::from(v as f32).to_bits();
    for ((p, q), n) in points.iter().zip(&read.points).zip(&normals) {
        assert_eq!(
            [q.x, q.y, q.z].map(f64::to_bits),
            [f(p.position.x), f(p.position.y), f(p.position.z)]
        );
        assert_eq!(
            [n.x, n.y, n.z].map(f64::to_bits),
            [f(p.normal.x), f(p.normal.y), f(p.normal.z)]
        );
    }
}
