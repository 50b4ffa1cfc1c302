//! The golden-image use: render a strongly distorted, tilted board with exact truth and check a
//! detector's corners against it, the way another project's test would. Exits non-zero when the
//! detector misses a corner or is off by more than 0.05 px RMS.
//!
//! `cargo run --release --example golden_detector_test`

use synthcam::camera::CameraModel;
use synthcam::detect::target::{detect, TargetSpec};
use synthcam::render::Renderer;
use synthcam::scene::{Facing, Scene};
use synthcam::target::Target;

fn main() -> Result<(), Box<dyn std::error::Error>> {
    let camera = CameraModel::pinhole(1280, 960, 1000.0).with_distortion([-0.25, 0.08, 0.0, 0.0, 0.0]);
    let scene = Scene::builder()
        .camera(camera)
        .target(Target::chessboard(10, 7, 0.03))
        .facing(Facing { distance_m: 0.45, tilt_x_deg: 35.0, tilt_y_deg: -15.0, roll_deg: 10.0 })
        .noise(1.0)
        .build()?;
    let (image, truth) = Renderer::headless()?.render_with_truth(&scene)?;
    // The detector under test: synthcam's own here; put yours in its place.
    let found = detect(&image.to_detector_image()?, &TargetSpec::for_target(&scene.target))?;
    let errors: Vec<f64> =
        found.points_px.iter().map(|p| truth.features.iter().map(|f| (p - nalgebra::Point2::from(f.pixel_px)).norm()).fold(f64::INFINITY, f64::min)).collect();
    let rms = (errors.iter().map(|e| e * e).sum::<f64>() / errors.len().max(1) as f64).sqrt();
    println!("{} of {} corners, RMS {rms:.4} px, max {:.4} px", found.points_px.len(), truth.features.len(), errors.iter().cloned().fold(0.0, f64::max));
    if found.points_px.len() != truth.features.len() || rms > 0.05 {
        return Err(format!("detector below the golden bar: {} corners, RMS {rms:.4} px", found.points_px.len()).into());
    }
    Ok(())
}
