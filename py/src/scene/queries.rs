//! Ray casting and clearance for `vpctl.scene`.

use nalgebra::{Point3, Vector3};
use numpy::{PyArray1, PyArray2};
use pyo3::prelude::*;
use pyo3::types::PyDict;
use vp_scene::clearance::Clearance;
use vp_scene::raycast::RayCaster;

use super::{PyCamera, PyMesh};
use crate::convert::{f64_2d, image2, points, points_array, ArrayPair};
use crate::errors::value_error;

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
    /// int64 (-1 on a miss) and `points` (N, 3) (NaN on a miss). `t_max`
    /// None: no limit (a default of infinity showed as `Ellipsis` in help()).
    #[pyo3(signature = (origins, directions, t_max = None))]
    fn closest_hits<'py>(
        &self,
        py: Python<'py>,
        origins: &Bound<'_, PyAny>,
        directions: &Bound<'_, PyAny>,
        t_max: Option<f64>,
    ) -> PyResult<Bound<'py, PyDict>> {
        let t_max = t_max.unwrap_or(f64::INFINITY);
        let o = points(&f64_2d(origins, "(N, 3)", "origins")?, "origins")?;
        let d = points(&f64_2d(directions, "(N, 3)", "directions")?, "directions")?;
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
        a: &Bound<'_, PyAny>,
        b: &Bound<'_, PyAny>,
    ) -> PyResult<Bound<'py, PyArray1<bool>>> {
        let (a, b) = (
            points(&f64_2d(a, "(N, 3)", "a")?, "a")?,
            points(&f64_2d(b, "(N, 3)", "b")?, "b")?,
        );
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
        pts: &Bound<'_, PyAny>,
    ) -> PyResult<Bound<'py, PyArray1<f64>>> {
        let p = points(&f64_2d(pts, "(N, 3)", "pts")?, "pts")?;
        let d: Vec<f64> = py.detach(|| p.iter().map(|q| self.0.distance(q)).collect());
        Ok(PyArray1::from_vec(py, d))
    }

    /// Whether each point keeps `radius` from the mesh, (N,) bool.
    fn points_clear<'py>(
        &self,
        py: Python<'py>,
        pts: &Bound<'_, PyAny>,
        radius: f64,
    ) -> PyResult<Bound<'py, PyArray1<bool>>> {
        check_radius(radius)?;
        let p = points(&f64_2d(pts, "(N, 3)", "pts")?, "pts")?;
        let c: Vec<bool> =
            py.detach(|| p.iter().map(|q| self.0.point_is_clear(q, radius)).collect());
        Ok(PyArray1::from_vec(py, c))
    }

    /// Whether each segment a[i]-b[i] keeps `radius` from the mesh, (N,) bool.
    fn segments_clear<'py>(
        &self,
        py: Python<'py>,
        a: &Bound<'_, PyAny>,
        b: &Bound<'_, PyAny>,
        radius: f64,
    ) -> PyResult<Bound<'py, PyArray1<bool>>> {
        check_radius(radius)?;
        let (a, b) = (
            points(&f64_2d(a, "(N, 3)", "a")?, "a")?,
            points(&f64_2d(b, "(N, 3)", "b")?, "b")?,
        );
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
