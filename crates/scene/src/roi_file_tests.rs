use super::*;

/// A rectangle around (lat 46.03, lon 10.35), as Google Earth writes it.
fn kml(placemarks: &str) -> String {
    format!(
        r#"<?xml version="1.0" encoding="UTF-8"?>
<kml xmlns="http://www.opengis.net/kml/2.2" xmlns:gx="http://www.google.com/kml/ext/2.2">
<Document>
	<name>area.kml</name>
	{placemarks}
</Document>
</kml>
"#
    )
}

fn placemark(name: &str, coords: &str, inner: &str) -> String {
    format!(
        r"<Placemark>
		<name>{name}</name>
		<styleUrl>#m_ylw-pushpin</styleUrl>
		<Polygon>
			<tessellate>1</tessellate>
			<outerBoundaryIs>
				<LinearRing>
					<coordinates>
						{coords}
					</coordinates>
				</LinearRing>
			</outerBoundaryIs>{inner}
		</Polygon>
	</Placemark>"
    )
}

const SQUARE: &str =
    "10.349,46.029,0 10.351,46.029,0 10.351,46.031,0 10.349,46.031,0 10.349,46.029,0";

fn write(dir: &Path, name: &str, text: &str) -> PathBuf {
    let p = dir.join(name);
    std::fs::write(&p, text).unwrap();
    p
}

fn origin() -> GeodeticOrigin {
    GeodeticOrigin::new(46.03, 10.35, 400.0).unwrap()
}

#[test]
fn google_earth_kml_becomes_a_local_polygon_around_the_origin() {
    let dir = tempfile::tempdir().unwrap();
    let p = write(dir.path(), "area.kml", &kml(&placemark("Area", SQUARE, "")));
    let g = GeoPolygon::load(&p, None).unwrap();
    assert_eq!(g.name.as_deref(), Some("Area"));
    assert_eq!(g.outer.len(), 4, "closing corner dropped");
    let Roi::Polygon { polygon, holes, .. } = g.to_roi(origin(), -5.0, 50.0).unwrap() else {
        panic!("not a polygon");
    };
    assert!(holes.is_empty());
    // 0.001 deg of longitude at 46.03 N is about 77.4 m; of latitude 111.1 m.
    let [x0, y0] = polygon[0];
    assert!(
        (x0 + 77.4).abs() < 0.5 && (y0 + 111.1).abs() < 0.5,
        "{x0} {y0}"
    );
    let [x2, y2] = polygon[2];
    assert!(
        (x2 - 77.4).abs() < 0.5 && (y2 - 111.1).abs() < 0.5,
        "{x2} {y2}"
    );
}

#[test]
fn geojson_and_kmz_give_the_same_polygon_as_kml() {
    let dir = tempfile::tempdir().unwrap();
    let kml_text = kml(&placemark("Area", SQUARE, ""));
    let from_kml = GeoPolygon::load(&write(dir.path(), "a.kml", &kml_text), None).unwrap();
    let gj = r#"{
"type": "FeatureCollection",
"name": "area",
"features": [
{ "type": "Feature", "properties": { "id": 1, "name": "Area" }, "geometry": { "type": "MultiPolygon", "coordinates": [ [ [ [ 10.349, 46.029 ], [ 10.351, 46.029 ], [ 10.351, 46.031 ], [ 10.349, 46.031 ], [ 10.349, 46.029 ] ] ] ] } }
]
}"#;
    let from_gj = GeoPolygon::load(&write(dir.path(), "a.geojson", gj), None).unwrap();
    assert_eq!(from_gj.outer, from_kml.outer);
    assert_eq!(from_gj.name, from_kml.name);
    let kmz = dir.path().join("a.kmz");
    {
        let mut z = zip::ZipWriter::new(std::fs::File::create(&kmz).unwrap());
        z.start_file("doc.kml", zip::write::SimpleFileOptions::default())
            .unwrap();
        std::io::Write::write_all(&mut z, kml_text.as_bytes()).unwrap();
        z.finish().unwrap();
    }
    assert_eq!(GeoPolygon::load(&kmz, None).unwrap().outer, from_kml.outer);
}

