//! numpy and Python values to and from the crates' types. Shape and range
//! checks only: every check raises `ValueError` naming the argument.

use nalgebra::{Matrix4, Point3, Rotation3, Translation3, UnitQuaternion};
use numpy::ndarray::{Array2, Array3};
use numpy::{IntoPyArray, PyArray2, PyArray3, PyReadonlyArray, PyReadonlyArray2, PyReadonlyArray3};
use pyo3::prelude::*;
use pyo3::types::PyAnyMethods;
use serde::de::DeserializeOwned;
use serde::Serialize;
use vp_scene::plan::{GeodeticOrigin, VerticalDatum};
use vp_scene::raster::{Label, LabelImage, RgbImage};

use crate::errors::{type_error, value_error, IntoPy};

/// Any array-like (a numpy array of any numeric dtype or layout, a list,
/// a tuple) as a C-contiguous numpy array of `dtype` of `shape`: the one
/// conversion at the boundary, as numpy-based libraries do. `shape` is
/// written as the docs write it, "(N, 3)", "(H, W, 3)", "(N,)": a number
/// must match, a name is any size. `kinds` are the numpy dtype kinds
/// accepted without loss of meaning ("iu" for indices: a float array of
/// indices is refused, not truncated; "iuf" for coordinates; "b" for
/// flags). Errors name the argument, the expected shape and dtype:
/// TypeError for what is not such numbers, ValueError for a wrong shape.
pub fn array_like<'py>(
    obj: &Bound<'py, PyAny>,
    dtype: &str,
    kinds: &str,
    shape: &str,
    what: &str,
) -> PyResult<Bound<'py, PyAny>> {
    let a = checked(obj, kinds, shape, what, &expected(dtype, kinds, shape))?;
    obj.py()
        .import("numpy")?
        .call_method1("ascontiguousarray", (a, dtype))
}

/// `obj` as a numpy array of `kinds` and `shape`, not converted; errors
/// say what was `expected`.
fn checked<'py>(
    obj: &Bound<'py, PyAny>,
    kinds: &str,
    shape: &str,
    what: &str,
    expected: &str,
) -> PyResult<Bound<'py, PyAny>> {
    let a = obj
        .py()
        .import("numpy")?
        .call_method1("asarray", (obj,))
        .map_err(|e| type_error(format!("{what}: expected {expected}: {e}")))?;
    let kind: String = a.getattr("dtype")?.getattr("kind")?.extract()?;
    let got: Vec<usize> = a.getattr("shape")?.extract()?;
    // An empty list has dtype float64 whatever is meant: let it through.
    let empty = got.contains(&0);
    if !empty && !kinds.contains(kind.as_str()) {
        let dt: String = a.getattr("dtype")?.str()?.extract()?;
        return Err(type_error(format!(
            "{what}: expected {expected}, got dtype {dt}"
        )));
    }
    let dims = dims(shape);
    let fits = got.len() == dims.len()
        && got
            .iter()
            .zip(&dims)
            .all(|(&n, d)| d.parse::<usize>().map_or(true, |want| want == n));
    if !fits {
        return Err(value_error(format!(
            "{what}: expected {expected}, got shape {}",
            tuple(&got)
        )));
    }
    Ok(a)
}

/// "an (N, 3) array of real numbers (float64)".
fn expected(dtype: &str, kinds: &str, shape: &str) -> String {
    let numbers = match kinds {
        "b" => "booleans",
        k if k.contains('f') => "real numbers",
        _ => "integers",
    };
    let article = if shape.starts_with("(N") || shape.starts_with("(M") {
        "an"
    } else {
        "a"
    };
    format!("{article} {shape} array of {numbers} ({dtype})")
}

/// The dimensions of `(N, 3)`: `N` and `3`.
fn dims(shape: &str) -> Vec<&str> {
    shape
        .trim_matches(|c| c == '(' || c == ')')
        .split(',')
        .map(str::trim)
        .filter(|d| !d.is_empty())
        .collect()
}

/// A shape as Python writes it: (3,), (2, 3).
fn tuple(shape: &[usize]) -> String {
    match shape {
        [n] => format!("({n},)"),
        _ => format!(
            "({})",
            shape
                .iter()
                .map(ToString::to_string)
                .collect::<Vec<_>>()
                .join(", ")
        ),
    }
}

/// [`array_like`] as an (N, C) float64 array; `shape` as "(N, 3)".
pub fn f64_2d<'py>(
    obj: &Bound<'py, PyAny>,
    shape: &str,
    what: &str,
) -> PyResult<PyReadonlyArray2<'py, f64>> {
    array_like(obj, "float64", "iuf", shape, what)?.extract()
}

