//! `vpctl.scene`: meshes, cameras, COLMAP models, procedural sites, ray
//! casting and clearance (vp-scene). Files (COLMAP models, depth maps,
//! images, label images) are in [`files`], ray casting and clearance in
//! [`queries`].

use std::path::PathBuf;

use nalgebra::{Point2, Point3};
use numpy::{PyArray1, PyArray2, PyReadonlyArray1, PyReadonlyArray2};
use pyo3::prelude::*;
use pyo3::types::PyDict;
use vp_scene::io::{self, MeshFormat};
use vp_scene::procedural::{self, Site, SiteParams};
use vp_scene::{fsio, Camera, Intrinsics, Material, Mesh};

use crate::convert::{self, image2, points, points_array, ArrayPair};
use crate::errors::{value_error, IntoPy};

mod files;
mod queries;

pub use files::{depth_map, PyColmap};
pub use queries::{PyClearance, PyRayCaster};

/// A triangle mesh with optional per-face materials (world frame, metres).
#[pyclass(name = "Mesh", module = "vpctl.scene", frozen)]
pub struct PyMesh(pub Mesh);

#[pymethods]
impl PyMesh {
    /// Vertices (N, 3) real, faces (M, 3) integer, materials (M,) integer
    /// ids or None: numpy arrays of any numeric dtype (float32 vertices and
    /// int32 faces as open3d gives them) or nested lists.
    #[new]
    #[pyo3(signature = (vertices, faces, materials = None))]
    fn new(
        vertices: &Bound<'_, PyAny>,
        faces: &Bound<'_, PyAny>,
        materials: Option<&Bound<'_, PyAny>>,
    ) -> PyResult<Self> {
        let vertices = convert::f64_2d(vertices, "(N, 3)", "vertices")?;
        let faces: PyReadonlyArray2<'_, i64> =
            convert::array_like(faces, "int64", "iu", "(M, 3)", "faces")?.extract()?;
        let materials: Option<PyReadonlyArray1<'_, i64>> = materials
            .map(|m| convert::array_like(m, "int64", "iu", "(M,)", "materials")?.extract())
            .transpose()?;
        let verts = points(&vertices, "vertices")?;
        let f = faces.as_array();
        if f.ncols() != 3 {
            return Err(value_error(format!(
                "faces: expected an (M, 3) array, got shape {:?}",
                f.shape()
            )));
        }
        let mut tris = Vec::with_capacity(f.nrows());
        for (i, r) in f.rows().into_iter().enumerate() {
            let idx = |k: usize| {
                u32::try_from(r[k])
                    .map_err(|_| value_error(format!("faces: row {i} has index {}", r[k])))
            };
            tris.push([idx(0)?, idx(1)?, idx(2)?]);
        }
        let mats = match materials {
            None => None,
            Some(m) => Some(
                m.as_array()
                    .iter()
                    .map(|&id| {
                        u8::try_from(id)
                            .ok()
                            .and_then(Material::from_id)
                            .ok_or_else(|| value_error(format!("materials: unknown id {id}")))
                    })
                    .collect::<PyResult<Vec<_>>>()?,
            ),
        };
        Ok(PyMesh(Mesh::new(verts, tris, mats).py()?))
    }

    /// Reads a PLY or OBJ file.
    #[staticmethod]
    fn load(py: Python<'_>, path: PathBuf) -> PyResult<Self> {
        crate::errors::read_mesh(py, &path).map(PyMesh)
    }

    /// Writes the mesh; `format` is ply-binary-le (default for .ply),
    /// ply-binary-be, ply-ascii or obj. Refuses to overwrite unless `force`.
    #[pyo3(signature = (path, format = None, force = false))]
    fn save(
        &self,
        py: Python<'_>,
        path: PathBuf,
        format: Option<&str>,
        force: bool,
    ) -> PyResult<()> {
        let format = match format {
            Some(f) => f.parse::<MeshFormat>().py()?,
            None => MeshFormat::for_path(&path).py()?,
        };
        fsio::check_overwrite(&path, force).py()?;
        py.detach(|| io::write_mesh(&path, &self.0, format)).py()
    }

