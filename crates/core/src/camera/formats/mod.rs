//! Camera files other tools load: OpenCV `FileStorage` YAML (as `calibrateCamera` and
//! `cv::fisheye::calibrate` results are saved), ROS `camera_info` YAML
//! (`camera_calibration_parsers`), Kalibr camchain YAML and mrcal `.cameramodel`. Each writer
//! refuses, with [`CameraFileError::Unsupported`], a camera its format cannot hold (no silent
//! truncation); [`read()`] reads every file written here back.
//!
//! Stereo pairs: [`opencv_stereo_yaml`] (`stereoCalibrate` + `stereoRectify`'s matrices),
//! [`ros_yaml_rectified`] per camera, [`mrcal_cameramodel_at`] with a rig pose, and
//! [`kalibr_camchain`] for any number of cameras.
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

pub use read::{read, read_camchain};

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

/// OpenCV's distortion matrix of `cam`: (`model`, rows, values).
fn opencv_distortion(cam: &CameraModel) -> Result<(&'static str, usize, Vec<f64>), CameraFileError> {
    match cam.lens {
        Lens::OpenCv(d) => Ok(("opencv", 1, d.coefficients()[..d.opencv_len().max(5)].to_vec())),
        Lens::Fisheye(f) => Ok(("fisheye", 4, f.k.to_vec())),
        Lens::DoubleSphere(_) => Err(unsupported("OpenCV YAML", "OpenCV has no Double Sphere model")),
    }
}

/// One `!!opencv-matrix` node.
fn cv_matrix(name: &str, rows: usize, values: &[f64]) -> String {
    let cols = values.len() / rows.max(1);
    format!("{name}: !!opencv-matrix\n   rows: {rows}\n   cols: {cols}\n   dt: d\n   data: [ {} ]\n", list(values))
}

fn row_major<const R: usize, const C: usize>(m: &nalgebra::SMatrix<f64, R, C>) -> Vec<f64> {
    (0..R).flat_map(|r| (0..C).map(move |c| m[(r, c)])).collect()
}

/// OpenCV `FileStorage` YAML: `image_width`, `image_height`, `camera_matrix`,
/// `distortion_coefficients` (OpenCV: 1 x N with N the shortest of 4, 5, 8, 12, 14 that holds
/// every coefficient, at least 5; fisheye: 4 x 1 and `model: fisheye`), `avg_reprojection_error`.
///
/// # Errors
/// [`CameraFileError::Unsupported`] for a Double Sphere camera.
pub fn opencv_yaml(cam: &CameraModel, rms_px: f64) -> Result<String, CameraFileError> {
    let (model, rows, d) = opencv_distortion(cam)?;
    Ok(format!(
        "%YAML:1.0\n---\nmodel: \"{model}\"\nimage_width: {}\nimage_height: {}\n{}{}avg_reprojection_error: {rms_px:.12e}\n",
        cam.size.width,
        cam.size.height,
        cv_matrix("camera_matrix", 3, &k_row_major(cam)),
        cv_matrix("distortion_coefficients", rows, &d),
    ))
}

/// A calibrated stereo pair with its rectification, in OpenCV's names (`stereoCalibrate` and
/// `stereoRectify`): `R`, `T` map camera 0's frame into camera 1's (`x1 = R x0 + T`).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct StereoPair<'a> {
    /// Camera 0 (`K1`, `D1`).
    pub cam0: &'a CameraModel,
    /// Camera 1 (`K2`, `D2`).
    pub cam1: &'a CameraModel,
    /// `cam1_from_cam0` (`R`, `T`).
    pub cam1_from_cam0: nalgebra::Isometry3<f64>,
    /// Essential matrix.
    pub e: nalgebra::Matrix3<f64>,
    /// Fundamental matrix.
    pub f: nalgebra::Matrix3<f64>,
    /// Rectifying rotation of camera 0.
    pub r1: nalgebra::Matrix3<f64>,
    /// Rectifying rotation of camera 1.
    pub r2: nalgebra::Matrix3<f64>,
    /// Rectified projection of camera 0.
    pub p1: nalgebra::Matrix3x4<f64>,
    /// Rectified projection of camera 1.
    pub p2: nalgebra::Matrix3x4<f64>,
    /// Disparity-to-depth mapping.
    pub q: nalgebra::Matrix4<f64>,
    /// RMS reprojection error over both cameras' points, px.
    pub rms_px: f64,
}

