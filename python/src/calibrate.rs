//! `calibrate(detections, target, square_m, image_size, ...)` and `calibrate_rig(cameras, ...)`.

use nalgebra::Point2;
use pyo3::prelude::*;
use synthcam::calib::{
    calibrate as calibrate_views, calibrate_rig as calibrate_rig_views, rectified_row_errors, views_from_detections, BoardViews, CalibModel, CalibParams,
    CalibResult, RigCamera,
};
use synthcam::camera::{intrinsic_names, ImageSize};
use synthcam::detect::target::Detection;
use synthcam::scene::file::CameraSpec;

use crate::convert::{chain, err, to_py};
use crate::detect::target_spec;

/// A detection dict (as `detect` returns it) as the library's detection: `points_px`, `ids`
/// (coded boards), `position_sigma_px` and `untrusted` (chessboards); `found` defaults to true.
fn detection_from(det: &Bound<'_, PyAny>) -> PyResult<Detection> {
    if !det.get_item("found").and_then(|f| f.extract::<bool>()).unwrap_or(true) {
        return Ok(Detection::default());
    }
    let optional = |key: &str| det.get_item(key).ok().filter(|v| !v.is_none());
    let pts: Vec<[f64; 2]> = det.py().import("numpy")?.call_method1("asarray", (det.get_item("points_px")?, "float64"))?.call_method0("tolist")?.extract()?;
    let ids: Option<Vec<u32>> = optional("ids").map(|v| v.extract()).transpose()?;
    let untrusted: Vec<usize> = optional("untrusted").map(|v| v.extract()).transpose()?.unwrap_or_default();
    let sigma: Option<Vec<Option<f64>>> = optional("position_sigma_px").map(|v| v.extract()).transpose()?;
    Ok(Detection {
        found: true,
        points_px: pts.into_iter().map(|p| Point2::new(p[0], p[1])).collect(),
        ids,
        position_sigma_px: sigma.map(|s| s.into_iter().map(|s| s.unwrap_or(f64::INFINITY)).collect()),
        untrusted,
        ..Default::default()
    })
}

#[derive(serde::Serialize)]
struct ViewOut {
    outliers: Vec<usize>,
    rms_px: f64,
    max_px: f64,
    rvec: [f64; 3],
    tvec: [f64; 3],
}

#[derive(serde::Serialize)]
struct Output {
    rms_px: f64,
    model: &'static str,
    #[serde(rename = "K")]
    k: [[f64; 3]; 3],
    dist: Vec<f64>,
    camera: CameraSpec,
    std: serde_json::Map<String, serde_json::Value>,
    views: Vec<ViewOut>,
    /// Index into the detections of each view used (detections not found are skipped).
    used: Vec<usize>,
    iterations: usize,
    converged: bool,
    /// Intrinsics the data do not determine (their `std` is left out: infinite).
    undetermined: Vec<String>,
    /// Points dropped as outliers over all views, and the RMS with every point.
    outliers_dropped: usize,
    rms_before_rejection_px: f64,
    /// Worst projection sigma inside and outside the area the views cover, px (at infinity).
    uncertainty_inside_px: f64,
    uncertainty_outside_px: f64,
}

fn output(r: &CalibResult, model: CalibModel, used: Vec<usize>, views: &[synthcam::calib::View], point_indices: &[Vec<usize>]) -> Output {
    let map = r.uncertainty_map(views, 16, 12, None);
    let c = &r.camera;
    let k = c.intrinsics;
    let std = intrinsic_names(c.lens.kind()).iter().zip(r.std).filter(|(_, v)| v.is_finite()).map(|(n, v)| ((*n).to_string(), serde_json::json!(v))).collect();
    let view_out = r
        .views
        .iter()
        .zip(point_indices)
        .map(|(v, idx)| ViewOut {
            outliers: v.outliers.iter().filter_map(|&j| idx.get(j).copied()).collect(),
            rms_px: v.rms_px,
            max_px: v.max_px,
            rvec: v.rvec.into(),
            tvec: v.tvec.into(),
        })
        .collect();
    Output {
        rms_px: r.rms_px,
        model: model.name(),
        k: [[k.fx, k.skew, k.cx], [0.0, k.fy, k.cy], [0.0, 0.0, 1.0]],
        dist: c.lens.params()[..model.n_lens_params()].to_vec(),
        camera: CameraSpec::from_model(c),
        std,
        views: view_out,
        used,
        iterations: r.iterations,
        converged: r.converged,
        undetermined: r.undetermined.iter().filter_map(|&i| intrinsic_names(c.lens.kind()).get(i).map(|n| (*n).to_string())).collect(),
        outliers_dropped: r.rejection.dropped,
        rms_before_rejection_px: r.rejection.rms_before_px,
        uncertainty_inside_px: map.worst_inside_px,
        uncertainty_outside_px: map.worst_outside_px,
    }
}