    /// Number of faces.
    #[getter]
    fn n_faces(&self) -> usize {
        self.0.n_faces()
    }

    /// Number of vertices.
    #[getter]
    fn n_vertices(&self) -> usize {
        self.0.n_vertices()
    }

    /// Vertices as an (N, 3) float64 array (a copy).
    #[getter]
    fn vertices<'py>(&self, py: Python<'py>) -> Bound<'py, PyArray2<f64>> {
        points_array(py, &self.0.vertices)
    }

    /// Faces as an (M, 3) int64 array (a copy).
    #[getter]
    fn faces<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyArray2<i64>>> {
        let flat: Vec<i64> = self
            .0
            .faces
            .iter()
            .flatten()
            .map(|&i| i64::from(i))
            .collect();
        image2(py, 3, self.0.n_faces() as u32, flat)
    }

    /// Material id per face, (M,) uint8, or None.
    #[getter]
    fn materials<'py>(&self, py: Python<'py>) -> Option<Bound<'py, PyArray1<u8>>> {
        self.0.materials.as_ref().map(|m| {
            let ids: Vec<u8> = m.iter().map(|&x| x as u8).collect();
            PyArray1::from_vec(py, ids)
        })
    }

    /// Face centroids, (M, 3).
    fn face_centroids<'py>(&self, py: Python<'py>) -> Bound<'py, PyArray2<f64>> {
        points_array(py, &self.0.face_centroids())
    }

    /// Unit face normals, (M, 3).
    fn face_normals<'py>(&self, py: Python<'py>) -> Bound<'py, PyArray2<f64>> {
        let n: Vec<Point3<f64>> = self
            .0
            .face_normals()
            .into_iter()
            .map(Point3::from)
            .collect();
        points_array(py, &n)
    }

    /// Axis-aligned bounds as a (2, 3) array: min row, max row.
    fn bounds<'py>(&self, py: Python<'py>) -> Bound<'py, PyArray2<f64>> {
        let b = self.0.bounds();
        points_array(py, &[b.min, b.max])
    }

    fn __repr__(&self) -> String {
        format!(
            "Mesh({} vertices, {} faces)",
            self.0.n_vertices(),
            self.0.n_faces()
        )
    }
}

/// Names of the materials, indexed by id.
#[pyfunction]
fn material_names() -> Vec<&'static str> {
    Material::ALL.iter().map(|m| m.name()).collect()
}

/// A posed pinhole camera (COLMAP convention: x right, y down, looking along +z).
#[pyclass(name = "Camera", module = "vpctl.scene", frozen, from_py_object)]
#[derive(Clone)]
pub struct PyCamera(pub Camera);

#[pymethods]
impl PyCamera {
    /// Intrinsics in pixels and the 4x4 `world_from_cam` transform.
    #[new]
    #[pyo3(signature = (width, height, fx, fy, cx, cy, world_from_cam))]
    fn new(
        width: u32,
        height: u32,
        fx: f64,
        fy: f64,
        cx: f64,
        cy: f64,
        world_from_cam: &Bound<'_, PyAny>,
    ) -> PyResult<Self> {
        let k = intrinsics(width, height, fx, fy, cx, cy)?;
        let world_from_cam = convert::f64_2d(world_from_cam, "(4, 4)", "world_from_cam")?;
        Ok(PyCamera(Camera::new(
            k,
            convert::isometry(&world_from_cam, "world_from_cam")?,
        )))
    }

