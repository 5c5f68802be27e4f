use nalgebra::Point3;
use proptest::prelude::*;
use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;

use super::*;

fn cube(n: f64) -> Aabb {
    Aabb {
        min: Point3::new(0.0, 0.0, 0.0),
        max: Point3::new(n, n, n),
    }
}

/// Distance from `p` to the nearest point of an unknown voxel or of the
/// outside of the map: the brute-force reference of `clearance`.
fn true_clearance(map: &OccupancyMap, p: &Point3<f64>) -> f64 {
    let [nx, ny, nz] = map.dims();
    let s = map.voxel_size();
    let mut best = f64::INFINITY;
    for i in 0..3 {
        let hi = map.origin[i] + map.dims[i] as f64 * s;
        best = best.min(p[i] - map.origin[i]).min(hi - p[i]);
    }
    for z in 0..nz {
        for y in 0..ny {
            for x in 0..nx {
                if map.cells[map.index([x, y, z])] != Voxel::Unknown {
                    continue;
                }
                let lo = map.origin + Vector3::new(x as f64, y as f64, z as f64) * s;
                let d2: f64 = (0..3)
                    .map(|i| {
                        let c = p[i].clamp(lo[i], lo[i] + s);
                        (p[i] - c).powi(2)
                    })
                    .sum();
                best = best.min(d2.sqrt());
            }
        }
    }
    best.max(0.0)
}

/// A map of `n`^3 unit voxels carved by `rays` random rays from the top face.
fn random_map(seed: u64, n: usize, rays: usize) -> OccupancyMap {
    let mut rng = ChaCha8Rng::seed_from_u64(seed);
    let size = n as f64;
    let mut map = OccupancyMap::new(&cube(size), 1.0).unwrap();
    let rays: Vec<_> = (0..rays)
        .map(|_| {
            let a = Point3::new(
                rng.random_range(0.0..size),
                rng.random_range(0.0..size),
                size - 0.01,
            );
            let b = Point3::new(
                rng.random_range(0.0..size),
                rng.random_range(0.0..size),
                rng.random_range(0.0..size * 0.5),
            );
            (a, b)
        })
        .collect();
    map.carve(&rays);
    map
}

#[test]
fn a_ray_frees_the_voxels_before_its_point_and_occupies_the_point() {
    let mut map = OccupancyMap::new(&cube(10.0), 1.0).unwrap();
    map.carve(&[(Point3::new(0.5, 0.5, 9.5), Point3::new(0.5, 0.5, 0.5))]);
    for z in 1..10 {
        let p = Point3::new(0.5, 0.5, z as f64 + 0.5);
        assert_eq!(map.state(&p), Voxel::Free, "z = {z}");
    }
    assert_eq!(map.state(&Point3::new(0.5, 0.5, 0.5)), Voxel::Occupied);
    assert_eq!(map.state(&Point3::new(1.5, 0.5, 5.5)), Voxel::Unknown);
    assert_eq!(map.counts(), [1000 - 10, 9, 1]);
}

#[test]
fn a_ray_from_outside_carves_the_part_inside_the_map() {
    let mut map = OccupancyMap::new(&cube(10.0), 1.0).unwrap();
    map.carve(&[(Point3::new(-20.0, 5.5, 5.5), Point3::new(4.5, 5.5, 5.5))]);
    assert_eq!(map.counts(), [1000 - 5, 4, 1]);
    assert_eq!(map.state(&Point3::new(0.2, 5.5, 5.5)), Voxel::Free);
}

#[test]
fn occupied_wins_whatever_the_order_of_the_rays() {
    let a = (Point3::new(5.5, 5.5, 9.5), Point3::new(5.5, 5.5, 4.5));
    let b = (Point3::new(5.5, 5.5, 9.5), Point3::new(5.5, 5.5, 0.5));
    let mut m1 = OccupancyMap::new(&cube(10.0), 1.0).unwrap();
    m1.carve(&[a, b]);
    let mut m2 = OccupancyMap::new(&cube(10.0), 1.0).unwrap();
    m2.carve(&[b, a]);
    assert_eq!(m1.cells, m2.cells);
    assert_eq!(m1.state(&a.1), Voxel::Occupied);
}

