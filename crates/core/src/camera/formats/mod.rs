//! Camera files other tools load: OpenCV `FileStorage` YAML (as `calibrateCamera` and
//! `cv::fisheye::calibrate` results are saved), ROS `camera_info` YAML
//! (`camera_calibration_parsers`), Kalibr camchain YAML and mrcal `.cameramodel`. Each writer
//! refuses, with [`CameraFileError::Unsupported`], a camera its format cannot hold (no silent
//! truncation); [`read()`] reads every file written here back.
//!
//! | format | OpenCV models | fisheye | Double Sphere | skew |
//! |---|---|---|---|---|
//! | OpenCV YAML | 4, 5, 8, 12, 14 values | `D` 4 x 1, `model: fisheye` | no | yes |
//! | ROS | `plumb_bob` (<= 5), `rational_polynomial` (8) | `equidistant` | no | yes |
//! | Kalibr | `pinhole-radtan` (k1 k2 p1 p2) | `pinhole-equi` | `ds-none` | no |
//! | mrcal | `LENSMODEL_OPENCV4/5/8/12` | no | no | no |
//!
//! Reference: OpenCV `FileStorage` docs; ROS `sensor_msgs/CameraInfo` and
//! `camera_calibration_parsers`; Kalibr wiki "Yaml formats"; mrcal docs "Camera model
//! representation in memory and on disk".

mod read;

pub use read::read;

use super::{CameraModel, Lens};