    /// A camera at `center` looking at `target`, roll 0, with horizontal
    /// field of view `hfov_deg`. Straight down (the usual aerial view) or
    /// up, where roll is undefined, the image's top points north and its x
    /// axis east (as a map).
    #[staticmethod]
    fn look_at(
        width: u32,
        height: u32,
        hfov_deg: f64,
        center: [f64; 3],
        target: [f64; 3],
    ) -> PyResult<Self> {
        let k = Intrinsics::from_hfov(width, height, hfov_deg).py()?;
        let (c, t) = (Point3::from(center), Point3::from(target));
        let d = t - c;
        if d.norm() > 0.0 && d.x.hypot(d.y) < 1e-9 * d.norm() {
            // Heading north: the image's top is north and its x axis east,
            // as a map (and as vp-sim's initial flights).
            let pitch = std::f64::consts::FRAC_PI_2.copysign(d.z);
            return Ok(PyCamera(Camera::from_yaw_pitch(
                k,
                c,
                std::f64::consts::FRAC_PI_2,
                pitch,
            )));
        }
        Camera::look_at(k, c, t)
            .py()
            .map_err(|e| value_error(format!("center, target: {e}")))
            .map(PyCamera)
    }

    /// (width, height) in pixels.
    #[getter]
    fn size(&self) -> (u32, u32) {
        (self.0.intrinsics.width, self.0.intrinsics.height)
    }

    /// (fx, fy, cx, cy) in pixels.
    #[getter]
    fn intrinsics(&self) -> (f64, f64, f64, f64) {
        let k = self.0.intrinsics;
        (k.fx, k.fy, k.cx, k.cy)
    }

    /// The 4x4 camera-to-world transform.
    #[getter]
    fn world_from_cam<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyArray2<f64>>> {
        convert::matrix_array(py, &self.0.world_from_cam)
    }

    /// Projection centre, world frame.
    #[getter]
    fn center(&self) -> [f64; 3] {
        self.0.center().coords.into()
    }

    /// Pixel coordinates of world points (N, 3) -> (N, 2); NaN behind the camera.
    fn project<'py>(
        &self,
        py: Python<'py>,
        pts: &Bound<'_, PyAny>,
    ) -> PyResult<Bound<'py, PyArray2<f64>>> {
        let p = points(&convert::f64_2d(pts, "(N, 3)", "pts")?, "pts")?;
        let flat: Vec<f64> = p
            .iter()
            .flat_map(|q| match self.0.project(q) {
                Some(px) => [px.x, px.y],
                None => [f64::NAN, f64::NAN],
            })
            .collect();
        image2(py, 2, p.len() as u32, flat)
    }

    /// Rays through pixels (N, 2): (origins (N, 3), unit directions (N, 3)).
    fn rays<'py>(
        &self,
        py: Python<'py>,
        pixels: &Bound<'_, PyAny>,
    ) -> PyResult<ArrayPair<'py, PyArray2<f64>, PyArray2<f64>>> {
        let pixels = convert::f64_2d(pixels, "(N, 2)", "pixels")?;
        let v = pixels.as_array();
        let (o, d): (Vec<Point3<f64>>, Vec<Point3<f64>>) = v
            .rows()
            .into_iter()
            .map(|r| {
                let (o, d) = self.0.ray(&Point2::new(r[0], r[1]));
                (o, Point3::from(d))
            })
            .unzip();
        Ok((points_array(py, &o), points_array(py, &d)))
    }

    fn __repr__(&self) -> String {
        let c = self.0.center();
        format!(
            "Camera({}x{}, center=[{:.3}, {:.3}, {:.3}])",
            self.0.intrinsics.width, self.0.intrinsics.height, c.x, c.y, c.z
        )
    }
}

fn intrinsics(width: u32, height: u32, fx: f64, fy: f64, cx: f64, cy: f64) -> PyResult<Intrinsics> {
    Intrinsics::new(width, height, fx, fy, cx, cy).py()
}

/// A procedural site: mesh with materials, rock bounds, flight volume, origin.
#[pyclass(name = "Site", module = "vpctl.scene", frozen)]
pub struct PySite {
    site: Site,
    mesh: Py<PyMesh>,
}

#[pymethods]
impl PySite {
    /// The scene mesh (per-face materials).
    #[getter]
    fn mesh(&self, py: Python<'_>) -> Py<PyMesh> {
        self.mesh.clone_ref(py)
    }

