//! `vpctl plan --roi-polygon`: an area drawn in Google Earth (KML, KMZ) or
//! QGIS (GeoJSON) in longitude/latitude, placed through the model's
//! georeference, limits what both planners work on; bad areas are refused
//! with exit 2, the file named and nothing written.

mod common;

use std::path::Path;

use common::{plan_fixture, snapshot, stderr, vpctl};
use nalgebra::{Point2, Point3};
use vp_scene::geodesy::LocalFrame;
use vp_scene::plan::{GeodeticOrigin, Plan, Role};
use vp_scene::raycast::RayCaster;
use vp_scene::roi::point_in_polygon;
use vp_scene::Intrinsics;

/// Corners (x, y) of the test area, in the fixture's ENU frame: a square
/// of 24 m around the rock's centre, i.e. part of the 44 m site the model
/// covers.
fn area_xy(site: &vp_scene::procedural::Site) -> Vec<[f64; 2]> {
    let b = site.rock_bounds;
    let c = nalgebra::center(&b.min, &b.max);
    let h = 12.0;
    vec![
        [c.x - h, c.y - h],
        [c.x + h, c.y - h],
        [c.x + h, c.y + h],
        [c.x - h, c.y + h],
    ]
}

/// (lon, lat) of ENU points (x, y), at the fixture's origin (its frame.json).
fn lon_lat(xy: &[[f64; 2]]) -> Vec<[f64; 2]> {
    let f = LocalFrame::new(GeodeticOrigin::default()).unwrap();
    xy.iter()
        .map(|&[x, y]| {
            let g = f.to_geodetic([x, y, 0.0]);
            [g.lon_deg, g.lat_deg]
        })
        .collect()
}

/// A KML file as Google Earth Pro saves a polygon drawn with "Add Polygon"
/// (ring closed, `lon,lat,alt` tuples, tabs and a style).
fn google_earth_kml(name: &str, ring: &[[f64; 2]]) -> String {
    let mut closed = ring.to_vec();
    closed.push(ring[0]);
    let coords: Vec<String> = closed
        .iter()
        .map(|[lon, lat]| format!("{lon:.12},{lat:.12},0"))
        .collect();
    format!(
        r#"<?xml version="1.0" encoding="UTF-8"?>
<kml xmlns="http://www.opengis.net/kml/2.2" xmlns:gx="http://www.google.com/kml/ext/2.2" xmlns:kml="http://www.opengis.net/kml/2.2" xmlns:atom="http://www.w3.org/2005/Atom">
<Document>
	<name>{name}.kml</name>
	<Style id="s_ylw-pushpin">
		<LineStyle><color>ff0000ff</color><width>2</width></LineStyle>
		<PolyStyle><fill>0</fill></PolyStyle>
	</Style>
	<Placemark>
		<name>{name}</name>
		<styleUrl>#s_ylw-pushpin</styleUrl>
		<Polygon>
			<tessellate>1</tessellate>
			<outerBoundaryIs>
				<LinearRing>
					<coordinates>
						{} 
					</coordinates>
				</LinearRing>
			</outerBoundaryIs>
		</Polygon>
	</Placemark>
</Document>
</kml>
"#,
        coords.join(" ")
    )
}

/// A GeoJSON file as QGIS exports a polygon layer (RFC 7946: WGS84,
/// MultiPolygon, a `name` attribute).
fn qgis_geojson(name: &str, ring: &[[f64; 2]]) -> String {
    let mut closed = ring.to_vec();
    closed.push(ring[0]);
    let coords: Vec<String> = closed
        .iter()
        .map(|[lon, lat]| format!("[ {lon:.12}, {lat:.12} ]"))
        .collect();
    format!(
        r#"{{
"type": "FeatureCollection",
"name": "{name}",
"features": [
{{ "type": "Feature", "properties": {{ "fid": 1, "name": "{name}" }}, "geometry": {{ "type": "MultiPolygon", "coordinates": [ [ [ {} ] ] ] }} }}
]
}}
"#,
        coords.join(", ")
    )
}

fn s(p: &Path) -> &str {
    p.to_str().unwrap()
}

fn grid(dir: &Path, roi: &[&str], out: &str) -> std::process::Output {
    let (mesh, cfg, out) = (dir.join("site.ply"), dir.join("plan.toml"), dir.join(out));
    let mut args = vec![
        "plan",
        "grid",
        "--mesh",
        s(&mesh),
        "--config",
        s(&cfg),
        "--origin",
        "46.03,10.35,400",
        "--height",
        "30",
        "--out",
        s(&out),
    ];
    args.extend_from_slice(roi);
    vpctl(&args)
}