#[test]
fn holes_are_kept_and_several_polygons_need_a_name() {
    let dir = tempfile::tempdir().unwrap();
    let hole = r"
			<innerBoundaryIs><LinearRing><coordinates>10.3495,46.0295,0 10.3505,46.0295,0 10.3505,46.0305,0 10.3495,46.0295,0</coordinates></LinearRing></innerBoundaryIs>";
    let two = kml(&format!(
        "{}{}",
        placemark("North", SQUARE, hole),
        placemark("South", SQUARE, "")
    ));
    let p = write(dir.path(), "two.kml", &two);
    let e = GeoPolygon::load(&p, None).unwrap_err().to_string();
    assert!(
        e.contains("two.kml")
            && e.contains("2 polygons")
            && e.contains("\"North\"")
            && e.contains("--roi-name"),
        "{e}"
    );
    let north = GeoPolygon::load(&p, Some("North")).unwrap();
    assert_eq!(north.holes.len(), 1);
    assert_eq!(north.holes[0].len(), 3);
    let e = GeoPolygon::load(&p, Some("East")).unwrap_err().to_string();
    assert!(e.contains("no polygon named \"East\""), "{e}");
}

#[test]
fn bad_areas_are_refused_with_the_file_named() {
    let dir = tempfile::tempdir().unwrap();
    let cases = [
        (
            "bowtie.kml",
            kml(&placemark(
                "Bowtie",
                "10.349,46.029,0 10.351,46.031,0 10.351,46.029,0 10.349,46.031,0 10.349,46.029,0",
                "",
            )),
            "crosses itself",
        ),
        (
            "line.kml",
            kml(&placemark(
                "Line",
                "10.349,46.029,0 10.351,46.029,0 10.349,46.029,0 10.351,46.029,0",
                "",
            )),
            "2 distinct corners",
        ),
        (
            "point.kml",
            kml("<Placemark><name>P</name><Point><coordinates>10.35,46.03,0</coordinates></Point></Placemark>"),
            "no polygon",
        ),
        ("broken.kml", "<kml><Document><Placemark>".into(), "never closed"),
        (
            "projected.geojson",
            r#"{"type": "FeatureCollection", "crs": {"type": "name", "properties": {"name": "urn:ogc:def:crs:EPSG::32632"}}, "features": []}"#.into(),
            "not WGS84",
        ),
        (
            "metres.geojson",
            r#"{"type": "Polygon", "coordinates": [[[600000, 5100000], [600100, 5100000], [600100, 5100100], [600000, 5100000]]]}"#.into(),
            "not longitude, latitude",
        ),
        ("area.txt", "x".into(), ".kml, .kmz, .geojson or .json"),
    ];
    for (name, text, why) in cases {
        let p = write(dir.path(), name, &text);
        let e = GeoPolygon::load(&p, None).unwrap_err();
        assert!(e.is_input_error());
        let e = e.to_string();
        assert!(e.contains(name) && e.contains(why), "{name}: {e}");
    }
    let kmz = dir.path().join("empty.kmz");
    {
        let mut z = zip::ZipWriter::new(std::fs::File::create(&kmz).unwrap());
        z.start_file("images/icon.png", zip::write::SimpleFileOptions::default())
            .unwrap();
        z.finish().unwrap();
    }
    let e = GeoPolygon::load(&kmz, None).unwrap_err().to_string();
    assert!(
        e.contains("empty.kmz") && e.contains("no .kml document"),
        "{e}"
    );
}

#[test]
fn a_polygon_far_from_the_origin_is_refused() {
    let dir = tempfile::tempdir().unwrap();
    // Latitude and longitude swapped: the area lands in Somalia.
    let swapped = "46.029,10.349,0 46.031,10.349,0 46.031,10.351,0 46.029,10.351,0";
    let p = write(
        dir.path(),
        "swapped.kml",
        &kml(&placemark("A", swapped, "")),
    );
    let g = GeoPolygon::load(&p, None).unwrap();
    let e = g.to_roi(origin(), 0.0, 1.0).unwrap_err().to_string();
    assert!(
        e.contains("swapped.kml") && e.contains("more than 10 km"),
        "{e}"
    );
}

#[test]
fn segment_intersection_cases() {
    assert!(segments_intersect(
        [0.0, 0.0],
        [2.0, 2.0],
        [0.0, 2.0],
        [2.0, 0.0]
    ));
    assert!(!segments_intersect(
        [0.0, 0.0],
        [1.0, 0.0],
        [0.0, 1.0],
        [1.0, 1.0]
    ));
    // Touching at an end, and collinear overlap.
    assert!(segments_intersect(
        [0.0, 0.0],
        [1.0, 0.0],
        [1.0, 0.0],
        [1.0, 1.0]
    ));
    assert!(segments_intersect(
        [0.0, 0.0],
        [2.0, 0.0],
        [1.0, 0.0],
        [3.0, 0.0]
    ));
    assert!(!segments_intersect(
        [0.0, 0.0],
        [1.0, 0.0],
        [2.0, 0.0],
        [3.0, 0.0]
    ));
}
