//! Regions of interest: which faces the quality requirements apply to, as
//! `vpctl plan --roi FILE` (JSON), `--roi-box` and the Python `roi=` give it.
//!
//! The JSON file holds one object with a `kind` and that kind's fields:
//!
//! ```json
//! {"kind": "box", "min": [x, y, z], "max": [x, y, z]}
//! {"kind": "polygon", "polygon": [[x, y], ...], "z_min": z, "z_max": z}
//! {"kind": "polygon", "polygon": [...], "holes": [[[x, y], ...]], "z_min": z, "z_max": z}
//! {"kind": "image_polygon", "camera": {...}, "polygon": [[u, v], ...]}
//! ```
//!
//! Coordinates are the mesh's (local ENU metres); image polygons are in
//! pixels of the camera given. Areas drawn on a map (KML, KMZ, GeoJSON in
//! longitude/latitude) are read by [`crate::roi_file`] into a polygon.

use std::path::Path;

use nalgebra::{Point2, Point3};
use serde::{Deserialize, Serialize};

use crate::camera::Camera;
use crate::error::{Location, Result, SceneError};
use crate::fsio;
use crate::mesh::{Aabb, Mesh};
use crate::raycast::RayCaster;

/// A region of interest: which faces the quality requirements apply to.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(tag = "kind", rename_all = "snake_case")]
pub enum Roi {
    /// Faces whose centroid lies inside an axis-aligned box.
    Box {
        /// Smallest corner (x, y, z).
        min: [f64; 3],
        /// Largest corner (x, y, z).
        max: [f64; 3],
    },
    /// Faces whose centroid lies inside a ground polygon (x, y; even-odd
    /// rule), outside its holes, and within a height range.
    Polygon {
        /// Polygon corners (x, y) in metres, in order; closed implicitly.
        polygon: Vec<[f64; 2]>,
        /// Holes cut out of the polygon (x, y corners each), e.g. the inner
        /// boundaries of a KML polygon; none by default.
        #[serde(default, skip_serializing_if = "Vec::is_empty")]
        holes: Vec<Vec<[f64; 2]>>,
        /// Lowest centroid height.
        z_min: f64,
        /// Highest centroid height.
        z_max: f64,
    },
    /// Faces visible in one image whose centroid projects inside a polygon
    /// drawn in that image.
    ImagePolygon {
        /// The image's camera.
        camera: Camera,
        /// Polygon corners in pixels, in order; closed implicitly.
        polygon: Vec<[f64; 2]>,
    },
}

impl Roi {
    /// A box ROI from `[xmin, ymin, zmin, xmax, ymax, zmax]` (`--roi-box`);
    /// each minimum must not exceed its maximum.
    pub fn from_box(b: [f64; 6]) -> Result<Roi> {
        let ok = b.iter().all(|v| v.is_finite()) && (0..3).all(|i| b[i] <= b[i + 3]);
        if !ok {
            return Err(SceneError::InvalidArgument(format!(
                "region-of-interest box {b:?}: expected finite xmin ymin zmin xmax ymax zmax \
                 with each minimum <= its maximum"
            )));
        }
        Ok(Roi::Box {
            min: [b[0], b[1], b[2]],
            max: [b[3], b[4], b[5]],
        })
    }

    /// Reads a region of interest from a JSON file (see the module docs);
    /// errors name the file, the line and the column.
    pub fn load(path: &Path) -> Result<Roi> {
        let text = fsio::read_text(path)?;
        serde_json::from_str(&text).map_err(|e| {
            SceneError::parse(
                path,
                Location::Line(e.line()),
                format!(
                    "column {}: not a region of interest ({{\"kind\": \"box\" | \"polygon\" | \
                     \"image_polygon\", ...}}): {e}",
                    e.column()
                ),
            )
        })
    }

    /// A box ROI from an [`Aabb`].
    pub fn from_aabb(b: &Aabb) -> Roi {
        Roi::Box {
            min: b.min.into(),
            max: b.max.into(),
        }
    }

    /// Indices of the faces of `mesh` inside the region. `caster` must be
    /// built from `mesh` (used only by [`Roi::ImagePolygon`]).
    pub fn select(&self, mesh: &Mesh, caster: &RayCaster) -> Result<Vec<u32>> {
        let inside: Vec<bool> = match self {
            Roi::Box { min, max } => {
                let b = Aabb {
                    min: Point3::from(*min),
                    max: Point3::from(*max),
                };
                (0..mesh.n_faces())
                    .map(|f| b.contains(&mesh.face_centroid(f)))
                    .collect()
            }
            Roi::Polygon {
                polygon,
                holes,
                z_min,
                z_max,
            } => {
                check_polygon(polygon)?;
                for h in holes {
                    check_polygon(h)?;
                }
                (0..mesh.n_faces())
                    .map(|f| {
                        let c = mesh.face_centroid(f);
                        let p = Point2::new(c.x, c.y);
                        c.z >= *z_min
                            && c.z <= *z_max
                            && point_in_polygon(&p, polygon)
                            && !holes.iter().any(|h| point_in_polygon(&p, h))
                    })
                    .collect()
            }
            Roi::ImagePolygon { camera, polygon } => {
                check_polygon(polygon)?;
                let visible = caster.visible_faces(camera, mesh);
                (0..mesh.n_faces())
                    .map(|f| {
                        visible[f]
                            && camera
                                .project(&mesh.face_centroid(f))
                                .is_some_and(|px| point_in_polygon(&px, polygon))
                    })
                    .collect()
            }
        };
        Ok(inside
            .iter()
            .enumerate()
            .filter_map(|(f, &i)| i.then_some(f as u32))
            .collect())
    }
}

fn check_polygon(polygon: &[[f64; 2]]) -> Result<()> {
    if polygon.len() < 3 || polygon.iter().flatten().any(|c| !c.is_finite()) {
        return Err(SceneError::InvalidArgument(format!(
            "region-of-interest polygon needs at least 3 finite corners, got {}",
            polygon.len()
        )));
    }
    Ok(())
}

/// Even-odd point-in-polygon test.
pub fn point_in_polygon(p: &Point2<f64>, polygon: &[[f64; 2]]) -> bool {
    let mut inside = false;
    let n = polygon.len();
    for i in 0..n {
        let [xi, yi] = polygon[i];
        let [xj, yj] = polygon[(i + n - 1) % n];
        if (yi > p.y) != (yj > p.y) && p.x < (xj - xi) * (p.y - yi) / (yj - yi) + xi {
            inside = !inside;
        }
    }
    inside
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn box_and_file_forms() {
        assert!(Roi::from_box([0.0, 0.0, 0.0, 1.0, 1.0, 1.0]).is_ok());
        let e = Roi::from_box([2.0, 0.0, 0.0, 1.0, 1.0, 1.0]).unwrap_err();
        assert!(e.to_string().contains("each minimum <= its maximum"), "{e}");
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("roi.json");
        std::fs::write(
            &path,
            r#"{"kind": "box", "min": [0, 0, 0], "max": [1, 1, 1]}"#,
        )
        .unwrap();
        assert_eq!(
            Roi::load(&path).unwrap(),
            Roi::Box {
                min: [0.0; 3],
                max: [1.0; 3]
            }
        );
        std::fs::write(&path, "{\"kind\": \"circle\"}").unwrap();
        let m = Roi::load(&path).unwrap_err().to_string();
        assert!(
            m.contains("roi.json: line 1: column") && m.contains("circle"),
            "{m}"
        );
    }
}
