//! Truth labels against the CPU camera model.

use nalgebra::{Point2, Vector2};
use synthcam::scene::file::parse_scene;
use synthcam::scene::truth::truth_labels;

use crate::common::{camera, chessboard_scene};

#[test]
fn json_corners_equal_cpu_projection_to_1e_9_px() {
    let scene = chessboard_scene(camera(640, 480, 500.0, [-0.25, 0.12, 1e-3, -5e-4, 0.0]), [9, 7], 0.03, 30.0, 0.5, [0.01, -0.02]);
    let truth = truth_labels(&scene);
    let json = serde_json::to_string(&truth).expect("json");
    let back: serde_json::Value = serde_json::from_str(&json).expect("parse");
    let feats = back["features"].as_array().expect("features");
    assert_eq!(feats.len(), 48);
    let mut worst: f64 = 0.0;
    for (f, p) in feats.iter().zip(scene.target.feature_points_m()) {
        let q = scene.camera.project_unchecked(&(scene.cam_from_target * p));
        let u = f["pixel_px"][0].as_f64().expect("u");
        let v = f["pixel_px"][1].as_f64().expect("v");
        worst = worst.max((u - q.x).abs()).max((v - q.y).abs());
    }
    eprintln!("max |JSON - CPU projection| = {worst:e} px");
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
            let xu = cam.distortion.undistort(&xd).expect("invertible");
            worst = worst.max((cam.distortion.distort(&xu) - xd).norm());
            let back = cam.distortion.undistort(&cam.distortion.distort(&xu)).expect("invertible");
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
