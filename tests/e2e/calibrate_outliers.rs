//! `synthcam calibrate` on a detections JSON holding bad corners: they are flagged per view in
//! the JSON's `views[i].outliers` and dropped, `--keep-outliers` keeps them, and the projection
//! uncertainty map is written.

use std::process::Command;

use nalgebra::{Isometry3, Point3, Translation3, UnitQuaternion, Vector3};
use rand::{Rng, SeedableRng};
use rand_distr::{Distribution, Normal};
use synthcam::camera::CameraModel;

use crate::common::bin;

/// 12 views of a 9 x 6 board (25 mm squares) through a distorted 640 x 480 camera, noise 0.05 px;
/// 4 corners moved 2-4 px. The detections JSON (in a fresh folder named after `name`) and the
/// moved (view, point) pairs.
fn detections_with_bad_corners(name: &str) -> (std::path::PathBuf, Vec<(usize, usize)>) {
    let cam = CameraModel::pinhole(640, 480, 520.0).with_distortion([-0.25, 0.08, 0.0, 0.0, 0.0]);
    let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(12);
    let noise = Normal::new(0.0, 0.05).expect("sigma");
    let bad = [(1usize, 7usize), (4, 30), (4, 31), (9, 52)];
    let mut images = Vec::new();
    while images.len() < 12 {
        let axis = nalgebra::Unit::new_normalize(Vector3::new(rng.random_range(-1.0..1.0), rng.random_range(-1.0..1.0), 0.0));
        let rot = UnitQuaternion::from_axis_angle(&axis, rng.random_range(0.1..0.6));
        let t = Vector3::new(rng.random_range(-0.08..0.08), rng.random_range(-0.06..0.06), rng.random_range(0.35..0.55)) - rot * Vector3::new(0.1, 0.0625, 0.0);
        let pose = Isometry3::from_parts(Translation3::from(t), rot);
        let pts: Vec<[f64; 2]> = (0..54)
            .filter_map(|i| {
                let p = cam.project(&(pose * Point3::new((i % 9) as f64 * 0.025, (i / 9) as f64 * 0.025, 0.0)));
                p.visible().then(|| [p.pixel_px.x + noise.sample(&mut rng), p.pixel_px.y + noise.sample(&mut rng)])
            })
            .collect();
        if pts.len() == 54 {
            images.push(pts);
        }
    }
    for (k, &(v, i)) in bad.iter().enumerate() {
        let (len, dir) = (2.0 + 0.6 * k as f64, 1.3 * k as f64);
        images[v][i][0] += len * dir.cos();
        images[v][i][1] += len * dir.sin();
    }
    (crate::calibrate_cli::write_detections(name, &images), bad.to_vec())
}

fn calibrate(det: &std::path::Path, out: &std::path::Path, extra: &[&str]) -> serde_json::Value {
    let o = Command::new(bin())
        .arg("calibrate")
        .arg(det)
        .args(["--target", "chessboard:9x6", "--square", "0.025", "--json"])
        .arg(out)
        .args(extra)
        .output()
        .expect("run");
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    serde_json::from_slice(&std::fs::read(out).expect("json")).expect("parse")
}

#[test]
fn bad_corners_in_a_detections_json_are_flagged_and_dropped() {
    let (det, bad) = detections_with_bad_corners("outliers");
    let dir = det.parent().expect("folder").to_path_buf();
    let j = calibrate(&det, &dir.join("robust.json"), &[]);
    let flagged: Vec<(usize, usize)> = j["views"]
        .as_array()
        .expect("views")
        .iter()
        .enumerate()
        .flat_map(|(v, view)| view["outliers"].as_array().expect("outliers").iter().map(move |i| (v, i.as_u64().expect("index") as usize)))
        .collect();
    assert_eq!(flagged, bad);
    assert_eq!(j["rejection"]["dropped"], 4);
    let rms = j["rms_px"].as_f64().expect("rms");
    assert!(rms < 0.09, "{rms}");
    let kept = calibrate(&det, &dir.join("kept.json"), &["--keep-outliers"]);
    assert_eq!(kept["rejection"]["dropped"], 0);
    assert!(kept["views"].as_array().expect("views").iter().all(|v| v["outliers"].as_array().is_some_and(Vec::is_empty)));
    let rms_kept = kept["rms_px"].as_f64().expect("rms");
    assert!(rms_kept > 2.0 * rms && (rms_kept - j["rejection"]["rms_before_px"].as_f64().expect("before")).abs() < 1e-9, "{rms_kept}");
    // The map: 16 x 12 cells, worse outside the covered area than inside.
    let u = &j["projection_uncertainty"];
    assert_eq!((u["cols"].as_u64(), u["rows"].as_u64()), (Some(16), Some(12)));
    assert_eq!(u["sigma_px"].as_array().map(Vec::len), Some(12));
    let (inside, outside) = (u["worst_inside_px"].as_f64().expect("inside"), u["worst_outside_px"].as_f64().expect("outside"));
    assert!(inside > 0.0 && outside > inside, "{inside} {outside}");
    let _ = std::fs::remove_dir_all(&dir);
}

#[test]
fn nonsense_outlier_and_uncertainty_options_fail() {
    let (det, _) = detections_with_bad_corners("outliers-bad");
    let dir = det.parent().expect("folder").to_path_buf();
    for args in [
        &["--outlier-threshold", "0"][..],
        &["--outlier-threshold", "nan"],
        &["--uncertainty-grid", "0x3"],
        &["--uncertainty-range", "-1"],
        &["--keep-outliers", "--outlier-threshold", "3"],
    ] {
        let o = Command::new(bin()).arg("calibrate").arg(&det).args(["--target", "chessboard:9x6", "--square", "0.025"]).args(args).output().expect("run");
        assert!(!o.status.success(), "{args:?} accepted");
        assert!(!String::from_utf8_lossy(&o.stderr).contains("panicked"), "{args:?}");
    }
    let _ = std::fs::remove_dir_all(&dir);
}
