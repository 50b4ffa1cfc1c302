//! Same scene and seed give bit-identical PNGs: across runs, across LP_NUM_THREADS, and between
//! the Vulkan and GL backends.

use std::process::Command;

use synthcam::dataset::encode_png;
use synthcam::render::{finish, BackendChoice, GpuContext, Renderer};
use synthcam::scene::file::parse_scene;

use crate::common::{bin, renderer};

fn scenes() -> Vec<(&'static str, synthcam::scene::Scene)> {
    let mut board = parse_scene(include_str!("../../assets/scenes/chessboard_k1.toml")).expect("scene");
    board.render.noise_sigma = 2.0;
    board.render.blur_sigma_px = 0.7;
    board.render.seed = 42;
    let spath = parse_scene(include_str!("../../assets/scenes/course_s_path.toml")).expect("scene");
    let fisheye_text = include_str!("../../assets/scenes/fisheye_chessboard.toml");
    let fisheye = parse_scene(fisheye_text).expect("scene");
    let ds =
        parse_scene(&fisheye_text.replace("model = \"fisheye\"\ndist = [0.05, -0.01, 0.002, -0.0005]", "model = \"double-sphere\"\nxi = -0.2\nalpha = 0.6"))
            .expect("scene");
    assert_eq!(ds.camera.lens.kind().name(), "double-sphere");
    let mut opencv14 = board.clone();
    opencv14.camera.lens = synthcam::camera::Lens::OpenCv(synthcam::camera::Distortion::from_coefficients([
        -0.2, 0.05, 0.001, -0.002, 0.01, 0.03, -0.01, 0.002, 1e-3, -2e-4, 5e-4, 3e-4, 0.02, -0.015,
    ]));
    let wide = parse_scene(include_str!("../../assets/scenes/fisheye_wide_chessboard.toml")).expect("scene");
    let charuco = parse_scene(include_str!("../../assets/scenes/charuco_k1.toml")).expect("scene");
    let mut aprilgrid = parse_scene(include_str!("../../assets/scenes/aprilgrid_k1.toml")).expect("scene");
    aprilgrid.camera.lens = fisheye.camera.lens;
    let real = parse_scene(include_str!("../../assets/scenes/effects/real_camera.toml")).expect("scene");
    // A fisheye (the shader's general-ray path) with defocus, motion blur and a rolling shutter.
    let mut fisheye_fx = fisheye.clone();
    fisheye_fx.render.effects = real.render.effects;
    fisheye_fx.render.effects.motion.exposure_s = 0.002;
    // Meshes: the gripper over the ChArUco board (OpenCV lens), the textured cube (fisheye).
    let meshes = synthcam::dataset::MeshLibrary::new(std::path::Path::new("assets/scenes/objects"));
    let load = |text: &str| synthcam::scene::file::parse_scene_with(text, &|p: &str| meshes.load(p)).expect("scene");
    let gripper = load(include_str!("../../assets/scenes/objects/gripper_charuco.toml"));
    let cube = load(include_str!("../../assets/scenes/objects/calibration_cube.toml"));
    // Backgrounds: a clutter panorama through the fisheye, a plane image behind the gripper.
    let panorama = parse_scene(include_str!("../../assets/scenes/background/fisheye_panorama.toml")).expect("scene");
    let mut gripper_plane = gripper.clone();
    gripper_plane.background = parse_scene(include_str!("../../assets/scenes/background/plane_chessboard.toml")).expect("scene").background;
    vec![
        ("fisheye-panorama", panorama),
        ("gripper-plane", gripper_plane),
        ("gripper", gripper),
        ("cube-fisheye", cube),
        ("real-camera", real),
        ("fisheye-effects", fisheye_fx),
        ("chessboard", board),
        ("s-path", spath),
        ("fisheye", fisheye),
        ("double-sphere", ds),
        ("opencv14", opencv14),
        ("fisheye-wide", wide),
        ("charuco", charuco),
        ("aprilgrid-fisheye", aprilgrid),
    ]
}

