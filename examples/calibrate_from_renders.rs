//! The front door: render a distorted board with truth, detect it, calibrate from the rendered
//! views and write the camera as OpenCV YAML, with `use synthcam::prelude::*` only. The same code
//! is the doctest of the crate's documentation (src/lib.rs). Exits non-zero when the calibration
//! misses the rendered camera by more than 0.5 px in fx or 0.002 in k1.
//!
//! `cargo run --release --example calibrate_from_renders`

use synthcam::prelude::*;

fn main() -> Result<(), Box<dyn std::error::Error>> {
    let camera = CameraModel::pinhole(1280, 1024, 1000.0).with_distortion([-0.25, 0.08, 0.0, 0.0, 0.0]);
    let (board, renderer) = (Target::chessboard(10, 7, 0.03), Renderer::headless()?);
    let mut detections = Vec::new();
    for (tilt_x_deg, tilt_y_deg) in [(0.0, 0.0), (30.0, 0.0), (-30.0, 10.0), (0.0, 30.0), (10.0, -30.0), (25.0, 25.0)] {
        let facing = Facing { distance_m: 0.5, tilt_x_deg, tilt_y_deg, roll_deg: 0.0 };
        let scene = Scene::builder().camera(camera).target(board.clone()).facing(facing).noise(1.0).build()?;
        let (image, truth) = renderer.render_with_truth(&scene)?; // truth: every corner's exact pixel
        let found = detect(&image.to_detector_image()?, &TargetSpec::for_target(&board))?;
        println!("view {}: {} of {} corners", detections.len(), found.points_px.len(), truth.features.len());
        detections.push(found);
    }
    let views = views_from_detections(&detections, &TargetSpec::for_target(&board), 0.03)?;
    let result = calibrate(&views.views, camera.size, &CalibParams::default())?;
    let yaml = std::env::temp_dir().join("synthcam_camera.yaml");
    std::fs::write(&yaml, opencv_yaml(&result.camera, result.rms_px)?)?;
    let (fx, k1) = (result.camera.intrinsics.fx, result.camera.lens.params()[0]);
    println!("RMS {:.4} px; fx {fx:.3} (rendered 1000), k1 {k1:.5} (rendered -0.25); wrote {}", result.rms_px, yaml.display());
    if (fx - 1000.0).abs() > 0.5 || (k1 + 0.25).abs() > 0.002 {
        return Err(format!("calibration off the rendered camera: fx {fx}, k1 {k1}").into());
    }
    Ok(())
}