/// [`array_like`] as a real array of `T` (float64 or float32) of `shape`.
pub fn reals<'py, T: numpy::Element, D: numpy::ndarray::Dimension>(
    obj: &Bound<'py, PyAny>,
    shape: &str,
    what: &str,
) -> PyResult<PyReadonlyArray<'py, T, D>> {
    let dtype: String = T::get_dtype(obj.py()).getattr("name")?.extract()?;
    array_like(obj, &dtype, "iuf", shape, what)?.extract()
}

/// [`array_like`] as a bool array of `shape` (numpy bools only: 2 is not a flag).
pub fn bools<'py, D: numpy::ndarray::Dimension>(
    obj: &Bound<'py, PyAny>,
    shape: &str,
    what: &str,
) -> PyResult<PyReadonlyArray<'py, bool, D>> {
    array_like(obj, "bool", "b", shape, what)?.extract()
}

/// An 8-bit array of `shape` from any integer or real array-like: integers
/// must be in 0..=255; reals in [0, 1] are scaled by 255 and rounded, as
/// scikit-image's `img_as_ubyte` does (a float image is in [0, 1] in the
/// numpy imaging libraries). `integers_only`: label codes, where a real
/// number is refused.
pub fn u8_array<'py, D: numpy::ndarray::Dimension>(
    obj: &Bound<'py, PyAny>,
    shape: &str,
    integers_only: bool,
    what: &str,
) -> PyResult<PyReadonlyArray<'py, u8, D>> {
    let (kinds, expected) = if integers_only {
        (
            "iu",
            format!("a {shape} array of integers in 0..=255 (uint8)"),
        )
    } else {
        (
            "iuf",
            format!("a {shape} image of integers in 0..=255 or reals in [0, 1] (uint8)"),
        )
    };
    let a = checked(obj, kinds, shape, what, &expected)?;
    let np = obj.py().import("numpy")?;
    let real = a.getattr("dtype")?.getattr("kind")?.extract::<String>()? == "f";
    let size: usize = a.getattr("size")?.extract()?;
    if size > 0 {
        let (lo, hi): (f64, f64) = (
            a.call_method0("min")?.extract()?,
            a.call_method0("max")?.extract()?,
        );
        let top = if real { 1.0 } else { 255.0 };
        if !(lo >= 0.0 && hi <= top) {
            return Err(value_error(format!(
                "{what}: expected {expected}: values from {lo} to {hi}{}",
                if real {
                    " (reals are scaled by 255: pass integers for 0-255)"
                } else {
                    ""
                }
            )));
        }
    }
    let a = if real {
        np.call_method1("rint", (a.call_method1("__mul__", (255.0,))?,))?
    } else {
        a
    };
    np.call_method1("ascontiguousarray", (a, "uint8"))?
        .extract()
}

/// An (N, 3) float array as points; `what` names the argument in errors.
pub fn points(a: &PyReadonlyArray2<'_, f64>, what: &str) -> PyResult<Vec<Point3<f64>>> {
    let v = a.as_array();
    if v.ncols() != 3 {
        return Err(value_error(format!(
            "{what}: expected an (N, 3) array, got shape {:?}",
            v.shape()
        )));
    }
    let pts: Vec<Point3<f64>> = v
        .rows()
        .into_iter()
        .map(|r| Point3::new(r[0], r[1], r[2]))
        .collect();
    if let Some(i) = pts.iter().position(|p| !p.iter().all(|c| c.is_finite())) {
        return Err(value_error(format!("{what}: row {i} is not finite")));
    }
    Ok(pts)
}

/// Points as an (N, 3) float64 array.
pub fn points_array<'py>(py: Python<'py>, pts: &[Point3<f64>]) -> Bound<'py, PyArray2<f64>> {
    let flat: Vec<f64> = pts.iter().flat_map(|p| [p.x, p.y, p.z]).collect();
    Array2::from_shape_vec((pts.len(), 3), flat)
        .unwrap_or_else(|_| Array2::zeros((0, 3)))
        .into_pyarray(py)
}

/// Two arrays returned together (e.g. labels and angles).
pub type ArrayPair<'py, A, B> = (Bound<'py, A>, Bound<'py, B>);

/// An (H, W) array from row-major data.
pub fn image2<T: numpy::Element>(
    py: Python<'_>,
    width: u32,
    height: u32,
    data: Vec<T>,
) -> PyResult<Bound<'_, PyArray2<T>>> {
    Array2::from_shape_vec((height as usize, width as usize), data)
        .map(|a| a.into_pyarray(py))
        .map_err(|e| value_error(format!("image of {width}x{height}: {e}")))
}

