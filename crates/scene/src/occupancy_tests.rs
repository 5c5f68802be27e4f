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

/// A nadir camera at `c`, image width along x, 90 degree horizontal field of view.
fn nadir(c: Point3<f64>) -> Camera {
    use std::f64::consts::FRAC_PI_2;
    let k = crate::camera::Intrinsics::from_hfov(400, 300, 90.0).unwrap();
    Camera::from_yaw_pitch(k, c, FRAC_PI_2, -FRAC_PI_2)
}

#[test]
fn free_above_frees_only_unknown_voxels_wholly_above_in_pictured_columns() {
    let bounds = Aabb {
        min: Point3::new(0.0, 0.0, 0.0),
        max: Point3::new(60.0, 40.0, 30.0),
    };
    let mut map = OccupancyMap::new(&bounds, 1.0).unwrap();
    map.carve(&[(Point3::new(10.5, 20.5, 25.5), Point3::new(10.5, 20.5, 8.5))]);
    let cams = [
        nadir(Point3::new(10.0, 20.0, 20.0)),
        nadir(Point3::new(14.0, 20.0, 20.0)),
        // Below the observed top: its line of sight may pass under it.
        nadir(Point3::new(45.0, 20.0, 7.0)),
        nadir(Point3::new(45.0, 20.0, 7.0)),
    ];
    map.mark_free_above(7.5, &cams, 2);
    let at = |x, z| map.state(&Point3::new(x, 20.5, z));
    assert_eq!(at(12.5, 7.9), Voxel::Unknown, "not wholly above the top");
    assert_eq!(at(12.5, 8.1), Voxel::Free);
    assert_eq!(
        at(12.5, 29.5),
        Voxel::Free,
        "the column is free up to the sky"
    );
    assert_eq!(at(10.5, 8.5), Voxel::Occupied, "observed points stay");
    assert_eq!(at(45.5, 12.5), Voxel::Unknown, "no camera above the top");
    // At z = 8.5 the frusta reach x = 21.5 (camera at x = 10) and
    // x = 25.5 (at x = 14), less the voxel's half-diagonal.
    assert_eq!(at(25.5, 12.5), Voxel::Unknown, "pictured by no camera");
    assert_eq!(at(22.5, 12.5), Voxel::Unknown, "pictured once");
    assert_eq!(at(19.5, 12.5), Voxel::Free, "pictured twice");
}

proptest! {
    /// Whatever the cameras, a freed column's lowest freed voxel lies
    /// wholly (all 8 corners) inside at least `min_views` frusta of
    /// cameras not below the top: the rule never frees what no camera
    /// pictured.
    #[test]
    fn free_above_frees_only_pictured_columns(seed in 0u64..1_000_000) {
        let mut rng = ChaCha8Rng::seed_from_u64(seed);
        let mut map = OccupancyMap::new(&cube(20.0), 1.0).unwrap();
        let k = crate::camera::Intrinsics::from_hfov(320, 240, rng.random_range(30.0..100.0)).unwrap();
        let cams: Vec<Camera> = (0..rng.random_range(1..5))
            .map(|_| {
                let c = Point3::new(
                    rng.random_range(-5.0..25.0),
                    rng.random_range(-5.0..25.0),
                    rng.random_range(5.0..30.0),
                );
                Camera::from_yaw_pitch(
                    k,
                    c,
                    rng.random_range(-3.2..3.2),
                    rng.random_range(-1.57..0.3),
                )
            })
            .collect();
        let top: f64 = rng.random_range(2.0..15.0);
        let min_views = rng.random_range(1..3);
        map.mark_free_above(top, &cams, min_views);
        let k0 = top.ceil() as usize;
        let [nx, ny, _] = map.dims();
        for j in 0..ny {
            for i in 0..nx {
                if map.cells[map.index([i, j, k0])] != Voxel::Free {
                    continue;
                }
                let corners_in = |c: &Camera| {
                    (0..8).all(|b| {
                        let p = Point3::new(
                            (i + (b & 1)) as f64,
                            (j + ((b >> 1) & 1)) as f64,
                            (k0 + ((b >> 2) & 1)) as f64,
                        );
                        c.in_frustum(&p)
                    })
                };
                let n = cams.iter().filter(|c| c.center().z >= top && corners_in(c)).count();
                prop_assert!(n >= min_views, "column {i},{j}: pictured by {n} < {min_views}");
            }
        }
    }
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
    let high = nadir(Point3::new(2.0, 2.0, 100.0));
    map.mark_free_above(0.0, &[high, high], 2);
    let fs = map.free_space();
    assert!((fs.clearance(&Point3::new(2.0, 2.0, 2.0)) - 2.0).abs() < 1e-9);
}