/// The calls' common arguments checked: a positive `square_m`, a known model, a board target.
fn checked_args(square_m: f64, model: &str, target: &Bound<'_, PyAny>) -> PyResult<(CalibModel, synthcam::detect::target::TargetSpec)> {
    if !(square_m > 0.0 && square_m.is_finite()) {
        return Err(pyo3::exceptions::PyValueError::new_err(format!("square_m must be a positive length in metres, got {square_m}")));
    }
    let model: CalibModel = model.parse().map_err(|e: String| pyo3::exceptions::PyValueError::new_err(e))?;
    let spec = target_spec(target)?;
    if spec.board_points_m(square_m).is_none() {
        return Err(pyo3::exceptions::PyValueError::new_err("calibration takes a chessboard, ChArUco or AprilGrid target"));
    }
    Ok((model, spec))
}

/// Calibrate a camera from detections of a planar board (Zhang's closed form, then
/// Levenberg-Marquardt over every view, as OpenCV's `calibrateCamera`).
///
/// `detections`: dicts as `detect` returns them (`points_px`, and `ids` for coded boards;
/// `found: False` ones, and views left with fewer than 8 trusted points, are skipped; `used`
/// lists the ones calibrated from). Poses are of the target's frame: its origin at the board's
/// outer corner, a chessboard's first inner corner at (square_m, square_m, 0). `target`: the board ("chessboard:9x6", ChArUco, AprilGrid;
/// see `detect`). `square_m`: square edge (AprilGrid: tag edge), metres. `image_size`: (width,
/// height). `model`: "opencv5" (k1 k2 p1 p2 k3; also opencv4, opencv8, opencv12, opencv14,
/// "fisheye" (Kannala-Brandt), "ds" (Double Sphere)).
///
/// Returns a dict: `rms_px`, `K` (3 x 3), `dist` (the lens parameters: OpenCV's coefficients in OpenCV's order; fisheye k1..k4; Double
/// Sphere xi, alpha),
/// `camera` (the scene-file camera, usable in a scene dict), `std` (standard deviation of each
/// estimated intrinsic), `views` (per view `outliers` (indices into its detection's `points_px`
/// dropped),
/// `rms_px`, `max_px`, `rvec`, `tvec` in metres: `cam_from_target`), `used`, `iterations`,
/// `converged`, `outliers_dropped`, `rms_before_rejection_px`, `uncertainty_inside_px` and
/// `uncertainty_outside_px` (worst projection sigma inside / outside the area the views cover).
/// `outlier_threshold`: drop points beyond this many robust sigmas and refit (None: keep all,
/// as OpenCV). The GIL is released while solving.
// The arguments are the Python function's keyword arguments (pyo3 maps them one to one); the
// literal 5.0 is `calib::DEFAULT_OUTLIER_THRESHOLD` (a literal, so the text signature shows it).
#[allow(clippy::too_many_arguments)]
#[pyfunction]
#[pyo3(signature = (detections, target, square_m, image_size, model="opencv5", estimate_skew=false, outlier_threshold=Some(5.0)), text_signature = "(detections, target, square_m, image_size, model='opencv5', estimate_skew=False, outlier_threshold=5.0)")]
pub fn calibrate<'py>(
    py: Python<'py>,
    detections: Vec<Bound<'py, PyAny>>,
    target: &Bound<'py, PyAny>,
    square_m: f64,
    image_size: (u32, u32),
    model: &str,
    estimate_skew: bool,
    outlier_threshold: Option<f64>,
) -> PyResult<Bound<'py, PyAny>> {
    let (model, spec) = checked_args(square_m, model, target)?;
    let dets = detections.iter().map(detection_from).collect::<PyResult<Vec<Detection>>>()?;
    let BoardViews { views, used, point_indices, .. } = views_from_detections(&dets, &spec, square_m).map_err(|e| err(chain(&e)))?;
    let size = ImageSize { width: image_size.0, height: image_size.1 };
    let params = CalibParams { estimate_skew, model, outlier_threshold, ..CalibParams::default() };
    let (r, views) = py.detach(move || calibrate_views(&views, size, &params).map(|r| (r, views))).map_err(|e| err(format!("calibrating: {}", chain(&e))))?;
    to_py(py, &output(&r, model, used, &views, &point_indices))
}

#[derive(serde::Serialize)]
struct PoseOut {
    #[serde(rename = "R")]
    r: [[f64; 3]; 3],
    t_m: [f64; 3],
}

#[derive(serde::Serialize)]
struct RigCameraOut {
    name: String,
    model: &'static str,
    #[serde(rename = "K")]
    k: [[f64; 3]; 3],
    dist: Vec<f64>,
    camera: CameraSpec,
    cam0_from_cam: PoseOut,
    rotation_std_deg: [f64; 3],
    translation_std_m: [f64; 3],
    rms_px: f64,
    views: usize,
}

#[derive(serde::Serialize)]
struct RigOutput {
    rms_px: f64,
    cameras: Vec<RigCameraOut>,
    iterations: usize,
    rectified_row_error_mean_px: Option<f64>,
    rectified_row_error_max_px: Option<f64>,
}

