//! `synthcam detect`: JSON shape, per-file errors, overlays, and the S-path on a render.

use std::process::Command;

use crate::common::bin;

fn tmp(name: &str) -> std::path::PathBuf {
    let d = std::env::temp_dir().join(format!("synthcam-detect-{}-{name}", std::process::id()));
    std::fs::create_dir_all(&d).expect("tmp");
    d
}

/// `synthcam render` of the course's S-path scene into `dir/spath.png` (its truth beside it).
fn render_course_s_path(dir: &std::path::Path) -> std::path::PathBuf {
    let png = dir.join("spath.png");
    let o = Command::new(bin())
        .args(["render", concat!(env!("CARGO_MANIFEST_DIR"), "/assets/scenes/course_s_path.toml"), "-o"])
        .arg(&png)
        .output()
        .expect("render");
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    png
}

#[test]
fn s_path_render_is_detected_in_order_and_bad_files_are_reported() {
    let dir = tmp("spath");
    let png = render_course_s_path(&dir);
    // A truncated PNG and a text file posing as a JPEG.
    let bytes = std::fs::read(&png).expect("png");
    std::fs::write(dir.join("truncated.png"), &bytes[..bytes.len() / 3]).expect("write");
    std::fs::write(dir.join("garbage.jpg"), b"not a jpeg").expect("write");
    let json = dir.join("det.json");
    let draw = dir.join("draw");
    let o = Command::new(bin()).args(["detect"]).arg(&dir).args(["--target", "s-path", "--json"]).arg(&json).arg("--draw").arg(&draw).output().expect("detect");
    let stderr = String::from_utf8_lossy(&o.stderr);
    assert!(!o.status.success(), "unreadable files must give a non-zero exit");
    assert!(stderr.contains("truncated.png") && stderr.contains("garbage.jpg"), "{stderr}");
    let v: serde_json::Value = serde_json::from_slice(&std::fs::read(&json).expect("json")).expect("parse");
    let images = v["images"].as_array().expect("images");
    assert_eq!(images.len(), 3);
    let good = images.iter().find(|i| i["file"] == "spath.png").expect("spath entry");
    assert_eq!(good["found"], true);
    assert_eq!(good["points_px"].as_array().map(Vec::len), Some(101));
    let idx: Vec<u64> = good["indices"].as_array().expect("indices").iter().filter_map(|x| x.as_u64()).collect();
    assert_eq!(idx, (0..101).collect::<Vec<u64>>());
    // The nominal target's dots sit on the nominal path: only the beads' own centroid offsets
    // (about 1.4 px at this pose, mostly absorbed by the fit: 0.135 px RMS, 1.6 mm at most).
    let dev: Vec<f64> = good["path_deviation_mm"].as_array().expect("deviations").iter().filter_map(serde_json::Value::as_f64).collect();
    assert_eq!(dev.len(), 101);
    let rms = good["path_residual_rms_px"].as_f64().expect("rms");
    eprintln!("path residual RMS {rms:.3} px, largest apparent deviation {:.2} mm", dev.iter().fold(0.0f64, |a, b| a.max(*b)));
    assert!(rms < 0.5 && dev.iter().all(|d| *d < 3.0), "{rms} {dev:?}");
    for bad in ["truncated.png", "garbage.jpg"] {
        let e = images.iter().find(|i| i["file"] == bad).expect("entry");
        assert_eq!(e["found"], false);
        assert!(e["error"].as_str().is_some_and(|s| !s.is_empty()));
    }
    assert!(draw.join("spath.png").exists(), "overlay written");
    // Detected centres against the truth centroids (noise-free render).
    let truth: serde_json::Value = serde_json::from_slice(&std::fs::read(png.with_extension("json")).expect("truth")).expect("parse");
    let mut errs = Vec::new();
    for (p, i) in good["points_px"].as_array().expect("pts").iter().zip(&idx) {
        let c = &truth["features"][*i as usize]["centroid_px"];
        let (du, dv) = (p[0].as_f64().unwrap_or(0.0) - c[0].as_f64().unwrap_or(0.0), p[1].as_f64().unwrap_or(0.0) - c[1].as_f64().unwrap_or(0.0));
        errs.push((du * du + dv * dv).sqrt());
    }
    errs.sort_by(f64::total_cmp);
    let rms = (errs.iter().map(|e| e * e).sum::<f64>() / errs.len() as f64).sqrt();
    eprintln!("S-path beads, noise-free: RMS {rms:.4} px, median {:.4}, max {:.4}", errs[errs.len() / 2], errs[errs.len() - 1]);
    // The three dots touching the sphere's outline are the worst (up to ~0.13 px); the rest < 0.01.
    assert!(rms < 0.02, "RMS {rms}");
    assert!(errs[errs.len() - 4] < 0.015, "4th worst {}", errs[errs.len() - 4]);
    let _ = std::fs::remove_dir_all(&dir);
}

