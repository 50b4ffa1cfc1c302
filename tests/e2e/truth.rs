//! Truth labels against a projection written independently of the crate (OpenCV's formula).

use nalgebra::{Point2, Vector2};
use synthcam::scene::file::parse_scene;
use synthcam::scene::truth::truth_labels;

use crate::common::{camera, chessboard_scene};

/// OpenCV's `projectPoints` for one point, written out from its documentation (pinhole + Brown-
/// Conrady, coefficients k1 k2 p1 p2 k3): independent of synthcam's camera code.
fn opencv_project(r: &nalgebra::Matrix3<f64>, t: &nalgebra::Vector3<f64>, p: [f64; 3], k: [f64; 4], d: [f64; 5]) -> [f64; 2] {
    let x = r * nalgebra::Vector3::from(p) + t;
    let (a, b) = (x[0] / x[2], x[1] / x[2]);
    let r2 = a * a + b * b;
    let radial = 1.0 + d[0] * r2 + d[1] * r2 * r2 + d[4] * r2 * r2 * r2;
    let xd = a * radial + 2.0 * d[2] * a * b + d[3] * (r2 + 2.0 * a * a);
    let yd = b * radial + d[2] * (r2 + 2.0 * b * b) + 2.0 * d[3] * a * b;
    [k[0] * xd + k[2], k[1] * yd + k[3]]
}

#[test]
fn json_corners_equal_an_independent_projection_to_1e_9_px() {
    let dist = [-0.25, 0.12, 1e-3, -5e-4, 0.0];
    let (square, tilt) = (0.03, 30f64.to_radians());
    let scene = chessboard_scene(camera(640, 480, 500.0, dist), [9, 7], square, 30.0, 0.5, [0.01, -0.02]);
    let truth = truth_labels(&scene);
    let json = serde_json::to_string(&truth).expect("json");
    let back: serde_json::Value = serde_json::from_str(&json).expect("parse");
    let feats = back["features"].as_array().expect("features");
    assert_eq!(feats.len(), 48);
    // The pose, built here from the helper's definition: tilt about x, board centre at
    // (0.01, -0.02, 0.5) m; inner corners at (c, r) squares from the board origin, row-major.
    let r = *nalgebra::Rotation3::from_axis_angle(&nalgebra::Vector3::x_axis(), tilt).matrix();
    let t = nalgebra::Vector3::new(0.01, -0.02, 0.5) - r * nalgebra::Vector3::new(4.5 * square, 3.5 * square, 0.0);
    let mut worst: f64 = 0.0;
    for (k, f) in feats.iter().enumerate() {
        let corner = [square * (k % 8 + 1) as f64, square * (k / 8 + 1) as f64, 0.0];
        let q = opencv_project(&r, &t, corner, [500.0, 500.0, 319.5, 239.5], dist);
        let u = f["pixel_px"][0].as_f64().expect("u");
        let v = f["pixel_px"][1].as_f64().expect("v");
        worst = worst.max((u - q[0]).abs()).max((v - q[1]).abs());
    }
    eprintln!("max |JSON - independent projection| = {worst:e} px");
    assert!(worst <= 1e-9, "{worst}");
}

#[test]
fn undistort_distort_round_trip_over_whole_image() {
    let cam = camera(1280, 1024, 1000.0, [-0.25, 0.12, 0.0, 0.0, 0.0]);
    let mut worst: f64 = 0.0;
    for y in (0..1024).step_by(4) {
        for x in (0..1280).step_by(4) {
            let q = Point2::new(f64::from(x), f64::from(y));
            let xd = cam.intrinsics.pixel_to_normalized(&q);
            let xu = cam.lens.undistort(&xd).expect("invertible");
            worst = worst.max((cam.lens.distort(&xu) - xd).norm());
            let back = cam.lens.undistort(&cam.lens.distort(&xu)).expect("invertible");
            worst = worst.max((back - xu).norm());
        }
    }
    eprintln!("max round-trip error {worst:e} (normalised units)");
    assert!(worst <= 1e-10);
    let _ = Vector2::<f64>::zeros();
}

#[test]
fn s_path_dot_centroids_are_labelled_and_differ_from_projection() {
    let text = include_str!("../../assets/scenes/course_s_path.toml");
    let scene = parse_scene(text).expect("scene");
    let truth = truth_labels(&scene);
    assert_eq!(truth.features.len(), 101);
    assert!(truth.features.iter().all(|f| f.visible), "all 101 dots visible from the desired pose");
    // Course-scenario 2 item 2: first point near (924.8, 143.3), last near (409.0, 825.3).
    let first = truth.features[0].pixel_px;
    let last = truth.features[100].pixel_px;
    assert!((first[0] - 924.8).abs() < 0.5 && (first[1] - 143.3).abs() < 0.5, "{first:?}");
    assert!((last[0] - 409.0).abs() < 0.5 && (last[1] - 825.3).abs() < 0.5, "{last:?}");
    let bias: Vec<f64> = truth
        .features
        .iter()
        .map(|f| {
            let c = f.centroid_px.expect("centroid");
            (Point2::from(c) - Point2::from(f.pixel_px)).norm()
        })
        .collect();
    let mean = bias.iter().sum::<f64>() / bias.len() as f64;
    let max = bias.iter().cloned().fold(0.0, f64::max);
    eprintln!("centroid - projected centre: mean {mean:.3} px, max {max:.3} px");
    assert!(max > 0.01, "perspective makes the blob centroid differ from the projected centre");
}