/// One camera of `calibrate_rig`'s input: `name`, `image_size` (width, height), `detections`
/// (one per frame, `None` or `found: False` where it did not see the board) and an optional
/// `model`.
fn rig_camera(cam: &Bound<'_, PyAny>, spec: &synthcam::detect::target::TargetSpec, square_m: f64, params: &CalibParams) -> PyResult<RigCamera> {
    let name: String = cam.get_item("name")?.extract()?;
    let (w, h): (u32, u32) = cam.get_item("image_size")?.extract()?;
    let model = match cam.get_item("model").ok().filter(|m| !m.is_none()) {
        Some(m) => {
            m.extract::<String>()?.parse::<CalibModel>().map_err(|e: String| pyo3::exceptions::PyValueError::new_err(format!("camera {name:?}: {e}")))?
        }
        None => params.model,
    };
    let dets: Vec<Detection> = cam
        .get_item("detections")?
        .try_iter()?
        .map(|d| d.and_then(|d| if d.is_none() { Ok(Detection::default()) } else { detection_from(&d) }))
        .collect::<PyResult<_>>()?;
    let mut views = vec![None; dets.len()];
    if dets.iter().any(|d| d.found) {
        let bv = views_from_detections(&dets, spec, square_m).map_err(|e| err(format!("camera {name:?}: {}", chain(&e))))?;
        for (v, i) in bv.views.into_iter().zip(bv.used) {
            views[i] = Some(v);
        }
    }
    Ok(RigCamera { name, size: ImageSize { width: w, height: h }, params: CalibParams { model, ..*params }, views })
}

/// Calibrate a camera rig (every camera's intrinsics and `cam0_from_cam`, with the frames' board
/// poses, in one bundle adjustment, as Kalibr and mrcal do; OpenCV's `stereoCalibrate` for two).
///
/// `cameras`: one dict per camera: `name`, `image_size` (width, height), `detections` (one per
/// synchronised frame, in the same order for every camera; `None` or `found: False` where the
/// camera did not see the board), optional `model` (default `model`). Returns a dict: `rms_px`
/// (over every camera's points), `cameras` (per camera `name`, `model`, `K`, `dist`, `camera`,
/// `cam0_from_cam` {`R`, `t_m`}, `rotation_std_deg`, `translation_std_m`, `rms_px`, `views`),
/// `iterations`, `rectified_row_error_mean_px` / `_max_px` (the first two cameras' corners after
/// OpenCV's stereo rectification). The GIL is released while solving.
#[pyfunction]
#[pyo3(signature = (cameras, target, square_m, model="opencv5", outlier_threshold=Some(5.0)), text_signature = "(cameras, target, square_m, model='opencv5', outlier_threshold=5.0)")]
pub fn calibrate_rig<'py>(
    py: Python<'py>,
    cameras: Vec<Bound<'py, PyAny>>,
    target: &Bound<'py, PyAny>,
    square_m: f64,
    model: &str,
    outlier_threshold: Option<f64>,
) -> PyResult<Bound<'py, PyAny>> {
    let (model, spec) = checked_args(square_m, model, target)?;
    let params = CalibParams { model, outlier_threshold, ..CalibParams::default() };
    let cams = cameras.iter().map(|c| rig_camera(c, &spec, square_m, &params)).collect::<PyResult<Vec<_>>>()?;
    let (r, cams) = py
        .detach(move || calibrate_rig_views(&cams, params.max_iterations).map(|r| (r, cams)))
        .map_err(|e| err(format!("calibrating the rig: {}", chain(&e))))?;
    let rows = rectified_row_errors(&r, &cams);
    let cameras = r
        .cameras
        .iter()
        .zip(&cams)
        .map(|(c, cam)| {
            let k = c.camera.intrinsics;
            let m = c.cam0_from_cam.rotation.to_rotation_matrix();
            let t = c.cam0_from_cam.translation.vector;
            RigCameraOut {
                name: c.name.clone(),
                model: cam.params.model.name(),
                k: [[k.fx, k.skew, k.cx], [0.0, k.fy, k.cy], [0.0, 0.0, 1.0]],
                dist: c.camera.lens.params()[..cam.params.model.n_lens_params()].to_vec(),
                camera: CameraSpec::from_model(&c.camera),
                cam0_from_cam: PoseOut { r: std::array::from_fn(|i| std::array::from_fn(|j| m[(i, j)])), t_m: [t.x, t.y, t.z] },
                rotation_std_deg: c.rotation_std_deg,
                translation_std_m: c.translation_std,
                rms_px: c.rms_px,
                views: cam.views.iter().filter(|v| v.is_some()).count(),
            }
        })
        .collect();
    let out = RigOutput {
        rms_px: r.rms_px,
        cameras,
        iterations: r.iterations,
        rectified_row_error_mean_px: rows.map(|r| r.0),
        rectified_row_error_max_px: rows.map(|r| r.1),
    };
    to_py(py, &out)
}
