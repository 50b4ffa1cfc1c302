//! Rigs end to end (issue 40's acceptance scene, `assets/specs/stereo_rig_1280.toml`): two
//! 1280 x 1024 pinholes, 12 cm baseline, 2 degrees of toe-in, 20 synchronised frames with noise
//! sigma 1, rendered by `synthcam dataset` into `images/left/` and `images/right/`; `calibrate
//! --rig` on the two folders against the spec's truth; every file rig users load written and
//! read back by its fields (OpenCV's stereo YAML by OpenCV itself, recomputing `stereoRectify`).

use std::path::Path;
use std::process::Command;

use nalgebra::{Isometry3, Translation3, UnitQuaternion, Vector3};

use crate::common::bin;

fn run(args: &[&std::ffi::OsStr]) -> std::process::Output {
    Command::new(bin()).args(args).env("NODEVICE_SELECT", "1").output().expect("run")
}

fn numbers(v: &serde_json::Value) -> Vec<f64> {
    match v {
        serde_json::Value::Array(a) => a.iter().flat_map(numbers).collect(),
        v => v.as_f64().into_iter().collect(),
    }
}

/// OpenCV reads the stereo YAML and recomputes `stereoRectify` from its K1 D1 K2 D2 R T: the
/// largest difference from the file's R1 R2 P1 P2 Q, or None (said) without Python's OpenCV.
fn opencv_rectify_difference(yaml: &Path) -> Option<f64> {
    let script = "import sys, cv2, numpy as np\nfs = cv2.FileStorage(sys.argv[1], cv2.FILE_STORAGE_READ)\ng = lambda n: fs.getNode(n).mat()\nsize = (int(fs.getNode('image_width').real()), int(fs.getNode('image_height').real()))\nr = cv2.stereoRectify(g('K1'), g('D1'), g('K2'), g('D2'), size, g('R'), g('T'))\nprint(max(float(np.abs(m - g(n)).max()) for m, n in zip(r[:5], ['R1', 'R2', 'P1', 'P2', 'Q'])))";
    let o = Command::new("python3").arg("-c").arg(script).arg(yaml).output().ok()?;
    if !o.status.success() {
        eprintln!("skipped: OpenCV stereoRectify check (python3 with cv2 failed: {})", String::from_utf8_lossy(&o.stderr).lines().last().unwrap_or(""));
        return None;
    }
    String::from_utf8_lossy(&o.stdout).trim().parse().ok()
}

#[test]
fn a_rendered_stereo_rig_dataset_calibrates_to_its_true_baseline_and_exports() {
    let dir = std::env::temp_dir().join(format!("synthcam-rig-{}", std::process::id()));
    let _ = std::fs::remove_dir_all(&dir);
    let p = |s: &str| dir.join(s).into_os_string();
    let spec = Path::new(env!("CARGO_MANIFEST_DIR")).join("assets/specs/stereo_rig_1280.toml");
    let o = run(&["dataset".as_ref(), spec.as_os_str(), "-o".as_ref(), &p("ds")]);
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    let manifest = std::fs::read_to_string(dir.join("ds/manifest.jsonl")).expect("manifest");
    let first: serde_json::Value = serde_json::from_str(manifest.lines().next().expect("a line")).expect("json");
    assert_eq!((manifest.lines().count(), first["cameras"][1]["file"].as_str()), (20, Some("images/right/000000.png")));
    let calibrate = |extra: &[&str]| {
        let mut args: Vec<std::ffi::OsString> = vec!["calibrate".into(), "--rig".into(), p("ds/images/left"), p("ds/images/right")];
        args.extend(["--target", "chessboard:8x6", "--square", "0.03"].map(Into::into));
        args.extend(extra.iter().map(Into::into));
        run(&args.iter().map(|a| a.as_os_str()).collect::<Vec<_>>())
    };
    let f = |s: &str| dir.join(s).to_string_lossy().into_owned();
    let o = calibrate(&[
        "--model",
        "opencv4",
        "--json",
        &f("rig.json"),
        "--kalibr-yaml",
        &f("camchain.yaml"),
        "--opencv-yaml",
        &f("stereo.yaml"),
        "--ros-yaml",
        &f("ros.yaml"),
        "--mrcal",
        &f("cam.cameramodel"),
    ]);
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    let j: serde_json::Value = serde_json::from_slice(&std::fs::read(dir.join("rig.json")).expect("json")).expect("parse");
    let cams = j["cameras"].as_array().expect("cameras");
    assert_eq!((cams.len(), cams[0]["name"].as_str(), cams[1]["name"].as_str()), (2, Some("left"), Some("right")));
    // The spec's truth: rig_from_right = (rvec [0, -2 deg, 0], t [0.12, 0, 0]), left = rig.
    let cam0_from_cam1 = Isometry3::from_parts(Translation3::new(0.12, 0.0, 0.0), UnitQuaternion::from_axis_angle(&Vector3::y_axis(), -2f64.to_radians()));
    let t = numbers(&cams[1]["cam0_from_cam"]["t_m"]);
    let r = numbers(&cams[1]["cam0_from_cam"]["R"]);
    let dt = (Vector3::new(t[0], t[1], t[2]) - cam0_from_cam1.translation.vector).norm();
    let est = nalgebra::Rotation3::from_matrix_unchecked(nalgebra::Matrix3::from_row_slice(&r));
    let dr = (est.inverse() * cam0_from_cam1.rotation.to_rotation_matrix()).angle().to_degrees();
    let fx1 = cams[1]["K"][0][0].as_f64().expect("fx");
    eprintln!("rig from renders: baseline error {:.4} mm, rotation {:.5} deg, right fx {fx1:.3} (1120), rms {:.4} px", dt * 1e3, dr, j["rms_px"]);
    assert!(dt <= 5e-5 && dr <= 0.002, "{} mm, {dr} deg", dt * 1e3);
    let (rows_mean, rows_max) = (j["rectified_row_error_mean_px"].as_f64().expect("mean"), j["rectified_row_error_max_px"].as_f64().expect("max"));
    eprintln!("rectified rows: mean {rows_mean:.4} px, max {rows_max:.4} px");
    assert!(rows_mean <= 0.02, "{rows_mean}");
    assert!((fx1 - 1120.0).abs() < 0.5);
    check_exports(&dir, &j);
    check_bad_rig_inputs(&dir, &calibrate);
    let _ = std::fs::remove_dir_all(&dir);
}

