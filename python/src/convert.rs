//! Conversions between Python values and the library's: JSON through Python's `json` module,
//! images through NumPy arrays, errors into `SynthcamError` with their cause chain.

use numpy::ndarray::{Array2, Array3};
use numpy::{IntoPyArray, PyReadonlyArray2, PyUntypedArrayMethods};
use pyo3::prelude::*;
use pyo3::types::PyString;
use synthcam::detect::ImageU8;
use synthcam::render::GreyImage;

use crate::SynthcamError;

/// An error and its `source()` chain, one line: "a: b: c".
pub fn chain(e: &dyn std::error::Error) -> String {
    let mut text = e.to_string();
    let mut cause = e.source();
    while let Some(c) = cause {
        let s = c.to_string();
        if !text.contains(&s) {
            text = format!("{text}: {s}");
        }
        cause = c.source();
    }
    text
}

/// `SynthcamError(message)`.
pub fn err(message: impl Into<String>) -> PyErr {
    SynthcamError::new_err(message.into())
}

/// A library error as `SynthcamError` with its chain, prefixed by what was being done.
pub fn lib_err(what: &str, e: &dyn std::error::Error) -> PyErr {
    err(format!("{what}: {}", chain(e)))
}

/// JSON text as Python objects (`json.loads`).
pub fn json_to_py<'py>(py: Python<'py>, text: &str) -> PyResult<Bound<'py, PyAny>> {
    py.import("json")?.call_method1("loads", (text,))
}

/// A serialisable value as Python objects.
pub fn to_py<'py, T: serde::Serialize>(py: Python<'py>, value: &T) -> PyResult<Bound<'py, PyAny>> {
    let text = serde_json::to_string(value).map_err(|e| err(format!("cannot serialise: {e}")))?;
    json_to_py(py, &text)
}

/// Text given as a `str` (TOML or JSON) or a dict (serialised with `json.dumps`).
pub fn text_or_json(value: &Bound<'_, PyAny>, what: &str) -> PyResult<String> {
    if value.is_instance_of::<PyString>() {
        return value.extract();
    }
    if value.is_instance_of::<pyo3::types::PyDict>() {
        return value.py().import("json")?.call_method1("dumps", (value,))?.extract();
    }
    Err(pyo3::exceptions::PyTypeError::new_err(format!("{what} must be TOML/JSON text (str) or a dict, not {}", value.get_type().name()?)))
}

/// A rendered image as a NumPy array: (H, W) uint8 or uint16, (H, W, 3) for RGB.
pub fn image_to_py<'py>(py: Python<'py>, img: GreyImage) -> PyResult<Bound<'py, PyAny>> {
    let (w, h) = img.dimensions();
    let (w, h) = (w as usize, h as usize);
    let shape_err = |e: numpy::ndarray::ShapeError| err(format!("image buffer: {e}"));
    Ok(match img {
        GreyImage::U8(i) => Array2::from_shape_vec((h, w), i.into_raw()).map_err(shape_err)?.into_pyarray(py).into_any(),
        GreyImage::U16(i) => Array2::from_shape_vec((h, w), i.into_raw()).map_err(shape_err)?.into_pyarray(py).into_any(),
        GreyImage::Rgb8(i) => Array3::from_shape_vec((h, w, 3), i.into_raw()).map_err(shape_err)?.into_pyarray(py).into_any(),
        GreyImage::Rgb16(i) => Array3::from_shape_vec((h, w, 3), i.into_raw()).map_err(shape_err)?.into_pyarray(py).into_any(),
    })
}

/// A (H, W) NumPy array as the detector's 8-bit image: uint8 as is; uint16 divided by 257;
/// float arrays (0..255) rounded and clamped. Other shapes or dtypes are a `TypeError`.
pub fn image_from_py(image: &Bound<'_, PyAny>) -> PyResult<ImageU8> {
    let np = image.py().import("numpy")?;
    let ndim: usize = image.getattr("ndim")?.extract()?;
    if ndim != 2 {
        return Err(pyo3::exceptions::PyTypeError::new_err(format!("image must be a 2-D (H, W) grey array, got {ndim} dimensions")));
    }
    let kind: String = image.getattr("dtype")?.getattr("kind")?.extract()?;
    let item: usize = image.getattr("dtype")?.getattr("itemsize")?.extract()?;
    let as_u8 = match (kind.as_str(), item) {
        ("u", 1) => image.clone(),
        ("u", 2) => np.call_method1("rint", (image.call_method1("__truediv__", (257.0,))?,))?.call_method1("astype", ("uint8",))?,
        ("f", _) => np.call_method1("clip", (np.call_method1("rint", (image,))?, 0, 255))?.call_method1("astype", ("uint8",))?,
        _ => return Err(pyo3::exceptions::PyTypeError::new_err(format!("image dtype must be uint8, uint16 or float, got kind {kind:?} size {item}"))),
    };
    let arr: PyReadonlyArray2<'_, u8> = np.call_method1("ascontiguousarray", (as_u8,))?.extract()?;
    let (h, w) = (arr.shape()[0], arr.shape()[1]);
    let data = arr.as_slice().map_err(|e| err(format!("image buffer: {e}")))?.to_vec();
    ImageU8::new(w, h, data).map_err(|e| lib_err("image", &e))
}

/// An (N, 2) float64 array of points.
pub fn points_to_py<'py>(py: Python<'py>, points: impl Iterator<Item = [f64; 2]>) -> PyResult<Bound<'py, PyAny>> {
    let flat: Vec<f64> = points.flatten().collect();
    let n = flat.len() / 2;
    Ok(Array2::from_shape_vec((n, 2), flat).map_err(|e| err(format!("points: {e}")))?.into_pyarray(py).into_any())
}

/// An (N, 2) float64 array of points, NaN where a point is `None` (not visible).
pub fn optional_points_to_py<'py>(py: Python<'py>, points: &[Option<nalgebra::Point2<f64>>]) -> PyResult<Bound<'py, PyAny>> {
    points_to_py(py, points.iter().map(|p| p.map_or([f64::NAN; 2], |p| [p.x, p.y])))
}

/// A 4 x 4 homogeneous matrix of an isometry, row-major nested lists.
pub fn isometry_rows(iso: &nalgebra::Isometry3<f64>) -> [[f64; 4]; 4] {
    let m = iso.to_homogeneous();
    std::array::from_fn(|r| std::array::from_fn(|c| m[(r, c)]))
}