#[test]
fn free_above_marks_only_unknown_voxels_wholly_above() {
    let mut map = OccupancyMap::new(&cube(10.0), 1.0).unwrap();
    map.carve(&[(Point3::new(0.5, 0.5, 2.5), Point3::new(0.5, 0.5, 8.5))]);
    map.mark_free_above(7.5);
    assert_eq!(map.state(&Point3::new(3.5, 3.5, 7.9)), Voxel::Unknown);
    assert_eq!(map.state(&Point3::new(3.5, 3.5, 8.1)), Voxel::Free);
    assert_eq!(map.state(&Point3::new(0.5, 0.5, 8.5)), Voxel::Occupied);
}

#[test]
fn the_distance_transform_is_exact_at_voxel_centres() {
    for seed in 0..6 {
        let map = random_map(seed, 9, 25);
        let fs = map.clone().free_space();
        let [nx, ny, nz] = map.dims();
        for z in 0..nz {
            for y in 0..ny {
                for x in 0..nx {
                    let mut best = f64::INFINITY;
                    for (i, c) in map.cells.iter().enumerate() {
                        if *c == Voxel::Unknown {
                            let (ux, uy, uz) = (i % nx, (i / nx) % ny, i / (nx * ny));
                            let d2 = (ux as f64 - x as f64).powi(2)
                                + (uy as f64 - y as f64).powi(2)
                                + (uz as f64 - z as f64).powi(2);
                            best = best.min(d2.sqrt());
                        }
                    }
                    let got = f64::from(fs.dist[map.index([x, y, z])]);
                    assert!(
                        (got - best).abs() < 1e-4,
                        "seed {seed} voxel {x},{y},{z}: {got} vs {best}"
                    );
                }
            }
        }
    }
}

#[test]
fn nothing_unknown_means_infinite_room_inside_the_map() {
    let mut map = OccupancyMap::new(&cube(4.0), 1.0).unwrap();
    map.mark_free_above(0.0);
    let fs = map.free_space();
    assert!((fs.clearance(&Point3::new(2.0, 2.0, 2.0)) - 2.0).abs() < 1e-9);
}

#[test]
fn bad_maps_are_refused_with_the_reason() {
    let e = OccupancyMap::new(&cube(10.0), 0.0).unwrap_err().to_string();
    assert!(e.contains("voxel size"), "{e}");
    let e = OccupancyMap::new(&cube(f64::NAN), 1.0)
        .unwrap_err()
        .to_string();
    assert!(e.contains("not finite"), "{e}");
    let e = OccupancyMap::new(&cube(1e5), 0.1).unwrap_err().to_string();
    assert!(e.contains("exceed the limit"), "{e}");
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(64))]

    /// Safety of the planner's query: the clearance never exceeds the true
    /// distance to unknown space.
    #[test]
    fn clearance_is_a_lower_bound(seed in 0u64..1_000_000, p in prop::array::uniform3(0.0f64..12.0)) {
        let map = random_map(seed, 12, 1500);
        let p = Point3::from(p);
        let truth = true_clearance(&map, &p);
        let fs = map.free_space();
        prop_assert!(fs.clearance(&p) <= truth + 1e-9, "{} > {truth}", fs.clearance(&p));
    }

    /// A segment reported clear keeps the radius at every point of it.
    #[test]
    fn a_clear_segment_is_clear_everywhere(seed in 0u64..1_000_000, a in prop::array::uniform3(2.0f64..10.0), b in prop::array::uniform3(2.0f64..10.0), r in 0.0f64..2.0) {
        // Dense enough that about half of these segments are clear.
        let map = random_map(seed, 12, 1500);
        let (a, b) = (Point3::from(a), Point3::from(b));
        let fs = map.clone().free_space();
        if fs.segment_is_clear(&a, &b, r) {
            for i in 0..=200 {
                let p = a + (b - a) * (f64::from(i) / 200.0);
                let t = true_clearance(&map, &p);
                prop_assert!(t >= r - 1e-9, "point {i}: {t} < {r}");
            }
        }
    }
}
