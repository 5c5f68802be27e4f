//! Tests of the site generator: determinism, budget, content, geometry.

use nalgebra::Point3;

use super::rock::SINK;
use super::*;
use crate::error::SceneError;
use crate::mesh::{Material, Mesh};

fn site(seed: u64, target: usize) -> Site {
    generate_site(&SiteParams {
        seed,
        target_faces: target,
        ..SiteParams::default()
    })
    .unwrap()
}

fn same_bits(a: &Mesh, b: &Mesh) -> bool {
    a.faces == b.faces
        && a.materials == b.materials
        && a.vertices.len() == b.vertices.len()
        && a.vertices.iter().zip(&b.vertices).all(|(p, q)| {
            p.iter()
                .zip(q.iter())
                .all(|(x, y)| x.to_bits() == y.to_bits())
        })
}

fn faces_of(m: &Mesh, mat: Material) -> impl Iterator<Item = usize> + '_ {
    (0..m.n_faces()).filter(move |&f| m.material(f) == Some(mat))
}

#[test]
fn same_seed_same_bits_whatever_the_thread_count() {
    let a = site(42, 20_000);
    let one = rayon::ThreadPoolBuilder::new()
        .num_threads(1)
        .build()
        .unwrap();
    let b = one.install(|| site(42, 20_000));
    assert!(same_bits(&a.mesh, &b.mesh));
    let c = site(43, 20_000);
    assert!(!same_bits(&a.mesh, &c.mesh));
    assert_ne!(a.rock.center, c.rock.center);
}

#[test]
fn face_count_is_within_ten_percent_of_target() {
    for target in [10_000, 100_000] {
        let s = site(7, target);
        let ratio = s.mesh.n_faces() as f64 / target as f64;
        assert!((ratio - 1.0).abs() < 0.10, "{target}: {}", s.summary());
    }
}

#[test]
#[ignore = "slow in debug builds: a million faces"]
fn face_count_is_within_ten_percent_of_a_million() {
    let s = site(7, 1_000_000);
    let ratio = s.mesh.n_faces() as f64 / 1e6;
    assert!((ratio - 1.0).abs() < 0.10, "{}", s.summary());
    s.mesh.validate().unwrap();
}

#[test]
fn every_material_present_with_plausible_shares_and_rock_size() {
    let s = site(1, 50_000);
    s.mesh.validate().unwrap();
    let sum = s.summary();
    let share = |m: Material| sum.faces_per_material[m as usize] as f64 / sum.n_faces as f64;
    assert!((0.2..0.6).contains(&share(Material::Ground)), "{sum}");
    assert!((0.15..0.35).contains(&share(Material::Rock)), "{sum}");
    assert!((0.05..0.25).contains(&share(Material::Grass)), "{sum}");
    assert!((0.15..0.35).contains(&share(Material::Tree)), "{sum}");
    assert_eq!(sum.faces_per_material[Material::Marker as usize], 12 * 6);
    let [x, y, z] = sum.rock_extent;
    assert!((x / 17.0 - 1.0).abs() < 0.12, "rock length {x}");
    assert!((y / 13.0 - 1.0).abs() < 0.12, "rock width {y}");
    // Crest a few metres above its base; the base follows the slope.
    let c = s.rock.center;
    let crest = s.surface_height(c.x, c.y) - s.ground.height(c.x, c.y);
    assert!((2.0..4.0).contains(&crest), "rock crest {crest} m");
    assert!(z > 2.0 && z < 8.0, "rock z extent {z}");
    let text = sum.to_string();
    assert!(
        Material::ALL.iter().all(|m| text.contains(m.name())),
        "{text}"
    );
}

#[test]
fn terrain_stays_within_its_bounds_and_has_no_faces_under_the_rock() {
    let s = site(3, 20_000);
    let (lo, hi) = s.terrain.height_bounds(0.5 * s.params.size);
    let m = &s.mesh;
    for f in faces_of(m, Material::Ground) {
        for p in m.triangle(f) {
            assert!(p.z >= lo && p.z <= hi, "ground at {p} outside [{lo}, {hi}]");
            assert!(p.x.abs() <= 30.0 && p.y.abs() <= 30.0);
        }
        // Kept faces reach out from under the rock with at least one corner.
        let hidden = m
            .triangle(f)
            .iter()
            .all(|p| s.rock.bump(p.x, p.y) > SINK + 0.1);
        assert!(!hidden, "ground face {f} hidden under the rock");
    }
}