/// An (H, W, C) array from row-major, channel-innermost data.
pub fn image3<T: numpy::Element>(
    py: Python<'_>,
    shape: (usize, usize, usize),
    data: Vec<T>,
) -> PyResult<Bound<'_, PyArray3<T>>> {
    Array3::from_shape_vec(shape, data)
        .map(|a| a.into_pyarray(py))
        .map_err(|e| value_error(format!("array of shape {shape:?}: {e}")))
}

/// An (H, W, 3) uint8 array as an RGB image.
pub fn rgb(a: &PyReadonlyArray3<'_, u8>, what: &str) -> PyResult<RgbImage> {
    let v = a.as_array();
    let (h, w, c) = v.dim();
    if c != 3 || h == 0 || w == 0 {
        return Err(value_error(format!(
            "{what}: expected an (H, W, 3) uint8 array, got shape {:?}",
            v.shape()
        )));
    }
    let raw: Vec<u8> = v.iter().copied().collect();
    RgbImage::from_raw(w as u32, h as u32, raw)
        .ok_or_else(|| value_error(format!("{what}: {w}x{h} image does not fit its data")))
}

/// An (H, W, 3) image array-like ([`u8_array`]) as an RGB image.
pub fn rgb_like(obj: &Bound<'_, PyAny>, what: &str) -> PyResult<RgbImage> {
    rgb(&u8_array(obj, "(H, W, 3)", false, what)?, what)
}

/// Label codes (H, W) and angles (H, W) array-likes as a label image;
/// `what` names the label argument, `angles_what` the angles.
pub fn label_image_like(
    labels: &Bound<'_, PyAny>,
    angles: &Bound<'_, PyAny>,
    what: &str,
    angles_what: &str,
) -> PyResult<LabelImage> {
    let l = u8_array(labels, "(H, W)", true, what)?;
    let a = reals(angles, "(H, W)", angles_what)?;
    label_image(&l, &a, what)
}

/// An RGB image as an (H, W, 3) uint8 array.
pub fn rgb_array<'py>(py: Python<'py>, img: &RgbImage) -> PyResult<Bound<'py, PyArray3<u8>>> {
    image3(
        py,
        (img.height() as usize, img.width() as usize, 3),
        img.as_raw().clone(),
    )
}

/// Labels (H, W) uint8 (0 unlabelled, 1 positive, 2 negative, as in
/// `.vplabel` files) and angles (H, W) float32 in degrees as a label image.
pub fn label_image(
    labels: &PyReadonlyArray2<'_, u8>,
    angles: &PyReadonlyArray2<'_, f32>,
    what: &str,
) -> PyResult<LabelImage> {
    let (l, a) = (labels.as_array(), angles.as_array());
    if l.dim() != a.dim() {
        return Err(value_error(format!(
            "{what}: labels {:?} and angles {:?} differ in shape",
            l.shape(),
            a.shape()
        )));
    }
    let (h, w) = l.dim();
    let mut img = LabelImage::new(w as u32, h as u32);
    for ((y, x), &code) in l.indexed_iter() {
        let label = match code {
            0 => Label::Unlabelled,
            1 => Label::Positive,
            2 => Label::Negative,
            other => {
                return Err(value_error(format!(
                    "{what}: label {other} at pixel ({x}, {y}); expected 0 (unlabelled), 1 (positive) or 2 (negative)"
                )))
            }
        };
        img.set(x as u32, y as u32, label, a[[y, x]])
            .map_err(|e| value_error(format!("{what}: {e}")))?;
    }
    Ok(img)
}

/// A label image as (labels uint8, angles float32) arrays.
pub fn label_arrays<'py>(
    py: Python<'py>,
    img: &LabelImage,
) -> PyResult<ArrayPair<'py, PyArray2<u8>, PyArray2<f32>>> {
    let (w, h) = (img.width(), img.height());
    let mut labels = Vec::with_capacity((w * h) as usize);
    let mut angles = Vec::with_capacity((w * h) as usize);
    for y in 0..h {
        for x in 0..w {
            labels.push(img.label(x, y) as u8);
            angles.push(img.angle(x, y));
        }
    }
    Ok((image2(py, w, h, labels)?, image2(py, w, h, angles)?))
}