/// Writes the area `ll` as Google Earth's KML and QGIS's GeoJSON, plans
/// with each through `run(area file, plan file)` and checks both give the
/// same plan bytes; returns the stdout of the KML run (plan in `kml.json`).
fn kml_and_geojson_plan_alike(
    d: &Path,
    ll: &[[f64; 2]],
    run: impl Fn(&Path, &Path) -> std::process::Output,
) -> String {
    std::fs::write(d.join("area.kml"), google_earth_kml("Rock", ll)).unwrap();
    std::fs::write(d.join("area.geojson"), qgis_geojson("Rock", ll)).unwrap();
    let mut stdout = String::new();
    for (area, out) in [("area.kml", "kml.json"), ("area.geojson", "geojson.json")] {
        let o = run(&d.join(area), &d.join(out));
        assert!(o.status.success(), "{area}: {}", stderr(&o));
        if stdout.is_empty() {
            stdout = common::stdout(&o);
        }
    }
    assert_eq!(
        std::fs::read(d.join("kml.json")).unwrap(),
        std::fs::read(d.join("geojson.json")).unwrap()
    );
    stdout
}

#[test]
fn a_kml_area_limits_the_grid_and_geojson_gives_the_same_plan() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    let site = plan_fixture(d);
    let xy = area_xy(&site);
    let ll = lon_lat(&xy);
    kml_and_geojson_plan_alike(d, &ll, |area, out| {
        let out = out.file_name().unwrap().to_str().unwrap();
        grid(d, &["--roi-polygon", s(area)], out)
    });
    let o = grid(d, &[], "all.json");
    assert!(o.status.success(), "{}", stderr(&o));
    // Nadir photos: the grid's photo centres lie over the area (its
    // footprint's bounds, the faces inside reach a little past the
    // corners), and fewer than over the whole site.
    let area = Plan::load(&d.join("kml.json")).unwrap();
    let all = Plan::load(&d.join("all.json")).unwrap();
    let photos = |p: &Plan| {
        p.waypoints
            .iter()
            .filter(|w| w.role == Role::Grid)
            .map(|w| w.position)
            .collect::<Vec<_>>()
    };
    let (lo, hi) = (xy[0], xy[2]);
    for p in photos(&area) {
        assert!(
            p[0] > lo[0] - 2.0 && p[0] < hi[0] + 2.0 && p[1] > lo[1] - 2.0 && p[1] < hi[1] + 2.0,
            "photo at {p:?} outside the area {lo:?}..{hi:?}"
        );
    }
    assert!(photos(&area).len() < photos(&all).len());
}

#[test]
fn a_kml_area_makes_the_planned_views_look_at_it() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    let site = plan_fixture(d);
    // The rock's outline, and its height range (--roi-heights): the
    // planner's triplets look at the rock, not at the ground around it.
    let b = site.rock_bounds;
    let xy = vec![
        [b.min.x, b.min.y],
        [b.max.x, b.min.y],
        [b.max.x, b.max.y],
        [b.min.x, b.max.y],
    ];
    let heights = format!("{},{}", b.min.z, b.max.z);
    let ll = lon_lat(&xy);
    let summary = kml_and_geojson_plan_alike(d, &ll, |area, out| {
        let (mesh, model, cfg) = (d.join("site.ply"), d.join("model"), d.join("plan.toml"));
        vpctl(&[
            "plan",
            "--mesh",
            s(&mesh),
            "--colmap",
            s(&model),
            "--config",
            s(&cfg),
            "--roi-polygon",
            s(area),
            "--roi-heights",
            &heights,
            "--out",
            s(out),
            "--no-timings",
        ])
    });
    // Every triplet member's optical axis meets the site inside the area
    // (grown by 3 m: a triplet looks at a patch, not a point).
    let plan = Plan::load(&d.join("kml.json")).unwrap();
    let k = Intrinsics::new(1200, 800, 1800.0, 1800.0, 600.0, 400.0).unwrap();
    let caster = RayCaster::new(&site.mesh);
    let grown: Vec<[f64; 2]> = {
        let (lo, hi) = (xy[0], xy[2]);
        vec![
            [lo[0] - 3.0, lo[1] - 3.0],
            [hi[0] + 3.0, lo[1] - 3.0],
            [hi[0] + 3.0, hi[1] + 3.0],
            [lo[0] - 3.0, hi[1] + 3.0],
        ]
    };
    let members: Vec<_> = plan
        .waypoints
        .iter()
        .filter(|w| w.role == Role::TripletMember)
        .collect();
    assert!(!members.is_empty(), "{summary}");
    for w in members {
        let cam = w.to_camera(k);
        let hit: Point3<f64> = caster
            .closest_hit(&cam.center(), &cam.axis(), 1000.0)
            .expect("the view looks at the site")
            .point;
        assert!(
            point_in_polygon(&Point2::new(hit.x, hit.y), &grown),
            "view at {:?} looks at {hit:?}, outside the area",
            w.position
        );
    }
}

