//! `vpctl.scene`: meshes, cameras, COLMAP models, procedural sites, ray
//! casting and clearance (vp-scene).

use std::path::PathBuf;

use nalgebra::{Point2, Point3, Vector3};
use numpy::{PyArray1, PyArray2, PyArray3, PyReadonlyArray1, PyReadonlyArray2, PyReadonlyArray3};
use pyo3::prelude::*;
use pyo3::types::PyDict;
use vp_scene::clearance::Clearance;
use vp_scene::colmap::{self, DepthMap, Reconstruction};
use vp_scene::io::{self, MeshFormat};
use vp_scene::procedural::{self, Site, SiteParams};
use vp_scene::raster::{self, LabelImage};
use vp_scene::raycast::RayCaster;
use vp_scene::{fsio, Camera, Intrinsics, Material, Mesh};

use crate::convert::{self, image2, points, points_array, ArrayPair};
use crate::errors::{value_error, IntoPy};

/// A triangle mesh with optional per-face materials (world frame, metres).
#[pyclass(name = "Mesh", module = "vpctl.scene", frozen)]
pub struct PyMesh(pub Mesh);

#[pymethods]
impl PyMesh {
    /// Vertices (N, 3) float64, faces (M, 3) integer, materials (M,) uint8 or None.
    #[new]
    #[pyo3(signature = (vertices, faces, materials = None))]
    fn new(
        vertices: PyReadonlyArray2<'_, f64>,
        faces: PyReadonlyArray2<'_, i64>,
        materials: Option<PyReadonlyArray1<'_, u8>>,
    ) -> PyResult<Self> {
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
                        Material::from_id(id)
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
        py.detach(|| io::read_mesh(&path)).py().map(PyMesh)
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
        world_from_cam: PyReadonlyArray2<'_, f64>,
    ) -> PyResult<Self> {
        let k = intrinsics(width, height, fx, fy, cx, cy)?;
        Ok(PyCamera(Camera::new(
            k,
            convert::isometry(&world_from_cam, "world_from_cam")?,
        )))
    }

    /// A camera at `center` looking at `target`, roll 0, with horizontal
    /// field of view `hfov_deg`.
    #[staticmethod]
    fn look_at(
        width: u32,
        height: u32,
        hfov_deg: f64,
        center: [f64; 3],
        target: [f64; 3],
    ) -> PyResult<Self> {
        let k = Intrinsics::from_hfov(width, height, hfov_deg).py()?;
        Camera::look_at(k, Point3::from(center), Point3::from(target))
            .py()
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
        pts: PyReadonlyArray2<'_, f64>,
    ) -> PyResult<Bound<'py, PyArray2<f64>>> {
        let p = points(&pts, "points")?;
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
        pixels: PyReadonlyArray2<'_, f64>,
    ) -> PyResult<ArrayPair<'py, PyArray2<f64>, PyArray2<f64>>> {
        let v = pixels.as_array();
        if v.ncols() != 2 {
            return Err(value_error(format!(
                "pixels: expected an (N, 2) array, got shape {:?}",
                v.shape()
            )));
        }
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

/// A COLMAP sparse model (cameras, images, points).
#[pyclass(name = "ColmapModel", module = "vpctl.scene", frozen)]
pub struct PyColmap(pub Reconstruction);

#[pymethods]
impl PyColmap {
    /// Reads a model folder (binary or text, detected).
    #[staticmethod]
    fn load(py: Python<'_>, path: PathBuf) -> PyResult<Self> {
        py.detach(|| colmap::read_model(&path)).py().map(PyColmap)
    }

    /// Writes the model into `path` as `binary` or `text` files.
    #[pyo3(signature = (path, format = "binary"))]
    fn save(&self, py: Python<'_>, path: PathBuf, format: &str) -> PyResult<()> {
        match format {
            "binary" => py.detach(|| colmap::write_binary(&path, &self.0)).py(),
            "text" => py.detach(|| colmap::write_text(&path, &self.0)).py(),
            other => Err(value_error(format!(
                "format {other:?}: expected \"binary\" or \"text\""
            ))),
        }
    }

    /// Image names in id order.
    #[getter]
    fn image_names(&self) -> Vec<String> {
        self.0.images.values().map(|i| i.name.clone()).collect()
    }

    /// One camera per image, in id order.
    fn cameras(&self) -> PyResult<Vec<PyCamera>> {
        self.0
            .images
            .keys()
            .map(|&id| self.0.camera_of(id).py().map(PyCamera))
            .collect()
    }

    /// 3D points, (N, 3).
    #[getter]
    fn points<'py>(&self, py: Python<'py>) -> Bound<'py, PyArray2<f64>> {
        let p: Vec<Point3<f64>> = self.0.points.values().map(|p| p.xyz).collect();
        points_array(py, &p)
    }

    fn __len__(&self) -> usize {
        self.0.images.len()
    }
}