#[test]
fn same_seed_same_bytes_across_runs() {
    for (name, scene) in scenes() {
        let a = encode_png(&renderer().render(&scene).expect("render")).expect("png");
        let b = encode_png(&renderer().render(&scene).expect("render")).expect("png");
        assert!(a == b, "{name}: two renders differ");
        let mut other = scene.clone();
        other.render.seed += 1;
        let c = encode_png(&renderer().render(&other).expect("render")).expect("png");
        if scene.render.noise_sigma > 0.0 {
            assert!(a != c, "{name}: a different seed must give different noise");
        }
    }
}

#[test]
fn vulkan_and_gl_give_identical_bytes() {
    let gl = match GpuContext::with_backend(BackendChoice::Gl) {
        Ok(ctx) => Renderer::new(ctx),
        Err(e) => panic!("GL backend (llvmpipe) unavailable: {e}"),
    };
    for (name, scene) in scenes() {
        let a = renderer().render_linear(&scene).expect("vulkan");
        let b = gl.render_linear(&scene).expect("gl");
        let pa = encode_png(&finish(&scene, &a).expect("finish")).expect("png");
        let pb = encode_png(&finish(&scene, &b).expect("finish")).expect("png");
        let differing = a.iter().zip(&b).filter(|(x, y)| x.to_bits() != y.to_bits()).count();
        let maxdiff = a.iter().zip(&b).map(|(x, y)| (x - y).abs()).fold(0.0f32, f32::max);
        if let Some(i) = a.iter().zip(&b).position(|(x, y)| (x - y).abs() == maxdiff) {
            eprintln!(
                "{name}: max float diff {maxdiff} at pixel ({}, {}): {} vs {}",
                i % scene.camera.size.width as usize,
                i / scene.camera.size.width as usize,
                a[i],
                b[i]
            );
        }
        eprintln!("{name}: {} of {} float pixels differ between {} and {}", differing, a.len(), renderer().context().describe(), gl.context().describe());
        assert!(pa == pb, "{name}: Vulkan and GL PNGs differ");
    }
}

#[test]
fn lp_num_threads_does_not_change_the_png() {
    let dir = std::env::temp_dir().join(format!("synthcam-det-{}", std::process::id()));
    std::fs::create_dir_all(&dir).expect("tmp");
    let mut outputs = Vec::new();
    for threads in ["1", "2", "0"] {
        let out = dir.join(format!("t{threads}.png"));
        let status = Command::new(bin())
            .args(["render", concat!(env!("CARGO_MANIFEST_DIR"), "/assets/scenes/chessboard_k1.toml"), "-o"])
            .arg(&out)
            .env("LP_NUM_THREADS", threads)
            .output()
            .expect("run synthcam");
        assert!(status.status.success(), "{}", String::from_utf8_lossy(&status.stderr));
        outputs.push(std::fs::read(&out).expect("png"));
    }
    assert!(outputs.windows(2).all(|w| w[0] == w[1]), "PNG bytes depend on LP_NUM_THREADS");
    let _ = std::fs::remove_dir_all(&dir);
}

#[test]
fn falls_back_to_gl_without_vulkan_and_renders_the_same_bytes() {
    let dir = std::env::temp_dir().join(format!("synthcam-gl-{}", std::process::id()));
    std::fs::create_dir_all(&dir).expect("tmp");
    let scene = concat!(env!("CARGO_MANIFEST_DIR"), "/assets/scenes/course_s_path.toml");
    let mut pngs = Vec::new();
    for (name, icd) in [("vk", None), ("gl", Some("/nonexistent/icd.json"))] {
        let out = dir.join(format!("{name}.png"));
        let mut cmd = Command::new(bin());
        cmd.args(["render", scene, "-o"]).arg(&out);
        if let Some(icd) = icd {
            cmd.env("VK_ICD_FILENAMES", icd).env("VK_DRIVER_FILES", icd);
        }
        let o = cmd.output().expect("run");
        let stderr = String::from_utf8_lossy(&o.stderr);
        assert!(o.status.success(), "{name}: {stderr}");
        if icd.is_some() {
            assert!(stderr.contains("Gl"), "expected the GL adapter without a Vulkan driver: {stderr}");
        }
        pngs.push(std::fs::read(&out).expect("png"));
    }
    assert!(pngs[0] == pngs[1], "GL fallback render differs from Vulkan");
    let _ = std::fs::remove_dir_all(&dir);
}