#[test]
fn bad_areas_exit_2_with_the_file_named_and_nothing_written() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    let site = plan_fixture(d);
    let xy = area_xy(&site);
    let ll = lon_lat(&xy);
    let shifted = |dx: f64| -> Vec<[f64; 2]> {
        lon_lat(&xy.iter().map(|&[x, y]| [x + dx, y]).collect::<Vec<_>>())
    };
    let swapped: Vec<[f64; 2]> = ll.iter().map(|&[lon, lat]| [lat, lon]).collect();
    let bowtie = vec![ll[0], ll[2], ll[1], ll[3]];
    let flat = vec![ll[0], ll[1], ll[0], ll[1]];
    let files = [
        ("bowtie.kml", google_earth_kml("Bowtie", &bowtie), "crosses itself"),
        ("flat.kml", google_earth_kml("Flat", &flat), "2 distinct corners"),
        ("swapped.kml", google_earth_kml("Swapped", &swapped), "more than 10 km"),
        ("beside.geojson", qgis_geojson("Beside", &shifted(2000.0)), "does not overlap the model"),
        (
            "pin.kml",
            "<kml xmlns=\"http://www.opengis.net/kml/2.2\"><Placemark><name>Pin</name><Point><coordinates>10.35,46.03,0</coordinates></Point></Placemark></kml>".into(),
            "no polygon",
        ),
    ];
    for (name, text, _) in &files {
        std::fs::write(d.join(name), text).unwrap();
    }
    {
        let mut z = zip::ZipWriter::new(std::fs::File::create(d.join("photos.kmz")).unwrap());
        z.start_file("files/photo.jpg", zip::write::SimpleFileOptions::default())
            .unwrap();
        z.finish().unwrap();
    }
    std::fs::write(d.join("area.kml"), google_earth_kml("Rock", &ll)).unwrap();
    let before = snapshot(d);
    // (file, whether the grid is given its origin, what the error says)
    let mut cases: Vec<(&str, bool, &str)> =
        files.iter().map(|(n, _, why)| (*n, true, *why)).collect();
    cases.push(("photos.kmz", true, "no .kml document"));
    // A grid without a georeference: the area cannot be placed.
    cases.push(("area.kml", false, "no geodetic origin"));
    for &(file, georeferenced, why) in &cases {
        let area = d.join(file);
        let o = if georeferenced {
            grid(d, &["--roi-polygon", s(&area)], "out.json")
        } else {
            let (mesh, out) = (d.join("site.ply"), d.join("out.json"));
            vpctl(&[
                "plan",
                "grid",
                "--mesh",
                s(&mesh),
                "--roi-polygon",
                s(&area),
                "--out",
                s(&out),
            ])
        };
        let err = stderr(&o);
        assert_eq!(o.status.code(), Some(2), "{file}: {err}");
        assert!(err.contains(file) && err.contains(why), "{file}: {err}");
        assert!(snapshot(d) == before, "{file}: files were written");
    }
    // A model without frame.json, planned as local ENU: no georeference.
    std::fs::remove_file(d.join("model/frame.json")).unwrap();
    let before = snapshot(d);
    let (mesh, model, cfg, area, out) = (
        d.join("site.ply"),
        d.join("model"),
        d.join("plan.toml"),
        d.join("area.kml"),
        d.join("out.json"),
    );
    let o = vpctl(&[
        "plan",
        "--mesh",
        s(&mesh),
        "--colmap",
        s(&model),
        "--config",
        s(&cfg),
        "--frame-unchecked",
        "--roi-polygon",
        s(&area),
        "--out",
        s(&out),
    ]);
    let err = stderr(&o);
    assert_eq!(o.status.code(), Some(2), "{err}");
    assert!(
        err.contains("area.kml") && err.contains("--origin"),
        "{err}"
    );
    assert!(snapshot(d) == before);
}