#[test]
fn rock_sits_on_the_ground_and_nothing_grows_on_it() {
    let s = site(5, 20_000);
    let m = &s.mesh;
    let mut hidden_ground = 0;
    for f in faces_of(m, Material::Ground) {
        let c = m.face_centroid(f);
        hidden_ground += usize::from(s.rock.bump(c.x, c.y) > 1.0);
    }
    assert_eq!(hidden_ground, 0, "ground faces left deep under the rock");
    for f in faces_of(m, Material::Rock) {
        for p in m.triangle(f) {
            // Only the cut edge dips below the ground, and not far.
            assert!(p.z >= s.ground.height(p.x, p.y) - 0.5);
        }
    }
    for mat in [Material::Grass, Material::Tree, Material::Marker] {
        for f in faces_of(m, mat) {
            let c = m.face_centroid(f);
            assert!(
                s.rock.bump(c.x, c.y) < 0.0,
                "{} face {f} on the rock",
                mat.name()
            );
        }
    }
    // Grass roots are just below the meshed ground: blades join it.
    for f in faces_of(m, Material::Grass) {
        let [a, b, _] = m.triangle(f);
        for p in [a, b] {
            let d = s.ground.height(p.x, p.y) - p.z;
            assert!(d > 0.0 && d < 0.05, "grass root {d} m below ground");
        }
    }
}

/// Share of vertical rays through the inner canopy footprint that hit no
/// tree face: the canopies must be see-through, not closed blobs.
fn gap_fraction(m: &Mesh, tree: &TreeInfo, tree_faces: &[usize]) -> f64 {
    let [cx, cy] = tree.position;
    let [rx, ry, _] = tree.canopy_radii;
    let tris: Vec<[Point3<f64>; 3]> = tree_faces
        .iter()
        .map(|&f| m.triangle(f))
        .filter(|t| {
            let c = (t[0].coords + t[1].coords + t[2].coords) / 3.0;
            (c.x - cx).hypot(c.y - cy) < 1.3 * rx.max(ry)
        })
        .collect();
    let covered = |x: f64, y: f64| {
        tris.iter().any(|[a, b, c]| {
            let side = |p: &Point3<f64>, q: &Point3<f64>| {
                (q.x - p.x) * (y - p.y) - (q.y - p.y) * (x - p.x)
            };
            let (d1, d2, d3) = (side(a, b), side(b, c), side(c, a));
            (d1 >= 0.0 && d2 >= 0.0 && d3 >= 0.0) || (d1 <= 0.0 && d2 <= 0.0 && d3 <= 0.0)
        })
    };
    let (mut n, mut open) = (0, 0);
    for i in 0..40 {
        for j in 0..40 {
            let (u, v) = (i as f64 / 19.5 - 1.0, j as f64 / 19.5 - 1.0);
            if u * u + v * v > 0.6 {
                continue; // inner part of the footprint only
            }
            n += 1;
            open += usize::from(!covered(cx + u * rx, cy + v * ry));
        }
    }
    open as f64 / n as f64
}

#[test]
fn canopies_have_gaps_you_can_see_through() {
    for target in [10_000, 100_000] {
        let s = site(9, target);
        let tree_faces: Vec<usize> = faces_of(&s.mesh, Material::Tree).collect();
        for t in &s.trees {
            let g = gap_fraction(&s.mesh, t, &tree_faces);
            assert!((0.1..0.8).contains(&g), "{target} faces: gap fraction {g}");
        }
    }
}

#[test]
fn trees_and_markers_stand_clear_and_markers_face_up() {
    let s = generate_site(&SiteParams {
        seed: 11,
        target_faces: 20_000,
        n_trees: 10,
        n_markers: 8,
        ..SiteParams::default()
    })
    .unwrap();
    assert_eq!(s.trees.len(), 10);
    assert_eq!(s.markers.len(), 8);
    for t in &s.trees {
        let [x, y] = t.position;
        assert!(s.rock.bump(x, y) < -1.0);
        for mk in &s.markers {
            assert!((mk.center[0] - x).hypot(mk.center[1] - y) > t.reach());
        }
    }
    for mk in &s.markers {
        let above = mk.center[2] - s.ground.height(mk.center[0], mk.center[1]);
        assert!((0.4..0.8).contains(&above));
    }
    let m = &s.mesh;
    let up: f64 = faces_of(m, Material::Marker)
        .filter(|&f| m.face_normal(f).z > 0.999)
        .map(|f| m.face_area(f))
        .sum();
    assert!((up - 8.0 * MARKER_SIZE * MARKER_SIZE).abs() < 1e-9);
}