/// Errors of the camera-file writers and the reader.
#[derive(Debug, thiserror::Error, Clone, PartialEq)]
#[non_exhaustive]
pub enum CameraFileError {
    /// The format cannot hold this camera.
    #[error("{format} cannot hold this camera: {reason}")]
    Unsupported {
        /// The format.
        format: &'static str,
        /// Why.
        reason: String,
    },
    /// The text is not a camera file we can read.
    #[error("not a readable camera file: {0}")]
    Parse(String),
    /// The file's camera is invalid.
    #[error(transparent)]
    Camera(#[from] super::CameraError),
}

fn list(v: &[f64]) -> String {
    v.iter().map(|x| format!("{x:.17e}")).collect::<Vec<_>>().join(", ")
}

fn unsupported(format: &'static str, reason: impl Into<String>) -> CameraFileError {
    CameraFileError::Unsupported { format, reason: reason.into() }
}

fn k_row_major(cam: &CameraModel) -> [f64; 9] {
    let k = &cam.intrinsics;
    [k.fx, k.skew, k.cx, 0.0, k.fy, k.cy, 0.0, 0.0, 1.0]
}

/// OpenCV `FileStorage` YAML: `image_width`, `image_height`, `camera_matrix`,
/// `distortion_coefficients` (OpenCV: 1 x N with N the shortest of 4, 5, 8, 12, 14 that holds
/// every coefficient, at least 5; fisheye: 4 x 1 and `model: fisheye`), `avg_reprojection_error`.
///
/// # Errors
/// [`CameraFileError::Unsupported`] for a Double Sphere camera.
pub fn opencv_yaml(cam: &CameraModel, rms_px: f64) -> Result<String, CameraFileError> {
    let (model, rows, d) = match cam.lens {
        Lens::OpenCv(d) => ("opencv", 1, d.coefficients()[..d.opencv_len().max(5)].to_vec()),
        Lens::Fisheye(f) => ("fisheye", 4, f.k.to_vec()),
        Lens::DoubleSphere(_) => return Err(unsupported("OpenCV YAML", "OpenCV has no Double Sphere model")),
    };
    let cols = d.len() / rows;
    Ok(format!(
        "%YAML:1.0\n---\nmodel: \"{model}\"\nimage_width: {}\nimage_height: {}\ncamera_matrix: !!opencv-matrix\n   rows: 3\n   cols: 3\n   dt: d\n   data: [ {} ]\ndistortion_coefficients: !!opencv-matrix\n   rows: {rows}\n   cols: {cols}\n   dt: d\n   data: [ {} ]\navg_reprojection_error: {rms_px:.12e}\n",
        cam.size.width,
        cam.size.height,
        list(&k_row_major(cam)),
        list(&d),
    ))
}

/// A camera as ROS's `sensor_msgs/CameraInfo` holds it (the rectification R is the identity).
#[derive(Debug, Clone, PartialEq)]
pub struct RosCameraInfo {
    /// `plumb_bob`, `rational_polynomial` or `equidistant`.
    pub distortion_model: &'static str,
    /// Distortion coefficients in that model's order.
    pub d: Vec<f64>,
    /// Intrinsic matrix, row-major, pixels.
    pub k: [f64; 9],
    /// Projection matrix `[K | 0]`, row-major.
    pub p: [f64; 12],
}

/// ROS's view of `cam`: `plumb_bob` for OpenCV's model with at most 5 coefficients,
/// `rational_polynomial` with 8, `equidistant` for the fisheye model. Used by [`ros_yaml`] and
/// by the ROS 2 bags' `CameraInfo` messages.
///
/// # Errors
/// [`CameraFileError::Unsupported`] for thin-prism or tilt terms, or a Double Sphere camera.
pub fn ros_camera_info(cam: &CameraModel) -> Result<RosCameraInfo, CameraFileError> {
    let (distortion_model, d) = match cam.lens {
        Lens::OpenCv(d) => match d.opencv_len() {
            0..=5 => ("plumb_bob", d.coefficients()[..5].to_vec()),
            8 => ("rational_polynomial", d.coefficients()[..8].to_vec()),
            n => return Err(unsupported("ROS camera_info", format!("no ROS distortion model has OpenCV's {n}-value form (thin-prism, tilt)"))),
        },
        Lens::Fisheye(f) => ("equidistant", f.k.to_vec()),
        Lens::DoubleSphere(_) => return Err(unsupported("ROS camera_info", "ROS has no Double Sphere (double-sphere) model")),
    };
    let k = &cam.intrinsics;
    let p = [k.fx, k.skew, k.cx, 0.0, 0.0, k.fy, k.cy, 0.0, 0.0, 0.0, 1.0, 0.0];
    Ok(RosCameraInfo { distortion_model, d, k: k_row_major(cam), p })
}

/// ROS `camera_info` YAML ([`ros_camera_info`]).
///
/// # Errors
/// As [`ros_camera_info`].
pub fn ros_yaml(cam: &CameraModel, camera_name: &str) -> Result<String, CameraFileError> {
    let info = ros_camera_info(cam)?;
    Ok(format!(
        "image_width: {}\nimage_height: {}\ncamera_name: {camera_name}\ncamera_matrix:\n  rows: 3\n  cols: 3\n  data: [{}]\ndistortion_model: {}\ndistortion_coefficients:\n  rows: 1\n  cols: {}\n  data: [{}]\nrectification_matrix:\n  rows: 3\n  cols: 3\n  data: [1, 0, 0, 0, 1, 0, 0, 0, 1]\nprojection_matrix:\n  rows: 3\n  cols: 4\n  data: [{}]\n",
        cam.size.width,
        cam.size.height,
        list(&info.k),
        info.distortion_model,
        info.d.len(),
        list(&info.d),
        list(&info.p)
    ))
}

/// Kalibr camchain YAML, one camera `cam0` (`pinhole-radtan`, `pinhole-equi` or `ds-none`).
///
/// # Errors
/// [`CameraFileError::Unsupported`] for skew, or OpenCV terms beyond `k1 k2 p1 p2`.
pub fn kalibr_yaml(cam: &CameraModel) -> Result<String, CameraFileError> {
    Ok(format!("cam0:\n{}", kalibr_block(cam)?))
}

/// One camera's fields of a Kalibr camchain (indented under its `camN:`).
fn kalibr_block(cam: &CameraModel) -> Result<String, CameraFileError> {
    let k = &cam.intrinsics;
    if k.skew != 0.0 {
        return Err(unsupported("Kalibr camchain", format!("Kalibr's intrinsics have no skew (skew = {})", k.skew)));
    }
    let base = [k.fx, k.fy, k.cx, k.cy];
    let (model, intr, dmodel, d) = match cam.lens {
        Lens::OpenCv(d) if d.opencv_len() <= 4 => ("pinhole", base.to_vec(), "radtan", d.coefficients()[..4].to_vec()),
        Lens::OpenCv(d) => {
            return Err(unsupported("Kalibr camchain", format!("radtan has k1 k2 p1 p2 only; this camera has OpenCV's {}-value form", d.opencv_len())))
        }
        Lens::Fisheye(f) => ("pinhole", base.to_vec(), "equidistant", f.k.to_vec()),
        Lens::DoubleSphere(d) => ("ds", [d.xi, d.alpha].iter().chain(&base).copied().collect(), "none", Vec::new()),
    };
    Ok(format!(
        "  camera_model: {model}\n  intrinsics: [{}]\n  distortion_model: {dmodel}\n  distortion_coeffs: [{}]\n  resolution: [{}, {}]\n",
        list(&intr),
        list(&d),
        cam.size.width,
        cam.size.height
    ))
}

/// A rig's Kalibr camchain: `cam0`, `cam1`, ... each with its intrinsics and, after the first,
/// `T_cn_cnm1` (`camN_from_cam(N-1)`, 4 x 4, metres) from the rig's `cam0_from_cam` poses.
///
/// # Errors
/// As [`kalibr_yaml`] for any camera; [`CameraFileError::Unsupported`] when the pose list's
/// length is not the cameras'.
pub fn kalibr_camchain(cams: &[CameraModel], cam0_from_cam: &[nalgebra::Isometry3<f64>]) -> Result<String, CameraFileError> {
    if cams.len() != cam0_from_cam.len() {
        return Err(unsupported("Kalibr camchain", format!("{} cameras, {} poses", cams.len(), cam0_from_cam.len())));
    }
    let mut out = String::new();
    for (n, (cam, pose)) in cams.iter().zip(cam0_from_cam).enumerate() {
        out += &format!("cam{n}:\n");
        if n > 0 {
            let t = (pose.inverse() * cam0_from_cam[n - 1]).to_homogeneous();
            out += "  T_cn_cnm1:\n";
            for r in 0..4 {
                out += &format!("  - [{}]\n", list(&[t[(r, 0)], t[(r, 1)], t[(r, 2)], t[(r, 3)]]));
            }
        }
        out += &kalibr_block(cam)?;
    }
    Ok(out)
}

/// mrcal `.cameramodel` (`LENSMODEL_OPENCV4`, `5`, `8` or `12`), extrinsics at the origin.
///
/// # Errors
/// [`CameraFileError::Unsupported`] for skew, tilt terms, fisheye or Double Sphere cameras.
pub fn mrcal_cameramodel(cam: &CameraModel) -> Result<String, CameraFileError> {
    let k = &cam.intrinsics;
    if k.skew != 0.0 {
        return Err(unsupported("mrcal", format!("mrcal's OpenCV models have no skew (skew = {})", k.skew)));
    }
    let Lens::OpenCv(d) = cam.lens else {
        return Err(unsupported("mrcal", format!("mrcal has no {} model", cam.lens.kind().name())));
    };
    let n = d.opencv_len().max(5);
    if n > 12 {
        return Err(unsupported("mrcal", "mrcal has no tilted-sensor (14-value) OpenCV model"));
    }
    let intr: Vec<f64> = [k.fx, k.fy, k.cx, k.cy].iter().chain(&d.coefficients()[..n]).copied().collect();
    Ok(format!(
        "# generated by synthcam\n{{\n    'lensmodel':  'LENSMODEL_OPENCV{n}',\n    'intrinsics': [ {} ],\n    'imagersize': [ {}, {} ],\n    'extrinsics': [ 0, 0, 0, 0, 0, 0 ],\n}}\n",
        list(&intr),
        cam.size.width,
        cam.size.height
    ))
}

#[cfg(test)]
mod tests;