/// Known space for x < 10 of a 20 m cube (unit voxels), unknown beyond.
fn half_known() -> FreeSpace {
    let mut map = OccupancyMap::new(&cube(20.0), 1.0).unwrap();
    let rays: Vec<_> = (0..10)
        .flat_map(|x| (0..20).map(move |z| (x, z)))
        .map(|(x, z)| {
            let (x, z) = (f64::from(x) + 0.5, f64::from(z) + 0.5);
            (Point3::new(x, -1.0, z), Point3::new(x, 19.5, z))
        })
        .collect();
    map.carve(&rays);
    map.free_space()
}

#[test]
fn a_leg_may_leave_the_edge_of_known_space_but_not_go_deeper() {
    let fs = half_known();
    // 2 m from unknown space, closer than the radius of 4 m.
    let vehicle = Point3::new(8.5, 10.5, 10.5);
    assert!(!fs.point_is_clear(&vehicle, 4.0));
    let away = Point3::new(4.6, 10.5, 10.5);
    assert!(fs.point_is_clear(&away, 4.0));
    assert!(
        !fs.segment_is_clear(&vehicle, &away, 4.0),
        "a plain segment"
    );
    assert!(
        fs.leg_is_clear(&vehicle, &away, 4.0),
        "away from unknown space"
    );
    let along = Point3::new(8.5, 14.5, 10.5);
    assert!(fs.leg_is_clear(&vehicle, &along, 4.0), "no closer");
    let deeper = Point3::new(9.5, 10.5, 10.5);
    assert!(!fs.leg_is_clear(&vehicle, &deeper, 4.0), "closer");
    let inside = Point3::new(12.5, 10.5, 10.5);
    assert!(!fs.leg_is_clear(&inside, &away, 4.0), "from unknown space");
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

    /// From a vehicle that keeps the radius, a leg is judged as any
    /// segment; from one that does not, an accepted leg comes at most one
    /// and a half voxel diagonals (and half a sampling step) closer to
    /// unknown space than the vehicle, until it keeps the radius.
    #[test]
    fn a_leg_gets_no_closer_to_unknown_space_than_the_vehicle(seed in 0u64..1_000_000, a in prop::array::uniform3(2.0f64..10.0), b in prop::array::uniform3(2.0f64..10.0), r in 0.0f64..2.0) {
        let map = random_map(seed, 12, 1500);
        let (a, b) = (Point3::from(a), Point3::from(b));
        let fs = map.clone().free_space();
        if fs.point_is_clear(&a, r + 0.25) {
            prop_assert_eq!(fs.leg_is_clear(&a, &b, r), fs.segment_is_clear(&a, &b, r));
        } else if fs.leg_is_clear(&a, &b, r) {
            let floor = r.min(true_clearance(&map, &a) - 1.5 * 3f64.sqrt() - 0.25);
            for i in 0..=100 {
                let p = a + (b - a) * (f64::from(i) / 100.0);
                let d = true_clearance(&map, &p);
                prop_assert!(d >= floor - 1e-9, "at {i}%: {d} < {floor}");
            }
        }
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