#[test]
fn trees_at_the_rock_fringe_its_outline() {
    let s = generate_site(&SiteParams {
        seed: 5,
        target_faces: 30_000,
        n_trees: 4,
        n_trees_at_rock: 4,
        ..SiteParams::default()
    })
    .unwrap();
    assert_eq!(s.trees.len(), 8);
    let (at_rock, open) = s.trees.split_at(4);
    for t in at_rock {
        let [x, y] = t.position;
        // The trunk stands outside the outline, at most 2 m from it.
        assert!(s.rock.ellipse_r(x, y, 0.0) > 1.0, "{t:?}");
        assert!(s.rock.ellipse_r(x, y, 2.0) <= 1.0 + 1e-9, "{t:?}");
    }
    for t in open {
        let [x, y] = t.position;
        assert!(s.rock.ellipse_r(x, y, t.reach() + 2.0) > 1.0, "{t:?}");
    }
}

#[test]
fn flight_volume_is_above_the_ground_and_covers_the_site() {
    let s = site(2, 10_000);
    let v = s.flight_volume;
    let m = &s.mesh;
    let mut low = f64::INFINITY;
    for f in faces_of(m, Material::Ground).chain(faces_of(m, Material::Rock)) {
        for p in m.triangle(f) {
            assert!(p.z + 2.0 <= v.min.z + 1e-9);
            low = low.min(p.z);
        }
    }
    assert!(v.max.z >= low + 60.0 - 1e-9);
    assert_eq!((v.min.x, v.max.y), (-30.0, 30.0));
    assert!(v.contains(&Point3::new(0.0, 0.0, low + 50.0)));
}

#[test]
fn more_trees_leave_terrain_rock_and_first_trees_unchanged() {
    let a = site(4, 20_000);
    let b = generate_site(&SiteParams {
        seed: 4,
        target_faces: 20_000,
        n_trees: 8,
        ..SiteParams::default()
    })
    .unwrap();
    assert_eq!(a.rock.center, b.rock.center);
    assert_eq!(
        a.terrain.slope.map(f64::to_bits),
        b.terrain.slope.map(f64::to_bits)
    );
    let (ha, hb) = (a.terrain.height(3.0, -7.0), b.terrain.height(3.0, -7.0));
    assert_eq!(ha.to_bits(), hb.to_bits());
    assert_eq!(a.trees[..], b.trees[..6]);
    // Marker heights follow the ground mesh, whose resolution shares the
    // face budget with the trees; positions do not move.
    for (p, q) in a.markers.iter().zip(&b.markers) {
        assert_eq!(
            (p.center[0], p.center[1], p.yaw),
            (q.center[0], q.center[1], q.yaw)
        );
    }
}