#[test]
fn bad_target_strings_are_rejected() {
    for t in ["chessboard:9", "dot-grid:3x4", "hexagon", "chessboard:0x6"] {
        let o = Command::new(bin()).args(["detect", "/nonexistent.png", "--target", t]).output().expect("run");
        assert!(!o.status.success(), "{t}");
        assert!(!String::from_utf8_lossy(&o.stderr).contains("panicked"));
    }
}

#[test]
fn images_of_different_sizes_are_each_detected() {
    let dir = tmp("sizes");
    // the same board scene at two image sizes (the second a pixel wider and taller, as a car
    // camera's odd frame): both are detected, nothing is skipped
    let scene = std::fs::read_to_string(concat!(env!("CARGO_MANIFEST_DIR"), "/assets/scenes/chessboard_k1.toml")).expect("scene");
    let bigger = scene.replacen("width = 1280", "width = 1281", 1).replacen("height = 1024", "height = 1025", 1);
    assert_ne!(bigger, scene, "the scene's size fields moved: update this test");
    for (name, text) in [("a", &scene), ("b", &bigger)] {
        std::fs::write(dir.join(format!("{name}.toml")), text).expect("write");
        let o =
            Command::new(bin()).arg("render").arg(dir.join(format!("{name}.toml"))).arg("-o").arg(dir.join(format!("{name}.png"))).output().expect("render");
        assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    }
    let json = dir.join("det.json");
    let o = Command::new(bin())
        .arg("detect")
        .arg(dir.join("a.png"))
        .arg(dir.join("b.png"))
        .args(["--target", "chessboard:11x8", "--json"])
        .arg(&json)
        .output()
        .expect("detect");
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    let v: serde_json::Value = serde_json::from_slice(&std::fs::read(&json).expect("json")).expect("parse");
    let images = v["images"].as_array().expect("images");
    assert_eq!(images.len(), 2);
    assert!(images.iter().all(|i| i["found"] == true), "{images:?}");
    assert_eq!(images[1]["width"], 1281);
    assert!(v.get("skipped").is_none());
}

/// The course camera as OpenCV's YAML, at `width` x `height`.
fn course_camera_yaml(width: u32, height: u32) -> String {
    format!(
        "%YAML:1.0\n---\nimage_width: {width}\nimage_height: {height}\ncamera_matrix: !!opencv-matrix\n   rows: 3\n   cols: 3\n   dt: d\n   data: [ 1500., 0., 640., 0., 1500., 512., 0., 0., 1. ]\ndistortion_coefficients: !!opencv-matrix\n   rows: 1\n   cols: 5\n   dt: d\n   data: [ 0., 0., 0., 0., 0. ]\n"
    )
}

#[test]
fn a_known_camera_places_the_s_path_and_bad_cameras_are_refused() {
    let dir = tmp("camera");
    let png = render_course_s_path(&dir);
    let detect = |camera: &str, target: &str| {
        let cam = dir.join("cam.yml");
        std::fs::write(&cam, camera).expect("write");
        let json = dir.join("det.json");
        let _ = std::fs::remove_file(&json);
        let o = Command::new(bin()).arg("detect").arg(&png).args(["--target", target, "--json"]).arg(&json).arg("--camera").arg(&cam).output().expect("detect");
        (o.status.success(), String::from_utf8_lossy(&o.stderr).into_owned(), std::fs::read(&json).ok())
    };
    let (ok, stderr, json) = detect(&course_camera_yaml(1280, 1024), "s-path");
    assert!(ok, "{stderr}");
    let v: serde_json::Value = serde_json::from_slice(&json.expect("json")).expect("parse");
    let idx: Vec<u64> = v["images"][0]["indices"].as_array().expect("indices").iter().filter_map(|x| x.as_u64()).collect();
    assert_eq!(idx, (0..101).collect::<Vec<u64>>());
    // Nonsense: a camera for a target that does not use it, a camera of another image size, a
    // file that is no camera. Each a clear error and a non-zero exit, no JSON written.
    for (camera, target, says) in [
        (course_camera_yaml(1280, 1024), "chessboard:9x6", "s-path only"),
        (course_camera_yaml(640, 480), "s-path", "image size"),
        ("not a camera".to_string(), "s-path", "camera file"),
    ] {
        let (ok, stderr, json) = detect(&camera, target);
        assert!(!ok && stderr.contains(says) && !stderr.contains("panicked"), "{target}: {stderr}");
        assert!(json.is_none(), "{target}: JSON written");
    }
    let _ = std::fs::remove_dir_all(&dir);
}