/// Kalibr's camchain, ROS's pair, mrcal's models and OpenCV's stereo file, each by its fields.
fn check_exports(dir: &Path, j: &serde_json::Value) {
    let chain = std::fs::read_to_string(dir.join("camchain.yaml")).expect("camchain");
    assert!(chain.contains("cam0:\n  camera_model: pinhole") && chain.contains("cam1:\n  T_cn_cnm1:") && chain.contains("distortion_model: radtan"), "{chain}");
    // T_cn_cnm1 = right_from_left: its translation is -R^T t of rig_from_right.
    let tx: f64 =
        chain.lines().find(|l| l.starts_with("  - [")).and_then(|l| l.trim_end_matches(']').split(", ").nth(3)).and_then(|v| v.parse().ok()).expect("T row 0");
    assert!((tx + 0.12 * 2f64.to_radians().cos()).abs() < 1e-4, "{tx}");
    let right = std::fs::read_to_string(dir.join("ros.right.yaml")).expect("ros right");
    assert!(right.contains("camera_name: right") && right.contains("rectification_matrix:") && std::fs::metadata(dir.join("ros.left.yaml")).is_ok(), "{right}");
    // ROS's P of the right camera: -fx' * baseline in P[0][3].
    let p_row: Vec<f64> = right
        .split("projection_matrix:")
        .nth(1)
        .and_then(|s| s.split("data: [").nth(1))
        .map(|s| s.split(']').next().unwrap_or("").split(", ").filter_map(|v| v.parse().ok()).collect())
        .expect("P");
    assert!((p_row[3] / p_row[0] + 0.12).abs() < 1e-3, "{p_row:?}");
    let model = std::fs::read_to_string(dir.join("cam.right.cameramodel")).expect("mrcal");
    let extrinsics: Vec<f64> = model
        .split("'extrinsics': [")
        .nth(1)
        .map(|s| s.split(']').next().unwrap_or("").split(", ").filter_map(|v| v.trim().parse().ok()).collect())
        .expect("extrinsics");
    assert!((extrinsics[1] - 2f64.to_radians()).abs() < 1e-4 && (extrinsics[3] + 0.12 * 2f64.to_radians().cos()).abs() < 1e-4, "{extrinsics:?}");
    let stereo = std::fs::read_to_string(dir.join("stereo.yaml")).expect("stereo");
    for name in ["K1:", "D1:", "K2:", "D2:", "R:", "T:", "E:", "F:", "R1:", "R2:", "P1:", "P2:", "Q:"] {
        assert!(stereo.contains(&format!("\n{name} !!opencv-matrix")), "{name} missing");
    }
    assert!(stereo.contains(&format!("rms: {:.12e}", j["rms_px"].as_f64().expect("rms"))));
    if let Some(d) = opencv_rectify_difference(&dir.join("stereo.yaml")) {
        eprintln!("OpenCV's stereoRectify from the file's K D R T differs from its R1 R2 P1 P2 Q by {d:.2e}");
        assert!(d < 1e-3, "{d}");
    }
}