/// Reads a COLMAP depth map (.bin) as an (H, W) float32 array.
#[pyfunction]
fn read_depth_map(py: Python<'_>, path: PathBuf) -> PyResult<Bound<'_, PyArray2<f32>>> {
    let d = py.detach(|| colmap::read_depth_map(&path)).py()?;
    image2(py, d.width, d.height, d.data)
}

/// Writes an (H, W) float32 array as a COLMAP depth map (.bin).
#[pyfunction]
fn write_depth_map(path: PathBuf, depth: PyReadonlyArray2<'_, f32>) -> PyResult<()> {
    colmap::write_depth_map(&path, &depth_map(&depth)).py()
}

/// An (H, W) float32 array as a depth map.
pub fn depth_map(a: &PyReadonlyArray2<'_, f32>) -> DepthMap {
    let v = a.as_array();
    DepthMap {
        width: v.ncols() as u32,
        height: v.nrows() as u32,
        data: v.iter().copied().collect(),
    }
}

/// Reads an image file (PNG, JPEG, TIFF) as an (H, W, 3) uint8 array.
#[pyfunction]
fn load_image(py: Python<'_>, path: PathBuf) -> PyResult<Bound<'_, PyArray3<u8>>> {
    let img = py.detach(|| raster::load_rgb(&path)).py()?;
    convert::rgb_array(py, &img)
}

/// Writes an (H, W, 3) uint8 array as an image file (format from the
/// extension); refuses to overwrite unless `force`.
#[pyfunction]
#[pyo3(signature = (path, image, force = false))]
fn save_image(path: PathBuf, image: PyReadonlyArray3<'_, u8>, force: bool) -> PyResult<()> {
    let img = convert::rgb(&image, "image")?;
    fsio::check_overwrite(&path, force).py()?;
    raster::save_rgb(&img, &path).py()
}

/// Writes labels (H, W) uint8 (0 unlabelled, 1 positive, 2 negative) and
/// angles (H, W) float32 (degrees) as a `.vplabel` file.
#[pyfunction]
#[pyo3(signature = (path, labels, angles, force = false))]
fn write_label_image(
    path: PathBuf,
    labels: PyReadonlyArray2<'_, u8>,
    angles: PyReadonlyArray2<'_, f32>,
    force: bool,
) -> PyResult<()> {
    let img = convert::label_image(&labels, &angles, "labels")?;
    fsio::check_overwrite(&path, force).py()?;
    img.save(&path).py()
}

/// Reads a `.vplabel` file as (labels (H, W) uint8, angles (H, W) float32).
#[pyfunction]
fn read_label_image(
    py: Python<'_>,
    path: PathBuf,
) -> PyResult<ArrayPair<'_, PyArray2<u8>, PyArray2<f32>>> {
    let img = LabelImage::load(&path).py()?;
    convert::label_arrays(py, &img)
}

/// BVH over a mesh for batches of rays (CWBVH, obvhs).
#[pyclass(name = "RayCaster", module = "vpctl.scene", frozen)]
pub struct PyRayCaster(pub RayCaster);

#[pymethods]
impl PyRayCaster {
    #[new]
    fn new(py: Python<'_>, mesh: PyRef<'_, PyMesh>) -> Self {
        let m = &mesh.0;
        PyRayCaster(py.detach(|| RayCaster::new(m)))
    }

    /// Closest hits of rays (origins (N, 3), directions (N, 3), normalised
    /// here) up to `t_max`: dict of `t` (N,) (inf on a miss), `face` (N,)
    /// int64 (-1 on a miss) and `points` (N, 3) (NaN on a miss).
    #[pyo3(signature = (origins, directions, t_max = f64::INFINITY))]
    fn closest_hits<'py>(
        &self,
        py: Python<'py>,
        origins: PyReadonlyArray2<'_, f64>,
        directions: PyReadonlyArray2<'_, f64>,
        t_max: f64,
    ) -> PyResult<Bound<'py, PyDict>> {
        let o = points(&origins, "origins")?;
        let d = points(&directions, "directions")?;
        if o.len() != d.len() {
            return Err(value_error(format!(
                "{} origins but {} directions",
                o.len(),
                d.len()
            )));
        }
        if !(t_max > 0.0) {
            return Err(value_error(format!("t_max = {t_max} must be positive")));
        }
        let mut rays = Vec::with_capacity(o.len());
        for (i, (o, d)) in o.iter().zip(&d).enumerate() {
            let n = d.coords.norm();
            if !(n > 0.0) {
                return Err(value_error(format!("directions: row {i} has zero length")));
            }
            rays.push((*o, Vector3::from(d.coords / n)));
        }
        let hits = py.detach(|| self.0.closest_hits(&rays, t_max));
        let t: Vec<f64> = hits
            .iter()
            .map(|h| h.map_or(f64::INFINITY, |h| h.t))
            .collect();
        let face: Vec<i64> = hits
            .iter()
            .map(|h| h.map_or(-1, |h| i64::from(h.face)))
            .collect();
        let nan = Point3::new(f64::NAN, f64::NAN, f64::NAN);
        let pts: Vec<Point3<f64>> = hits.iter().map(|h| h.map_or(nan, |h| h.point)).collect();
        let out = PyDict::new(py);
        out.set_item("t", PyArray1::from_vec(py, t))?;
        out.set_item("face", PyArray1::from_vec(py, face))?;
        out.set_item("points", points_array(py, &pts))?;
        Ok(out)
    }

    /// Whether a surface lies between `a[i]` and `b[i]`, (N,) bool.
    fn occluded<'py>(
        &self,
        py: Python<'py>,
        a: PyReadonlyArray2<'_, f64>,
        b: PyReadonlyArray2<'_, f64>,
    ) -> PyResult<Bound<'py, PyArray1<bool>>> {
        let (a, b) = (points(&a, "a")?, points(&b, "b")?);
        if a.len() != b.len() {
            return Err(value_error(format!(
                "{} starts but {} ends",
                a.len(),
                b.len()
            )));
        }
        let segs: Vec<(Point3<f64>, Point3<f64>)> = a.into_iter().zip(b).collect();
        Ok(PyArray1::from_vec(
            py,
            py.detach(|| self.0.occluded_batch(&segs)),
        ))
    }

    /// Depth (along the optical axis, 0 where no surface) and face id (-1)
    /// images seen by `camera`, each (H, W).
    fn render_depth<'py>(
        &self,
        py: Python<'py>,
        camera: PyRef<'_, PyCamera>,
    ) -> PyResult<ArrayPair<'py, PyArray2<f32>, PyArray2<i64>>> {
        let cam = &camera.0;
        let (depth, face) = py.detach(|| self.0.render_depth(cam));
        let face: Vec<i64> = face
            .into_iter()
            .map(|f| if f == u32::MAX { -1 } else { i64::from(f) })
            .collect();
        let k = camera.0.intrinsics;
        Ok((
            image2(py, k.width, k.height, depth)?,
            image2(py, k.width, k.height, face)?,
        ))
    }
}

