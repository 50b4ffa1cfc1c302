//! Golden images: small scenes rendered on lavapipe and compared with `golden/render/<case>.png`.
//! Each case declares its metric and thresholds. On a mismatch `<case>-actual.png` and
//! `<case>-diff.png` (|diff| x 16) are written to `target/golden-out/`. `UPDATE_GOLDEN=1`
//! regenerates the goldens (and their truth JSON); a missing golden fails unless updating.

use std::path::PathBuf;

use synthcam::camera::CameraModel;
use synthcam::dataset::{encode_png, write_atomic};
use synthcam::render::GreyImage;
use synthcam::scene::file::parse_scene;
use synthcam::scene::truth::truth_labels;
use synthcam::scene::Scene;

use crate::common::{camera, chessboard_scene, renderer};

/// Thresholds of one case: max |diff| and mean |diff| in grey levels. The goldens were made on
/// lavapipe (Mesa 22.3.6, LLVM 15); renders there are bit-exact, so the thresholds only leave room
/// for other LLVM versions' rounding of f32 maths.
struct Case {
    name: &'static str,
    scene: Scene,
    max_abs: u8,
    max_mean: f64,
}

fn small(mut s: Scene, w: u32, h: u32) -> Scene {
    let k = s.camera.intrinsics;
    let scale = f64::from(w) / f64::from(s.camera.size.width);
    s.camera = CameraModel {
        size: synthcam::camera::ImageSize { width: w, height: h },
        intrinsics: synthcam::camera::Intrinsics {
            fx: k.fx * scale,
            fy: k.fy * scale,
            cx: (k.cx + 0.5) * scale - 0.5,
            cy: (k.cy + 0.5) * scale - 0.5,
            skew: k.skew * scale,
        },
        lens: s.camera.lens,
    };
    s
}

fn cases() -> Vec<Case> {
    let board = small(parse_scene(include_str!("../../assets/scenes/chessboard_k1.toml")).expect("scene"), 320, 256);
    let spath = small(parse_scene(include_str!("../../assets/scenes/course_s_path.toml")).expect("scene"), 320, 256);
    let mut noisy = chessboard_scene(camera(203, 157, 180.0, [-0.2, 0.05, 0.001, 0.0, 0.0]), [7, 5], 0.03, 25.0, 0.4, [0.0, 0.0]);
    noisy.render.noise_sigma = 3.0;
    noisy.render.blur_sigma_px = 0.8;
    noisy.render.seed = 7;
    let mut grid = parse_scene(include_str!("../../assets/scenes/chessboard_k1.toml")).expect("scene");
    grid.target = synthcam::target::Target::DotGrid(synthcam::target::DotGrid { n: 5, edge_m: 0.4, dot_radius_m: 0.02, margin_m: 0.05, ..Default::default() });
    grid.cam_from_target.translation.vector = nalgebra::Vector3::new(0.0, 0.0, 0.8);
    let grid = small(grid, 240, 192);
    let charuco = small(parse_scene(include_str!("../../assets/scenes/charuco_k1.toml")).expect("scene"), 320, 256);
    let aprilgrid = small(parse_scene(include_str!("../../assets/scenes/aprilgrid_k1.toml")).expect("scene"), 320, 256);
    let real = small(parse_scene(include_str!("../../assets/scenes/effects/real_camera.toml")).expect("scene"), 320, 256);
    let meshes = synthcam::dataset::MeshLibrary::new(std::path::Path::new("assets/scenes/objects"));
    let gripper_text = include_str!("../../assets/scenes/objects/gripper_charuco.toml");
    let gripper = small(synthcam::scene::file::parse_scene_with(gripper_text, &|p: &str| meshes.load(p)).expect("scene"), 320, 256);
    let panorama = small(parse_scene(include_str!("../../assets/scenes/background/fisheye_panorama.toml")).expect("scene"), 320, 256);
    vec![
        Case { name: "fisheye_panorama_320", scene: panorama, max_abs: 1, max_mean: 0.01 },
        Case { name: "real_camera_320", scene: real, max_abs: 1, max_mean: 0.01 },
        Case { name: "gripper_charuco_320", scene: gripper, max_abs: 1, max_mean: 0.01 },
        Case { name: "charuco_k1_320", scene: charuco, max_abs: 1, max_mean: 0.01 },
        Case { name: "aprilgrid_k1_320", scene: aprilgrid, max_abs: 1, max_mean: 0.01 },
        Case { name: "chessboard_k1_320", scene: board, max_abs: 1, max_mean: 0.01 },
        Case { name: "s_path_320", scene: spath, max_abs: 1, max_mean: 0.01 },
        Case { name: "chessboard_noise_blur_203", scene: noisy, max_abs: 1, max_mean: 0.01 },
        Case { name: "dot_grid_240", scene: grid, max_abs: 1, max_mean: 0.01 },
    ]
}

fn gray(img: &GreyImage) -> Vec<u8> {
    img.to_u8()
}

#[test]
fn golden_images_match() {
    let root = PathBuf::from(env!("CARGO_MANIFEST_DIR"));
    let dir = root.join("golden/render");
    let out_dir = root.join("target/golden-out");
    let update = std::env::var("UPDATE_GOLDEN").is_ok_and(|v| v == "1");
    let mut failures = Vec::new();
    for case in cases() {
        let img = renderer().render(&case.scene).expect("render");
        let png = encode_png(&img).expect("png");
        let path = dir.join(format!("{}.png", case.name));
        if update {
            std::fs::create_dir_all(&dir).expect("mkdir");
            write_atomic(&path, &png).expect("write golden");
            let truth = serde_json::to_vec_pretty(&truth_labels(&case.scene)).expect("json");
            write_atomic(&path.with_extension("json"), &truth).expect("write truth");
            continue;
        }
        let golden = match image::open(&path) {
            Ok(g) => g.to_luma8(),
            Err(e) => {
                failures.push(format!("{}: missing golden {} ({e}); run with UPDATE_GOLDEN=1", case.name, path.display()));
                continue;
            }
        };
        let actual = gray(&img);
        let (w, h) = (case.scene.camera.size.width, case.scene.camera.size.height);
        if golden.dimensions() != (w, h) {
            failures.push(format!("{}: size {:?} vs {:?}", case.name, golden.dimensions(), (w, h)));
            continue;
        }
        let diffs: Vec<u8> = actual.iter().zip(golden.as_raw()).map(|(a, b)| a.abs_diff(*b)).collect();
        let max = diffs.iter().copied().max().unwrap_or(0);
        let mean = diffs.iter().map(|d| f64::from(*d)).sum::<f64>() / diffs.len() as f64;
        eprintln!("golden {}: max |diff| {max}, mean {mean:.5}", case.name);
        if max > case.max_abs || mean > case.max_mean {
            std::fs::create_dir_all(&out_dir).expect("mkdir");
            let _ = std::fs::write(out_dir.join(format!("{}-actual.png", case.name)), &png);
            let diff_img = image::GrayImage::from_raw(w, h, diffs.iter().map(|d| d.saturating_mul(16)).collect()).expect("size");
            let _ = diff_img.save(out_dir.join(format!("{}-diff.png", case.name)));
            failures.push(format!("{}: max |diff| {max} > {} or mean {mean} > {} (see {})", case.name, case.max_abs, case.max_mean, out_dir.display()));
        }
    }
    assert!(failures.is_empty(), "{}", failures.join("\n"));
}
