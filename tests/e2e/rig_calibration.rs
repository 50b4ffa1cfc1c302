//! `calibrate --rig` on rendered stereo views (issue 40's acceptance scene): two 1280 x 1024
//! pinholes, 12 cm baseline, 2 degrees of toe-in, 20 synchronised views with noise sigma 1; each
//! camera's images in its own folder, frames matched by file name. The extrinsics against the truth.

use std::process::Command;

use nalgebra::{Isometry3, Translation3, UnitQuaternion, Vector3};
use rand::{Rng, SeedableRng};

use crate::common::{bin, camera, chessboard_scene, renderer};

#[test]
fn a_rendered_stereo_rig_calibrates_to_its_true_baseline() {
    let dir = std::env::temp_dir().join(format!("synthcam-rig-{}", std::process::id()));
    let (left, right) = (dir.join("left"), dir.join("right"));
    std::fs::create_dir_all(&left).expect("tmp");
    std::fs::create_dir_all(&right).expect("tmp");
    let cam0_from_cam1 = Isometry3::from_parts(Translation3::new(0.12, 0.0, 0.0), UnitQuaternion::from_axis_angle(&Vector3::y_axis(), -2f64.to_radians()));
    let (c0, c1) = (camera(1280, 1024, 1100.0, [-0.15, 0.05, 0.0, 0.0, 0.0]), camera(1280, 1024, 1120.0, [-0.1, 0.03, 0.0, 0.0, 0.0]));
    let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(40);
    let mut written = 0;
    while written < 20 {
        let mut s0 = chessboard_scene(
            c0,
            [9, 7],
            0.03,
            rng.random_range(-35.0..35.0),
            rng.random_range(0.45..0.7),
            [rng.random_range(-0.02..0.14), rng.random_range(-0.08..0.08)],
        );
        let roll = UnitQuaternion::from_axis_angle(&Vector3::y_axis(), rng.random_range(-0.4..0.4));
        s0.cam_from_target = Isometry3::from_parts(s0.cam_from_target.translation, roll * s0.cam_from_target.rotation);
        s0.render.noise_sigma = 1.0;
        s0.render.seed = rng.random_range(0..u64::MAX);
        let mut s1 = s0.clone();
        s1.camera = c1;
        s1.cam_from_target = cam0_from_cam1.inverse() * s0.cam_from_target;
        s1.render.seed = rng.random_range(0..u64::MAX);
        let (Ok((i0, t0)), Ok((i1, t1))) = (renderer().render_with_truth(&s0), renderer().render_with_truth(&s1)) else { continue };
        if !(t0.features.iter().all(|f| f.visible) && t1.features.iter().all(|f| f.visible)) {
            continue;
        }
        let name = format!("{written:03}.png");
        std::fs::write(left.join(&name), synthcam::dataset::encode_png(&i0).expect("png")).expect("write");
        std::fs::write(right.join(&name), synthcam::dataset::encode_png(&i1).expect("png")).expect("write");
        written += 1;
    }
    let (json, camchain) = (dir.join("rig.json"), dir.join("camchain.yaml"));
    let o = Command::new(bin())
        .args(["calibrate", "--rig"])
        .arg(&left)
        .arg(&right)
        .args(["--target", "chessboard:8x6", "--square", "0.03", "--model", "opencv4", "--json"])
        .arg(&json)
        .arg("--kalibr-yaml")
        .arg(&camchain)
        .output()
        .expect("run");
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    let chain = std::fs::read_to_string(&camchain).expect("camchain");
    assert!(chain.contains("cam0:\n  camera_model: pinhole") && chain.contains("cam1:\n  T_cn_cnm1:") && chain.contains("distortion_model: radtan"), "{chain}");
    let j: serde_json::Value = serde_json::from_slice(&std::fs::read(&json).expect("json")).expect("parse");
    let cams = j["cameras"].as_array().expect("cameras");
    assert_eq!((cams.len(), cams[0]["name"].as_str(), cams[1]["name"].as_str()), (2, Some("left"), Some("right")));
    let t: Vec<f64> = cams[1]["cam0_from_cam"]["t_m"].as_array().expect("t").iter().map(|v| v.as_f64().expect("number")).collect();
    let r: Vec<Vec<f64>> = cams[1]["cam0_from_cam"]["R"]
        .as_array()
        .expect("R")
        .iter()
        .map(|row| row.as_array().expect("row").iter().map(|v| v.as_f64().expect("n")).collect())
        .collect();
    let dt = (Vector3::new(t[0], t[1], t[2]) - cam0_from_cam1.translation.vector).norm();
    let est = nalgebra::Rotation3::from_matrix_unchecked(nalgebra::Matrix3::from_fn(|i, k| r[i][k]));
    let dr = (est.inverse() * cam0_from_cam1.rotation.to_rotation_matrix()).angle().to_degrees();
    let fx1 = cams[1]["K"][0][0].as_f64().expect("fx");
    eprintln!("rig from renders: baseline error {:.4} mm, rotation {:.5} deg, right fx {fx1:.3} (1120), rms {:.4} px", dt * 1e3, dr, j["rms_px"]);
    assert!(dt <= 5e-5 && dr <= 0.002, "{} mm, {dr} deg", dt * 1e3);
    let (rows_mean, rows_max) = (j["rectified_row_error_mean_px"].as_f64().expect("mean"), j["rectified_row_error_max_px"].as_f64().expect("max"));
    eprintln!("rectified rows: mean {rows_mean:.4} px, max {rows_max:.4} px");
    assert!(rows_mean <= 0.02, "{rows_mean}");
    assert!((fx1 - 1120.0).abs() < 0.5);
    // A missing camera folder is a clear error.
    let o = Command::new(bin())
        .args(["calibrate", "--rig"])
        .arg(&left)
        .arg(dir.join("nope"))
        .args(["--target", "chessboard:8x6", "--square", "0.03"])
        .output()
        .expect("run");
    assert!(!o.status.success() && !String::from_utf8_lossy(&o.stderr).contains("panicked"));
    let _ = std::fs::remove_dir_all(&dir);
}
