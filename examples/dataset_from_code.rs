//! A labelled dataset from code: 12 views of a dot grid under barrel distortion, each written as
//! PNG + truth JSON (atomically), then read back and checked: the truth JSON deserialises into the
//! same labels, and the images decode to the rendered pixels.
//!
//! `cargo run --release --example dataset_from_code [OUT_DIR]` (default: a folder under the
//! system's temporary directory).

use synthcam::camera::CameraModel;
use synthcam::dataset::{load_grey_u8, write_image_and_truth};
use synthcam::render::Renderer;
use synthcam::scene::{Facing, Scene, TruthLabels};
use synthcam::target::{DotGrid, Target};

fn main() -> Result<(), Box<dyn std::error::Error>> {
    let out = std::env::args().nth(1).map(std::path::PathBuf::from).unwrap_or_else(|| std::env::temp_dir().join("synthcam_dataset_from_code"));
    std::fs::create_dir_all(&out)?;
    let renderer = Renderer::headless()?;
    let camera = CameraModel::pinhole(800, 600, 700.0).with_distortion([-0.15, 0.02, 0.0, 0.0, 0.0]);
    let grid = Target::DotGrid(DotGrid { n: 7, edge_m: 0.2, dot_radius_m: 0.008, margin_m: 0.03, ..DotGrid::default() });
    for k in 0..12 {
        let (tilt_x, tilt_y, roll) = (f64::from(k % 4) * 10.0 - 15.0, f64::from(k / 4) * 12.0 - 12.0, f64::from(k) * 7.0 - 40.0);
        let scene = Scene::builder()
            .camera(camera)
            .target(grid.clone())
            .facing(Facing { distance_m: 0.45, tilt_x_deg: tilt_x, tilt_y_deg: tilt_y, roll_deg: roll })
            .noise(0.5)
            .build()?;
        let (image, truth) = renderer.render_with_truth(&scene)?;
        let path = out.join(format!("view_{k:03}.png"));
        write_image_and_truth(&path, &image, &truth)?;
        // Read back: the labels and the pixels round-trip.
        let back: TruthLabels = serde_json::from_slice(&std::fs::read(path.with_extension("json"))?)?;
        if back != truth {
            return Err(format!("{}: truth JSON does not read back to the same labels", path.display()).into());
        }
        if load_grey_u8(&path)?.data != image.to_u8() {
            return Err(format!("{}: PNG does not decode to the rendered pixels", path.display()).into());
        }
    }
    println!("12 views with truth in {}", out.display());
    Ok(())
}
