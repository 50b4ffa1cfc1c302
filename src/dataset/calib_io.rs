//! Calibration results as text: OpenCV `FileStorage` YAML and ROS `camera_info` YAML.

use crate::calib::CalibResult;

fn list(v: &[f64]) -> String {
    v.iter().map(|x| format!("{x:.12e}")).collect::<Vec<_>>().join(", ")
}

/// The result as OpenCV YAML (loads with `cv2.FileStorage(path, cv2.FILE_STORAGE_READ)`:
/// `camera_matrix`, `distortion_coefficients`, `image_width`, `image_height`,
/// `avg_reprojection_error`).
pub fn opencv_yaml(r: &CalibResult) -> String {
    let k = r.camera.intrinsics.matrix();
    let kv: Vec<f64> = (0..3).flat_map(|i| (0..3).map(move |j| (i, j))).map(|(i, j)| k[(i, j)]).collect();
    format!(
        "%YAML:1.0\n---\nimage_width: {}\nimage_height: {}\ncamera_matrix: !!opencv-matrix\n   rows: 3\n   cols: 3\n   dt: d\n   data: [ {} ]\ndistortion_coefficients: !!opencv-matrix\n   rows: 1\n   cols: 5\n   dt: d\n   data: [ {} ]\navg_reprojection_error: {:.12e}\n",
        r.camera.size.width,
        r.camera.size.height,
        list(&kv),
        list(&r.camera.distortion.to_array()),
        r.rms_px
    )
}

/// The result as a ROS `camera_info` YAML (plumb_bob model; `camera_calibration_parsers` format).
pub fn ros_yaml(r: &CalibResult, camera_name: &str) -> String {
    let k = r.camera.intrinsics;
    let km = [k.fx, k.skew, k.cx, 0.0, k.fy, k.cy, 0.0, 0.0, 1.0];
    let p = [k.fx, k.skew, k.cx, 0.0, 0.0, k.fy, k.cy, 0.0, 0.0, 0.0, 1.0, 0.0];
    format!(
        "image_width: {}\nimage_height: {}\ncamera_name: {camera_name}\ncamera_matrix:\n  rows: 3\n  cols: 3\n  data: [{}]\ndistortion_model: plumb_bob\ndistortion_coefficients:\n  rows: 1\n  cols: 5\n  data: [{}]\nrectification_matrix:\n  rows: 3\n  cols: 3\n  data: [1, 0, 0, 0, 1, 0, 0, 0, 1]\nprojection_matrix:\n  rows: 3\n  cols: 4\n  data: [{}]\n",
        r.camera.size.width,
        r.camera.size.height,
        list(&km),
        list(&r.camera.distortion.to_array()),
        list(&p)
    )
}