/// A missing camera folder, two cameras of one name, a model count that is not the cameras', a format that cannot hold a
/// mixed pair (nothing written), and a camera that lacks one frame's image (that frame counts as
/// not seen by it, said on stderr).
fn check_bad_rig_inputs(dir: &Path, calibrate: &dyn Fn(&[&str]) -> std::process::Output) {
    let o = run(&[
        "calibrate".as_ref(),
        "--rig".as_ref(),
        dir.join("ds/images/left").as_os_str(),
        dir.join("nope").as_os_str(),
        "--target".as_ref(),
        "chessboard:8x6".as_ref(),
        "--square".as_ref(),
        "0.03".as_ref(),
    ]);
    assert!(!o.status.success() && !String::from_utf8_lossy(&o.stderr).contains("panicked"));
    let left = dir.join("ds/images/left");
    let o = run(&[
        "calibrate".as_ref(),
        "--rig".as_ref(),
        left.as_os_str(),
        left.as_os_str(),
        "--target".as_ref(),
        "chessboard:8x6".as_ref(),
        "--square".as_ref(),
        "0.03".as_ref(),
    ]);
    assert!(!o.status.success() && String::from_utf8_lossy(&o.stderr).contains("two cameras are named \"left\""), "{}", String::from_utf8_lossy(&o.stderr));
    let o = calibrate(&["--model", "opencv4,opencv5,opencv8"]);
    assert!(!o.status.success() && String::from_utf8_lossy(&o.stderr).contains("one per camera"), "{}", String::from_utf8_lossy(&o.stderr));
    let mixed = dir.join("mixed.yaml");
    let o = calibrate(&["--model", "fisheye,opencv4", "--opencv-yaml", &mixed.to_string_lossy()]);
    let stderr = String::from_utf8_lossy(&o.stderr);
    assert!(!o.status.success() && stderr.contains("one model for both") && !mixed.exists(), "{stderr}");
    std::fs::remove_file(dir.join("ds/images/right/000003.png")).expect("remove");
    let o = calibrate(&["--model", "opencv4"]);
    let stderr = String::from_utf8_lossy(&o.stderr);
    assert!(o.status.success() && stderr.contains("right: no board in 1 of the 20 frames"), "{stderr}");
}

/// The mixed rig (`assets/specs/mixed_rig_1280.toml`, 16 frames): a fisheye and a pinhole 10 cm
/// apart, turned 15 degrees, views that overlap in part (some frames seen by the fisheye alone);
/// calibrated with a model per camera; the Kalibr camchain read back by its fields
/// (`camera::formats::read_camchain`) holds the extrinsics within issue 40's 0.1 mm / 0.005 deg.
#[test]
fn a_mixed_fisheye_and_pinhole_rig_calibrates_from_partly_overlapping_views() {
    let dir = std::env::temp_dir().join(format!("synthcam-mixed-rig-{}", std::process::id()));
    let _ = std::fs::remove_dir_all(&dir);
    std::fs::create_dir_all(&dir).expect("tmp");
    let spec = std::fs::read_to_string(Path::new(env!("CARGO_MANIFEST_DIR")).join("assets/specs/mixed_rig_1280.toml"))
        .expect("spec")
        .replace("count = 40", "count = 16");
    std::fs::write(dir.join("spec.toml"), spec).expect("write");
    let p = |s: &str| dir.join(s).into_os_string();
    let o = run(&["dataset".as_ref(), &p("spec.toml"), "-o".as_ref(), &p("ds")]);
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    let mut args: Vec<std::ffi::OsString> = vec!["calibrate".into(), "--rig".into(), p("ds/images/fisheye"), p("ds/images/pinhole")];
    args.extend(["--target", "chessboard:8x6", "--square", "0.03", "--model", "fisheye,opencv4", "--json"].map(Into::into));
    args.extend([p("rig.json"), "--kalibr-yaml".into(), p("camchain.yaml")]);
    let o = run(&args.iter().map(|a| a.as_os_str()).collect::<Vec<_>>());
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    let j: serde_json::Value = serde_json::from_slice(&std::fs::read(dir.join("rig.json")).expect("json")).expect("parse");
    let views: Vec<u64> = j["cameras"].as_array().expect("cameras").iter().map(|c| c["views"].as_u64().expect("views")).collect();
    assert!(views[0] > views[1] && views[1] >= 4, "frames seen: {views:?}");
    let chain = synthcam::camera::formats::read_camchain(&std::fs::read_to_string(dir.join("camchain.yaml")).expect("camchain")).expect("read back");
    assert!(matches!(chain[0].0.lens, synthcam::camera::Lens::Fisheye(_)) && matches!(chain[1].0.lens, synthcam::camera::Lens::OpenCv(_)));
    let truth = Isometry3::from_parts(Translation3::new(0.1, 0.0, 0.0), UnitQuaternion::from_axis_angle(&Vector3::y_axis(), 15f64.to_radians()));
    let est = chain[1].1;
    let dt_mm = (est.translation.vector - truth.translation.vector).norm() * 1e3;
    let dr_deg = (est.rotation.inverse() * truth.rotation).angle().to_degrees();
    eprintln!("mixed rig: frames seen {views:?}; cam0_from_cam1 from the camchain: {dt_mm:.4} mm, {dr_deg:.5} deg off the truth");
    assert!(dt_mm <= 0.1 && dr_deg <= 0.005, "{dt_mm} mm, {dr_deg} deg");
    let _ = std::fs::remove_dir_all(&dir);
}