    /// Bounds of the rock, (2, 3): the natural region of interest.
    #[getter]
    fn rock_bounds<'py>(&self, py: Python<'py>) -> Bound<'py, PyArray2<f64>> {
        let b = self.site.rock_bounds;
        points_array(py, &[b.min, b.max])
    }

    /// Where cameras may fly, (2, 3).
    #[getter]
    fn flight_volume<'py>(&self, py: Python<'py>) -> Bound<'py, PyArray2<f64>> {
        let b = self.site.flight_volume;
        points_array(py, &[b.min, b.max])
    }

    /// WGS84 position of the world origin: {lat_deg, lon_deg, alt_m}.
    #[getter]
    fn origin<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyAny>> {
        convert::to_py(py, &self.site.origin)
    }

    /// The parameters it was made from.
    #[getter]
    fn params<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyAny>> {
        convert::to_py(py, &self.site.params)
    }

    /// Face and vertex counts: {n_faces, n_vertices, faces_per_material: {name: n}, ...}.
    fn summary<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyDict>> {
        let s = self.site.summary();
        let per = PyDict::new(py);
        for (m, n) in Material::ALL.iter().zip(s.faces_per_material) {
            per.set_item(m.name(), n)?;
        }
        let d = PyDict::new(py);
        d.set_item("n_faces", s.n_faces)?;
        d.set_item("n_vertices", s.n_vertices)?;
        d.set_item("faces_per_material", per)?;
        d.set_item("rock_extent", s.rock_extent)?;
        d.set_item("n_trees", s.n_trees)?;
        d.set_item("n_markers", s.n_markers)?;
        Ok(d)
    }

    /// Ground height under (x, y).
    fn surface_height(&self, x: f64, y: f64) -> f64 {
        self.site.surface_height(x, y)
    }

    /// Writes the mesh as `vpctl scene generate` does (same bytes).
    #[pyo3(signature = (path, format = None, force = false))]
    fn save(
        &self,
        py: Python<'_>,
        path: PathBuf,
        format: Option<&str>,
        force: bool,
    ) -> PyResult<()> {
        self.mesh.get().save(py, path, format, force)
    }
}

/// Generates a procedural site (terrain, rock, trees, grass, markers) with
/// about `faces` faces; more parameters (size, n_trees, rock_length, ...)
/// as keywords. Same seed and parameters, same mesh.
#[pyfunction]
#[pyo3(signature = (seed = 1, faces = 200_000, **params))]
fn generate_site(
    py: Python<'_>,
    seed: u64,
    faces: usize,
    params: Option<&Bound<'_, PyDict>>,
) -> PyResult<PySite> {
    let mut p: SiteParams = convert::from_py_strict(params.map(Bound::as_any), "site parameters")?;
    p.seed = seed;
    p.target_faces = faces;
    let site = py.detach(|| procedural::generate_site(&p)).py()?;
    let mesh = Py::new(py, PyMesh(site.mesh.clone()))?;
    Ok(PySite { site, mesh })
}

/// Registers the submodule.
pub fn register(m: &Bound<'_, PyModule>) -> PyResult<()> {
    m.add_class::<PyMesh>()?;
    m.add_class::<PyCamera>()?;
    m.add_class::<PySite>()?;
    m.add_class::<PyColmap>()?;
    m.add_class::<PyRayCaster>()?;
    m.add_class::<PyClearance>()?;
    m.add_function(wrap_pyfunction!(generate_site, m)?)?;
    m.add_function(wrap_pyfunction!(material_names, m)?)?;
    m.add_function(wrap_pyfunction!(files::read_depth_map, m)?)?;
    m.add_function(wrap_pyfunction!(files::write_depth_map, m)?)?;
    m.add_function(wrap_pyfunction!(files::load_image, m)?)?;
    m.add_function(wrap_pyfunction!(files::save_image, m)?)?;
    m.add_function(wrap_pyfunction!(files::write_label_image, m)?)?;
    m.add_function(wrap_pyfunction!(files::read_label_image, m)?)?;
    Ok(())
}