/// Distance to a mesh (parry3d), for safety checks.
#[pyclass(name = "Clearance", module = "vpctl.scene", frozen)]
pub struct PyClearance(Clearance);

#[pymethods]
impl PyClearance {
    #[new]
    fn new(py: Python<'_>, mesh: PyRef<'_, PyMesh>) -> Self {
        let m = &mesh.0;
        PyClearance(py.detach(|| Clearance::new(m)))
    }

    /// Distance of each point (N, 3) to the mesh, (N,).
    fn distance<'py>(
        &self,
        py: Python<'py>,
        pts: PyReadonlyArray2<'_, f64>,
    ) -> PyResult<Bound<'py, PyArray1<f64>>> {
        let p = points(&pts, "points")?;
        let d: Vec<f64> = py.detach(|| p.iter().map(|q| self.0.distance(q)).collect());
        Ok(PyArray1::from_vec(py, d))
    }

    /// Whether each point keeps `radius` from the mesh, (N,) bool.
    fn points_clear<'py>(
        &self,
        py: Python<'py>,
        pts: PyReadonlyArray2<'_, f64>,
        radius: f64,
    ) -> PyResult<Bound<'py, PyArray1<bool>>> {
        check_radius(radius)?;
        let p = points(&pts, "points")?;
        let c: Vec<bool> =
            py.detach(|| p.iter().map(|q| self.0.point_is_clear(q, radius)).collect());
        Ok(PyArray1::from_vec(py, c))
    }

    /// Whether each segment a[i]-b[i] keeps `radius` from the mesh, (N,) bool.
    fn segments_clear<'py>(
        &self,
        py: Python<'py>,
        a: PyReadonlyArray2<'_, f64>,
        b: PyReadonlyArray2<'_, f64>,
        radius: f64,
    ) -> PyResult<Bound<'py, PyArray1<bool>>> {
        check_radius(radius)?;
        let (a, b) = (points(&a, "a")?, points(&b, "b")?);
        if a.len() != b.len() {
            return Err(value_error(format!(
                "{} starts but {} ends",
                a.len(),
                b.len()
            )));
        }
        let c: Vec<bool> = py.detach(|| {
            a.iter()
                .zip(&b)
                .map(|(p, q)| self.0.segment_is_clear(p, q, radius))
                .collect()
        });
        Ok(PyArray1::from_vec(py, c))
    }
}

fn check_radius(radius: f64) -> PyResult<()> {
    if radius.is_finite() && radius >= 0.0 {
        Ok(())
    } else {
        Err(value_error(format!(
            "radius = {radius} must be finite and >= 0"
        )))
    }
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
    m.add_function(wrap_pyfunction!(read_depth_map, m)?)?;
    m.add_function(wrap_pyfunction!(write_depth_map, m)?)?;
    m.add_function(wrap_pyfunction!(load_image, m)?)?;
    m.add_function(wrap_pyfunction!(save_image, m)?)?;
    m.add_function(wrap_pyfunction!(write_label_image, m)?)?;
    m.add_function(wrap_pyfunction!(read_label_image, m)?)?;
    Ok(())
}