/// OpenCV `FileStorage` YAML of a stereo pair: `image_width`, `image_height` (camera 0's),
/// `model`, `K1`, `D1`, `K2`, `D2`, `R`, `T`, `E`, `F`, `R1`, `R2`, `P1`, `P2`, `Q` and `rms`,
/// the matrices `stereoCalibrate` and `stereoRectify` return, under their documented names
/// (`cv2.FileStorage(path).getNode("R1").mat()`). Camera 1's size is `image_width_2`,
/// `image_height_2`.
///
/// # Errors
/// As [`opencv_yaml`] for either camera; [`CameraFileError::Unsupported`] for a fisheye beside a
/// pinhole (OpenCV's stereo functions take one model for both).
pub fn opencv_stereo_yaml(pair: &StereoPair<'_>) -> Result<String, CameraFileError> {
    let (m0, rows0, d0) = opencv_distortion(pair.cam0)?;
    let (m1, rows1, d1) = opencv_distortion(pair.cam1)?;
    if m0 != m1 {
        return Err(unsupported("OpenCV stereo YAML", format!("OpenCV's stereo functions take one model for both cameras, got {m0} and {m1}")));
    }
    let t = pair.cam1_from_cam0.translation.vector;
    let r = pair.cam1_from_cam0.rotation.to_rotation_matrix();
    let mut out = format!(
        "%YAML:1.0\n---\nmodel: \"{m0}\"\nimage_width: {}\nimage_height: {}\nimage_width_2: {}\nimage_height_2: {}\n",
        pair.cam0.size.width, pair.cam0.size.height, pair.cam1.size.width, pair.cam1.size.height
    );
    out += &cv_matrix("K1", 3, &k_row_major(pair.cam0));
    out += &cv_matrix("D1", rows0, &d0);
    out += &cv_matrix("K2", 3, &k_row_major(pair.cam1));
    out += &cv_matrix("D2", rows1, &d1);
    out += &cv_matrix("R", 3, &row_major(r.matrix()));
    out += &cv_matrix("T", 3, &[t.x, t.y, t.z]);
    for (name, m) in [("E", &pair.e), ("F", &pair.f), ("R1", &pair.r1), ("R2", &pair.r2)] {
        out += &cv_matrix(name, 3, &row_major(m));
    }
    out += &cv_matrix("P1", 3, &row_major(&pair.p1));
    out += &cv_matrix("P2", 3, &row_major(&pair.p2));
    out += &cv_matrix("Q", 4, &row_major(&pair.q));
    out += &format!("rms: {:.12e}\n", pair.rms_px);
    Ok(out)
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

/// ROS `camera_info` YAML ([`ros_camera_info`]; rectification the identity, projection
/// `[K | 0]`).
///
/// # Errors
/// As [`ros_camera_info`].
pub fn ros_yaml(cam: &CameraModel, camera_name: &str) -> Result<String, CameraFileError> {
    let p = ros_camera_info(cam)?.p;
    ros_yaml_rectified(cam, camera_name, &nalgebra::Matrix3::identity(), &nalgebra::Matrix3x4::from_row_slice(&p))
}

/// ROS `camera_info` YAML of one camera of a stereo pair: its rectification matrix `R` (the
/// rectifying rotation, `R1` or `R2` of `stereoRectify`) and projection matrix `P` (`P1` or
/// `P2`, whose column 3 holds `f * Tx`, negative for a right camera, as ROS's `Tx = -fx' B`), as
/// ROS's `camera_calibration` writes `left.yaml` and `right.yaml`.
///
/// # Errors
/// As [`ros_camera_info`].
pub fn ros_yaml_rectified(cam: &CameraModel, camera_name: &str, r: &nalgebra::Matrix3<f64>, p: &nalgebra::Matrix3x4<f64>) -> Result<String, CameraFileError> {
    let info = ros_camera_info(cam)?;
    Ok(format!(
        "image_width: {}\nimage_height: {}\ncamera_name: {camera_name}\ncamera_matrix:\n  rows: 3\n  cols: 3\n  data: [{}]\ndistortion_model: {}\ndistortion_coefficients:\n  rows: 1\n  cols: {}\n  data: [{}]\nrectification_matrix:\n  rows: 3\n  cols: 3\n  data: [{}]\nprojection_matrix:\n  rows: 3\n  cols: 4\n  data: [{}]\n",
        cam.size.width,
        cam.size.height,
        list(&info.k),
        info.distortion_model,
        info.d.len(),
        list(&info.d),
        list(&row_major(r)),
        list(&row_major(p))
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
    mrcal_cameramodel_at(cam, &nalgebra::Isometry3::identity())
}

/// mrcal `.cameramodel` of one camera of a rig: `extrinsics` is mrcal's `rt_cam_ref`, the
/// rotation vector and translation of `cam_from_ref` (the reference frame being the rig's,
/// camera 0's for a rig calibrated here), so `mrcal.cameramodel(path).extrinsics_rt_fromref()`
/// returns it.
///
/// # Errors
/// As [`mrcal_cameramodel`].
pub fn mrcal_cameramodel_at(cam: &CameraModel, cam_from_ref: &nalgebra::Isometry3<f64>) -> Result<String, CameraFileError> {
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
    let r = cam_from_ref.rotation.scaled_axis();
    let t = cam_from_ref.translation.vector;
    let extrinsics = [r.x, r.y, r.z, t.x, t.y, t.z];
    Ok(format!(
        "# generated by synthcam\n{{\n    'lensmodel':  'LENSMODEL_OPENCV{n}',\n    'intrinsics': [ {} ],\n    'imagersize': [ {}, {} ],\n    'extrinsics': [ {} ],\n}}\n",
        list(&intr),
        cam.size.width,
        cam.size.height,
        list(&extrinsics)
    ))
}

#[cfg(test)]
mod tests;