/// A 4x4 rigid transform (row-major nested sequence or array) as an isometry.
pub fn isometry(m: &PyReadonlyArray2<'_, f64>, what: &str) -> PyResult<nalgebra::Isometry3<f64>> {
    let v = m.as_array();
    if v.dim() != (4, 4) {
        return Err(value_error(format!(
            "{what}: expected a 4x4 matrix, got shape {:?}",
            v.shape()
        )));
    }
    let m4 = Matrix4::from_fn(|r, c| v[[r, c]]);
    let rot = m4.fixed_view::<3, 3>(0, 0).into_owned();
    let ortho = (rot.transpose() * rot - nalgebra::Matrix3::identity()).norm();
    if !m4.iter().all(|x| x.is_finite()) || ortho > 1e-6 || rot.determinant() < 0.0 {
        return Err(value_error(format!(
            "{what}: the upper-left 3x3 block is not a rotation"
        )));
    }
    let t = m4.fixed_view::<3, 1>(0, 3).into_owned();
    Ok(nalgebra::Isometry3::from_parts(
        Translation3::from(t),
        UnitQuaternion::from_rotation_matrix(&Rotation3::from_matrix_unchecked(rot)),
    ))
}

/// An isometry as a 4x4 float64 array.
pub fn matrix_array<'py>(
    py: Python<'py>,
    iso: &nalgebra::Isometry3<f64>,
) -> PyResult<Bound<'py, PyArray2<f64>>> {
    let m = iso.to_homogeneous();
    let flat: Vec<f64> = (0..4)
        .flat_map(|r| (0..4).map(move |c| (r, c)))
        .map(|(r, c)| m[(r, c)])
        .collect();
    image2(py, 4, 4, flat)
}

/// A Python object (dict, list, ...) through JSON into a serde type.
/// `None` gives the type's default.
pub fn from_py<T: DeserializeOwned + Default>(
    obj: Option<&Bound<'_, PyAny>>,
    what: &str,
) -> PyResult<T> {
    let Some(obj) = obj.filter(|o| !o.is_none()) else {
        return Ok(T::default());
    };
    from_py_required(obj, what)
}

/// [`from_py`] for types whose serde form fills missing fields with
/// defaults but would silently ignore unknown ones: a key that the type's
/// default does not serialise is a `ValueError` naming it.
pub fn from_py_strict<T: DeserializeOwned + Serialize + Default>(
    obj: Option<&Bound<'_, PyAny>>,
    what: &str,
) -> PyResult<T> {
    if let Some(dict) = obj.and_then(|o| o.cast::<pyo3::types::PyDict>().ok()) {
        let known =
            serde_json::to_value(T::default()).map_err(|e| value_error(format!("{what}: {e}")))?;
        for key in dict.keys() {
            let k: String = key.extract()?;
            if known.get(&k).is_none() {
                let mut names: Vec<&String> = known
                    .as_object()
                    .map(|o| o.keys().collect())
                    .unwrap_or_default();
                names.sort();
                return Err(value_error(format!(
                    "{what}: unknown parameter {k:?} (known: {})",
                    names
                        .iter()
                        .map(|s| s.as_str())
                        .collect::<Vec<_>>()
                        .join(", ")
                )));
            }
        }
    }
    from_py(obj, what)
}

/// A Python object through JSON into a serde type.
pub fn from_py_required<T: DeserializeOwned>(obj: &Bound<'_, PyAny>, what: &str) -> PyResult<T> {
    let json = obj.py().import("json")?;
    let text: String = json
        .call_method1("dumps", (obj,))
        .map_err(|e| value_error(format!("{what}: not JSON-serialisable: {e}")))?
        .extract()?;
    serde_json::from_str(&text).map_err(|e| value_error(format!("{what}: {e}")))
}

/// A serde value as Python objects (through JSON: dicts, lists, numbers).
pub fn to_py<'py, T: Serialize>(py: Python<'py>, value: &T) -> PyResult<Bound<'py, PyAny>> {
    let text =
        serde_json::to_string(value).map_err(|e| value_error(format!("not serialisable: {e}")))?;
    py.import("json")?.call_method1("loads", (text,))
}

/// `home=(lat, lon, alt)` or `(lat, lon, alt, "egm96" | "ellipsoid" | "takeoff")`;
/// any other shape is a `ValueError` "home: expected {expected}" (the
/// planner's `home=` also takes "first_image" and says so).
pub(crate) fn home_of(
    home: Option<&Bound<'_, PyAny>>,
    expected: &str,
) -> PyResult<Option<(GeodeticOrigin, Option<VerticalDatum>)>> {
    let Some(home) = home.filter(|h| !h.is_none()) else {
        return Ok(None);
    };
    let (lat, lon, alt, datum) = if let Ok((lat, lon, alt)) = home.extract::<(f64, f64, f64)>() {
        (lat, lon, alt, None)
    } else {
        let (lat, lon, alt, d) = home
            .extract::<(f64, f64, f64, String)>()
            .map_err(|_| value_error(format!("home: expected {expected}")))?;
        (lat, lon, alt, Some(d.parse::<VerticalDatum>().py()?))
    };
    Ok(Some((GeodeticOrigin::new(lat, lon, alt).py()?, datum)))
}
