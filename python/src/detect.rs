//! `detect(image, target, camera=None)`.

use pyo3::prelude::*;
use pyo3::types::{PyDict, PyString};
use synthcam::camera::CameraModel;
use synthcam::detect::target::{detect_u8_with_camera, TargetSpec};
use synthcam::scene::file::{parse_scene, CameraSpec};

use crate::convert::{chain, err, image_from_py, points_to_py, text_or_json};

/// What to detect: a target description such as "chessboard:9x6" or
/// "charuco:11x8:DICT_5X5_100:0.733" (`synthcam detect --help`), or a scene (text or dict)
/// whose target is meant.
pub fn target_spec(target: &Bound<'_, PyAny>) -> PyResult<TargetSpec> {
    if target.is_instance_of::<PyString>() {
        let s: String = target.extract()?;
        if let Ok(spec) = s.parse::<TargetSpec>() {
            return Ok(spec);
        }
        if !s.contains('=') && !s.trim_start().starts_with('{') {
            return Err(pyo3::exceptions::PyValueError::new_err(s.parse::<TargetSpec>().err().unwrap_or_default()));
        }
    }
    let text = text_or_json(target, "target")?;
    let scene = parse_scene(&text).map_err(|e| err(format!("target given as a scene: {}", chain(&e))))?;
    Ok(TargetSpec::for_target(&scene.target))
}

/// A camera given as a camera file's text (OpenCV, ROS, Kalibr or mrcal, as `calibrate` writes
/// them) or as the scene-file camera (a dict, e.g. `calibrate(...)["camera"]`, or its JSON text).
pub fn camera_from_py(value: &Bound<'_, PyAny>) -> PyResult<CameraModel> {
    let text = text_or_json(value, "camera")?;
    if let Ok(camera) = synthcam::camera::formats::read(&text) {
        return Ok(camera);
    }
    let spec: CameraSpec = serde_json::from_str(&text).map_err(|e| err(format!("camera: neither a camera file nor a scene-file camera ({e})")))?;
    spec.to_model().map_err(|e| err(format!("camera: {}", chain(&e))))
}

/// Detect a target's points in a grey image.
///
/// `image`: a (H, W) NumPy array, uint8 (uint16 is divided by 257, floats are rounded).
/// `target`: a description such as "chessboard:9x6" (inner corners), "dot-grid:3x3", "s-path",
/// "charuco:11x8:DICT_5X5_100:0.733", "aprilgrid:6x6:tag36h11:0.3", or a scene (TOML/JSON text or
/// dict) whose target is meant.
/// `camera` (optional): the camera that took the image, as [`camera_from_py`] reads it. The
/// S-path's dots are then placed by the camera's pose, which tells apart shifts of the path
/// along itself where dots stray from their nominal points; other targets do not use it.
///
/// Returns a dict: `found` (bool), `points_px` ((N, 2) float64, OpenCV's pixel convention: the
/// centre of the top-left pixel is (0, 0)), `ids` (coded boards: each point's id, else None),
/// `indices` (S-path: each dot's path index, else None), `untrusted` (chessboards: indices of the
/// points the sub-pixel fit cannot place within 0.1 px), `position_sigma_px` (chessboards: each
/// point's standard deviation from its fit, None where it failed; `calibrate` leaves out the
/// untrusted points that failed or are outliers in their view), `note` (why
/// nothing was found). The GIL
/// is released while detecting.
#[pyfunction]
#[pyo3(signature = (image, target, camera=None))]
pub fn detect<'py>(py: Python<'py>, image: &Bound<'py, PyAny>, target: &Bound<'py, PyAny>, camera: Option<&Bound<'py, PyAny>>) -> PyResult<Bound<'py, PyDict>> {
    let spec = target_spec(target)?;
    let img = image_from_py(image)?;
    let camera = camera.map(camera_from_py).transpose()?;
    let det = py.detach(move || detect_u8_with_camera(&img, &spec, camera.as_ref())).map_err(|e| err(format!("detecting: {}", chain(&e))))?;
    let out = PyDict::new(py);
    out.set_item("found", det.found)?;
    out.set_item("points_px", points_to_py(py, det.points_px.iter().map(|p| [p.x, p.y]))?)?;
    out.set_item("ids", det.ids)?;
    out.set_item("indices", det.indices)?;
    out.set_item("untrusted", det.untrusted)?;
    out.set_item("position_sigma_px", det.position_sigma_px.map(|v| v.into_iter().map(|s| s.is_finite().then_some(s)).collect::<Vec<_>>()))?;
    out.set_item("note", det.note)?;
    Ok(out)
}