#[test]
fn params_read_partially_from_json_with_defaults() {
    let p: SiteParams = serde_json::from_str(r#"{"seed": 5, "n_trees": 2}"#).unwrap();
    assert_eq!((p.seed, p.n_trees, p.target_faces), (5, 2, 200_000));
    let back: SiteParams = serde_json::from_str(&serde_json::to_string(&p).unwrap()).unwrap();
    assert_eq!(back, p);
}

#[test]
fn bad_params_are_refused_with_the_field_named() {
    let cases = [
        (
            SiteParams {
                target_faces: 100,
                ..SiteParams::default()
            },
            "target_faces",
        ),
        (
            SiteParams {
                size: 20.0,
                ..SiteParams::default()
            },
            "size",
        ),
        (
            SiteParams {
                meadow: 1.5,
                ..SiteParams::default()
            },
            "meadow",
        ),
        (
            SiteParams {
                rock_height: f64::NAN,
                ..SiteParams::default()
            },
            "rock_height",
        ),
        (
            SiteParams {
                rock_width: 20.0,
                ..SiteParams::default()
            },
            "rock_width",
        ),
        (
            SiteParams {
                target_faces: 10_000,
                n_grass_tufts: Some(5_000),
                ..SiteParams::default()
            },
            "raise target_faces",
        ),
        (
            SiteParams {
                n_trees: 500,
                target_faces: 200_000,
                ..SiteParams::default()
            },
            "trees",
        ),
        (
            SiteParams {
                n_trees: 1_000_000,
                ..SiteParams::default()
            },
            "n_trees",
        ),
        (
            SiteParams {
                n_markers: 100,
                ..SiteParams::default()
            },
            "markers do not fit",
        ),
        (
            SiteParams {
                n_grass_tufts: Some(usize::MAX),
                ..SiteParams::default()
            },
            "n_grass_tufts",
        ),
    ];
    for (p, want) in cases {
        match generate_site(&p) {
            Err(SceneError::InvalidArgument(msg)) => assert!(msg.contains(want), "{msg}"),
            other => panic!("expected an invalid-argument error about {want}, got {other:?}"),
        }
    }
}

proptest::proptest! {
    #![proptest_config(proptest::prelude::ProptestConfig::with_cases(16))]

    /// Any seed and mix of counts gives a valid mesh within 10 % of the
    /// budget, or is refused because the counts cannot fit it (and only then).
    #[test]
    fn any_seed_and_counts_give_a_valid_site_on_budget(
        seed in proptest::prelude::any::<u64>(),
        target in 5_000usize..60_000,
        n_trees in 0usize..12,
        n_markers in 0usize..16,
        grass_share in proptest::option::of(0.0f64..0.2),
        yaw in -180.0f64..180.0,
    ) {
        // Explicit tuft counts up to 20 % of the budget in blades.
        let tufts = grass_share.map(|g| (g * target as f64 / 7.0) as usize);
        let p = SiteParams {
            seed,
            target_faces: target,
            n_trees,
            n_markers,
            n_grass_tufts: tufts,
            rock_yaw_deg: yaw,
            ..SiteParams::default()
        };
        // Faces the fixed parts may take at most (a tuft has up to 9 blades).
        let n_tufts = tufts.unwrap_or_else(|| {
            (super::site::GRASS_SHARE * target as f64 / super::grass::MEAN_BLADES as f64).round()
                as usize
        });
        let worst = n_trees * super::vegetation::WOOD_FACES
            + 9 * n_tufts
            + n_markers * super::markers::MARKER_FACES;
        let shares = super::site::ROCK_SHARE
            + super::site::LEAF_SHARE
            + super::site::MIN_TERRAIN_SHARE;
        let fits = worst as f64 + shares * target as f64 <= 0.99 * target as f64;
        let s = match generate_site(&p) {
            Ok(s) => s,
            Err(SceneError::InvalidArgument(m)) if m.contains("leave too few") => {
                proptest::prop_assert!(!fits, "refused although the counts fit: {m}");
                return Ok(());
            }
            Err(e) => return Err(proptest::test_runner::TestCaseError::fail(e.to_string())),
        };
        s.mesh.validate().unwrap();
        let ratio = s.mesh.n_faces() as f64 / target as f64;
        proptest::prop_assert!((ratio - 1.0).abs() < 0.10, "{}", s.summary());
        proptest::prop_assert_eq!(s.trees.len(), n_trees);
        proptest::prop_assert_eq!(s.markers.len(), n_markers);
        let rock = s.summary().faces_per_material[Material::Rock as usize];
        proptest::prop_assert!(rock > target / 5);
    }
}

/// Share of vertical rays over the ground within 4 m of the rock whose
/// first hit is grass, counting rays that meet bare ground or grass (the
/// rock, trees and markers left out).
fn grass_seen_from_above(s: &Site) -> f64 {
    let caster = crate::raycast::RayCaster::new(&s.mesh);
    let (lo, hi) = s.rock.box_bounds(4.0);
    let top = s.flight_volume.max.z;
    let (mut grass, mut n) = (0usize, 0usize);
    let step = 0.07;
    let mut y = lo[1];
    while y < hi[1] {
        let mut x = lo[0];
        while x < hi[0] {
            if s.rock.within_box(x, y, 4.0) {
                let down = -nalgebra::Vector3::z();
                let hit = caster.closest_hit(&Point3::new(x, y, top), &down, f64::INFINITY);
                match hit.and_then(|h| s.mesh.material(h.face as usize)) {
                    Some(Material::Grass) => (grass, n) = (grass + 1, n + 1),
                    Some(Material::Ground) => n += 1,
                    _ => {}
                }
            }
            x += step;
        }
        y += step;
    }
    grass as f64 / n as f64
}

#[test]
fn a_meadow_hides_the_soil_and_changes_nothing_else() {
    let params = |meadow| SiteParams {
        seed: 6,
        target_faces: 20_000,
        size: 40.0,
        rock_length: 11.0,
        rock_width: 8.0,
        meadow,
        ..SiteParams::default()
    };
    let bare = generate_site(&params(0.0)).unwrap();
    let lush = generate_site(&params(0.9)).unwrap();
    let (before, after) = (grass_seen_from_above(&bare), grass_seen_from_above(&lush));
    assert!(before < 0.05, "tufts alone cover {before:.3} of the ground");
    assert!(
        after > 0.7,
        "a 0.9 meadow covers only {after:.3} of the ground"
    );
    // The meadow's blades come after every other face, on top of the budget.
    let n = bare.mesh.n_faces();
    assert!(bare.mesh.faces[..] == lush.mesh.faces[..n]);
    assert!(bare.mesh.vertices[..] == lush.mesh.vertices[..bare.mesh.n_vertices()]);
    assert!(faces_of(&lush.mesh, Material::Grass).count() > n);
}
