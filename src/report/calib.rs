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

/// The calibration as a PNG: per-view RMS and max reprojection error (bars) and every residual
/// vector drawn at its corner in the image frame, magnified so the largest is 40 px.
///
/// # Errors
/// PNG encoding.
pub fn plot_png(r: &CalibResult, points_px: &[Vec<nalgebra::Point2<f64>>]) -> Result<Vec<u8>, super::ReportError> {
    use super::plot::{canvas, png, text, Panel, PALETTE};
    use image::Rgb;
    use imageproc::drawing::draw_line_segment_mut;
    let mut img = canvas(1200, 560);
    let n = r.views.len().max(1);
    let ymax = r.views.iter().map(|v| v.max_px).fold(1e-6, f64::max) * 1.1;
    let bars = Panel { rect: (80, 60, 440, 420), x: (-0.5, n as f64 - 0.5), y: (0.0, ymax) };
    let xt: Vec<(f64, String)> = (0..n).step_by(n.div_ceil(10)).map(|i| (i as f64, i.to_string())).collect();
    let yt: Vec<(f64, String)> = (0..=4).map(|k| (ymax * f64::from(k) / 4.0, format!("{:.3}", ymax * f64::from(k) / 4.0))).collect();
    bars.axes(&mut img, "reprojection error per view", "view", "px", &xt, &yt);
    let w = (400 / n).clamp(2, 30) as u32;
    for (i, v) in r.views.iter().enumerate() {
        bars.bar(&mut img, i as f64, v.max_px, w, Rgb([200, 200, 200]));
        bars.bar(&mut img, i as f64, v.rms_px, w.div_ceil(2), PALETTE[0]);
    }
    text(&mut img, 300, 70, "RMS (blue), max (grey)", Rgb([0, 0, 0]), 1);
    let (iw, ih) = (f64::from(r.camera.size.width), f64::from(r.camera.size.height));
    let scale = 560.0 / iw.max(ih * 560.0 / 420.0);
    let frame = Panel { rect: (600, 60, (iw * scale) as i32, (ih * scale) as i32), x: (0.0, iw), y: (ih, 0.0) };
    let big = r.views.iter().flat_map(|v| v.residuals_px.iter().map(|e| e.norm())).fold(1e-9, f64::max);
    let mag = 40.0 / big;
    frame.axes(
        &mut img,
        &format!("residuals x{mag:.0}"),
        "u px",
        "v px",
        &[(0.0, "0".into()), (iw, format!("{iw}"))],
        &[(0.0, "0".into()), (ih, format!("{ih}"))],
    );
    for (k, (v, pts)) in r.views.iter().zip(points_px).enumerate() {
        for (e, p) in v.residuals_px.iter().zip(pts) {
            let a = frame.px(p.x, p.y);
            let b = (a.0 + (e.x * mag * scale) as f32, a.1 + (e.y * mag * scale) as f32);
            draw_line_segment_mut(&mut img, a, b, PALETTE[k % PALETTE.len()]);
        }
    }
    png(&img)
}
