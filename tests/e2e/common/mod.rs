//! Shared helpers: one renderer per test binary, scene builders, image statistics.

pub mod lines;

use std::sync::OnceLock;

use nalgebra::{Isometry3, Translation3, UnitQuaternion, Vector3};
use synthcam::camera::{CameraModel, Distortion, ImageSize, Intrinsics};
use synthcam::render::{GpuContext, Renderer};
use synthcam::scene::{RenderSettings, Scene};
use synthcam::target::{Chessboard, Target};

/// The shared renderer. Panics (fails the test loudly) when no adapter exists: CI installs lavapipe.
pub fn renderer() -> &'static Renderer {
    static R: OnceLock<Renderer> = OnceLock::new();
    R.get_or_init(|| {
        let ctx = GpuContext::new_headless().expect("no GPU adapter: install mesa-vulkan-drivers libvulkan1 (lavapipe)");
        eprintln!("adapter: {}", ctx.describe());
        Renderer::new(ctx)
    })
}

/// A chessboard of `squares` squares of `square_m`, rotated `tilt_deg` about its x axis, its centre
/// `distance_m` in front of the camera (plus an offset in the image plane).
pub fn chessboard_scene(camera: CameraModel, squares: [u32; 2], square_m: f64, tilt_deg: f64, distance_m: f64, offset_m: [f64; 2]) -> Scene {
    let board = Chessboard { squares, square_m, margin_m: 0.5 * square_m, ..Default::default() };
    let rot = UnitQuaternion::from_axis_angle(&Vector3::x_axis(), tilt_deg.to_radians());
    let centre = Vector3::new(0.5 * square_m * f64::from(squares[0]), 0.5 * square_m * f64::from(squares[1]), 0.0);
    let t = Vector3::new(offset_m[0], offset_m[1], distance_m) - rot * centre;
    Scene {
        camera,
        target: Target::Chessboard(board),
        cam_from_target: Isometry3::from_parts(Translation3::from(t), rot),
        render: RenderSettings::default(),
        objects: Vec::new(),
        background: None,
    }
}

/// A camera of the given size and focal length, principal point at the centre, with distortion.
pub fn camera(width: u32, height: u32, f: f64, dist: [f64; 5]) -> CameraModel {
    CameraModel {
        size: ImageSize { width, height },
        intrinsics: Intrinsics { fx: f, fy: f, cx: 0.5 * f64::from(width) - 0.5, cy: 0.5 * f64::from(height) - 0.5, skew: 0.0 },
        lens: synthcam::camera::Lens::OpenCv(Distortion::from_array(dist)),
    }
}

/// Sorted absolute differences, for mean and percentiles.
pub fn abs_diffs(a: &[f32], b: &[f64]) -> Vec<f64> {
    let mut d: Vec<f64> = a.iter().zip(b).map(|(x, y)| (f64::from(*x) - y).abs()).collect();
    d.sort_by(f64::total_cmp);
    d
}

/// Percentile of sorted values.
pub fn percentile(sorted: &[f64], p: f64) -> f64 {
    sorted[((sorted.len() - 1) as f64 * p).round() as usize]
}

/// Path of the synthcam binary built for these tests.
pub fn bin() -> &'static str {
    env!("CARGO_BIN_EXE_synthcam")
}

/// Every file under `dir/images`, name -> bytes.
pub fn images(dir: &std::path::Path) -> std::collections::BTreeMap<String, Vec<u8>> {
    std::fs::read_dir(dir.join("images"))
        .expect("images/")
        .flatten()
        .map(|e| (e.file_name().to_string_lossy().into_owned(), std::fs::read(e.path()).expect("read")))
        .collect()
}

/// Six rendered views of a 9 x 7 square chessboard (8 x 6 inner corners, 0.03 m) at 640 x 480
/// through a 600 px camera with k1 = -0.1, and a seventh at 641 x 481 (an odd frame that
/// `calibrate` skips), written as `dir/v0.png` .. `dir/v6.png`.
pub fn write_chessboard_views(dir: &std::path::Path) {
    std::fs::create_dir_all(dir).expect("tmp");
    for (k, (tilt, offset)) in [
        (25.0, [0.0, 0.0]),
        (35.0, [0.03, 0.0]),
        (-30.0, [0.0, 0.02]),
        (40.0, [-0.03, 0.01]),
        (-20.0, [0.02, -0.02]),
        (30.0, [-0.02, -0.01]),
        (30.0, [0.0, 0.0]),
    ]
    .iter()
    .enumerate()
    {
        let (w, h) = if k == 6 { (641, 481) } else { (640, 480) };
        let mut cam = camera(w, h, 600.0, [-0.1, 0.0, 0.0, 0.0, 0.0]);
        cam.intrinsics.cx = 319.5;
        cam.intrinsics.cy = 239.5;
        let mut scene = chessboard_scene(cam, [9, 7], 0.03, *tilt, 0.55, *offset);
        if k % 2 == 1 {
            // Tilt some views about y as well, so the views are not all alike.
            let rot = UnitQuaternion::from_axis_angle(&Vector3::y_axis(), 0.3);
            scene.cam_from_target = Isometry3::from_parts(scene.cam_from_target.translation, rot * scene.cam_from_target.rotation);
        }
        let img = renderer().render(&scene).expect("render");
        std::fs::write(dir.join(format!("v{k}.png")), synthcam::dataset::encode_png(&img).expect("png")).expect("write");
    }
}

/// A stress test's seed: `SYNTHCAM_STRESS_SEED` when set (to repeat a run), else fresh from the
/// clock; printed, so that a failing run can be repeated.
pub fn stress_seed() -> u64 {
    let seed = std::env::var("SYNTHCAM_STRESS_SEED")
        .ok()
        .and_then(|s| s.parse().ok())
        .unwrap_or_else(|| std::time::SystemTime::now().duration_since(std::time::UNIX_EPOCH).map_or(1, |d| d.as_nanos() as u64));
    eprintln!("SYNTHCAM_STRESS_SEED={seed}");
    seed
}
