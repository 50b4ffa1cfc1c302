//! `synthcam calibrate`: bad detections files fail with a typed explanation; the sweep runs.

use std::process::Command;

use synthcam::course::sweep::{run_sweep, SweepMode};

use crate::common::{bin, renderer};

/// A detections JSON of 640 x 480 images (`v{i}.png`, each found with its points) in a fresh
/// temporary folder named after `name`.
pub(crate) fn write_detections(name: &str, images: &[Vec<[f64; 2]>]) -> std::path::PathBuf {
    let dir = std::env::temp_dir().join(format!("synthcam-cal-{}-{name}", std::process::id()));
    std::fs::create_dir_all(&dir).expect("tmp");
    let v = serde_json::json!({
        "images": images.iter().enumerate().map(|(i, p)| serde_json::json!({
            "file": format!("v{i}.png"), "width": 640, "height": 480, "found": true, "points_px": p
        })).collect::<Vec<_>>()
    });
    let path = dir.join("det.json");
    std::fs::write(&path, serde_json::to_vec(&v).expect("json")).expect("write");
    path
}

/// A 4 x 3 board seen by an ideal 500 px camera under pose `k`.
fn view(k: usize) -> Vec<[f64; 2]> {
    let a = 0.15 * k as f64;
    (0..12)
        .map(|i| {
            let (x, y) = ((i % 4) as f64 * 0.03 - 0.045, (i / 4) as f64 * 0.03 - 0.03);
            let z = 0.5 + a * x;
            [320.0 + 500.0 * (x * (1.0 - 0.1 * a)) / z, 240.0 + 500.0 * (y + 0.2 * a * x) / z]
        })
        .collect()
}

fn run(path: &std::path::Path) -> (bool, String) {
    let o = Command::new(bin()).arg("calibrate").arg(path).args(["--target", "chessboard:4x3", "--square", "0.03"]).output().expect("run");
    (o.status.success(), String::from_utf8_lossy(&o.stderr).into_owned())
}

/// (case name, detected points per image, text the error must contain).
type Case = (&'static str, Vec<Vec<[f64; 2]>>, &'static str);

#[test]
fn bad_detections_fail_with_an_explanation() {
    let cases: Vec<Case> = vec![
        ("two-views", vec![view(1), view(2)], "at least 3 views"),
        ("wrong-shape", vec![view(1), view(2), view(3)[..10].to_vec()], "10 points"),
        ("collinear", vec![(0..12).map(|i| [100.0 + 10.0 * f64::from(i), 200.0]).collect(), view(2), view(3)], "degenerate"),
        ("parallel", vec![view(1), view(1), view(1), view(1)], "degenerate"),
    ];
    for (name, images, needle) in cases {
        let (ok, stderr) = run(&write_detections(name, &images));
        assert!(!ok, "{name}: succeeded");
        assert!(!stderr.contains("panicked"), "{name}: {stderr}");
        assert!(stderr.to_lowercase().contains(needle), "{name}: `{needle}` not in: {stderr}");
    }
    let dir = std::env::temp_dir().join(format!("synthcam-cal-{}-nan", std::process::id()));
    std::fs::create_dir_all(&dir).expect("tmp");
    let nan = dir.join("det.json");
    std::fs::write(&nan, r#"{"images": [{"file": "a", "width": 640, "height": 480, "found": true, "points_px": [[1, "x"]]}]}"#).expect("write");
    let (ok, stderr) = run(&nan);
    assert!(!ok && stderr.contains("not [u, v]"), "{stderr}");
}

#[test]
fn calib_sweep_runs_in_both_modes() {
    let ideal = run_sweep(SweepMode::Ideal, &[20], &[5], 20, None).expect("sweep");
    let mean = ideal.iter().map(|r| r.err_pct[0]).sum::<f64>() / ideal.len() as f64;
    eprintln!("ideal mode, M = 20, N = 5, 20 seeds: mean % error of fx {mean:.2} (seed report: about 3 %)");
    assert!(ideal.len() >= 18 && mean > 0.5 && mean < 20.0, "{} runs, mean {mean}", ideal.len());
    let rendered = run_sweep(SweepMode::Rendered, &[5], &[5], 1, Some(renderer())).expect("sweep");
    assert_eq!(rendered.len(), 1);
    eprintln!("rendered mode, M = 5, N = 5: % errors {:?}", rendered[0].err_pct);
    assert!(rendered[0].err_pct.iter().all(|e| *e < 1.0));
}

#[test]
fn calib_sweep_runs_with_any_lens_model() {
    use synthcam::calib::CalibModel;
    use synthcam::camera::{CameraModel, Fisheye, Lens};
    use synthcam::course::sweep::{run_sweep_with, SweepSetup};
    // The course's poses through a fisheye lens of the course's focal length, its four
    // coefficients estimated with the intrinsics.
    let camera = CameraModel::pinhole(1280, 1024, 1500.0).with_lens(Lens::Fisheye(Fisheye { k: [0.3, -0.1, 0.0, 0.0] }));
    let setup = SweepSetup { camera, model: Some(CalibModel::Fisheye) };
    let rendered = run_sweep_with(&setup, SweepMode::Rendered, &[8], &[5], 1, Some(renderer()), &mut |_, _| {}).expect("sweep");
    assert_eq!(rendered.len(), 1);
    eprintln!("rendered fisheye sweep, M = 8, N = 5: % errors {:?}, rms {:.4} px", rendered[0].err_pct, rendered[0].rms_px);
    assert!(rendered[0].err_pct.iter().all(|e| *e < 1.0) && rendered[0].rms_px < 0.05, "{:?}", rendered[0]);
    let bad = SweepSetup { camera: CameraModel { size: synthcam::camera::ImageSize { width: 0, height: 10 }, ..camera }, model: None };
    assert!(run_sweep_with(&bad, SweepMode::Ideal, &[5], &[5], 1, None, &mut |_, _| {}).is_err());
}

#[test]
fn images_of_another_size_are_skipped_not_fatal() {
    // Six rendered views at 640 x 480 and one at 641 x 481 (as a real set with two odd frames):
    // calibrate uses the six, lists the odd one in `skipped` with its reason, exits 0.
    let dir = std::env::temp_dir().join(format!("synthcam-cal-{}-mixed", std::process::id()));
    let _ = std::fs::remove_dir_all(&dir);
    std::fs::create_dir_all(&dir).expect("tmp");
    crate::common::write_chessboard_views(&dir);
    let json = dir.join("calib.json");
    let o = Command::new(bin()).arg("calibrate").arg(&dir).args(["--target", "chessboard:8x6", "--square", "0.03", "--json"]).arg(&json).output().expect("run");
    let stderr = String::from_utf8_lossy(&o.stderr);
    assert!(o.status.success(), "exit {:?}: {stderr}", o.status);
    assert!(stderr.contains("warning: skipping v6.png"), "{stderr}");
    let v: serde_json::Value = serde_json::from_slice(&std::fs::read(&json).expect("json")).expect("parse");
    assert_eq!(v["used"], 6, "{v}");
    let skipped = v["skipped"].as_array().expect("skipped");
    assert_eq!(skipped.len(), 1, "{skipped:?}");
    assert_eq!(skipped[0]["file"], "v6.png");
    assert!(skipped[0]["reason"].as_str().is_some_and(|r| r.contains("641x481") && r.contains("640x480")), "{skipped:?}");
    assert!((v["K"][0][0].as_f64().expect("fx") - 600.0).abs() < 1.0, "fx {}", v["K"][0][0]);
}

/// OpenCV reads the YAML back (`cv2.FileStorage`), when Python has OpenCV (CI installs it);
/// otherwise says that it skipped.
fn opencv_reads(yaml: &std::path::Path) -> Option<Vec<f64>> {
    let script = "import sys, cv2\nfs = cv2.FileStorage(sys.argv[1], cv2.FILE_STORAGE_READ)\nk = fs.getNode('camera_matrix').mat()\nd = fs.getNode('distortion_coefficients').mat()\nprint(' '.join(repr(float(v)) for v in list(k.ravel()) + list(d.ravel())))";
    let o = Command::new("python3").arg("-c").arg(script).arg(yaml).output().ok()?;
    if !o.status.success() {
        eprintln!("skipped: OpenCV read-back (python3 -c 'import cv2' failed: {})", String::from_utf8_lossy(&o.stderr).lines().last().unwrap_or(""));
        return None;
    }
    Some(String::from_utf8_lossy(&o.stdout).split_whitespace().filter_map(|v| v.parse().ok()).collect())
}

#[test]
fn fisheye_renders_calibrate_with_their_model_and_export_for_other_tools() {
    let dir = std::env::temp_dir().join(format!("synthcam-cal-{}-fisheye", std::process::id()));
    let _ = std::fs::remove_dir_all(&dir);
    std::fs::create_dir_all(&dir).expect("tmp");
    let spec = "version = 1\ncount = 10\nseed = 3\n[camera]\nwidth = 640\nheight = 512\nfx = 200.0\nfy = 201.0\ncx = 319.5\ncy = 255.5\nmodel = \"fisheye\"\ndist = [0.05, -0.01, 0.002, -0.0005]\n[target]\nkind = \"chessboard\"\nsquares = [9, 7]\nsquare_m = 0.04\n[render]\nnoise_sigma = 1.0\n[poses]\nmode = \"board\"\ndistance_m = [0.25, 0.5]\ntilt_deg = [0.0, 40.0]\nroll_deg = [-180.0, 180.0]\noffset_x_m = [-0.3, 0.3]\noffset_y_m = [-0.25, 0.25]\nmargin_px = 8.0\n";
    std::fs::write(dir.join("spec.toml"), spec).expect("spec");
    let ok = |args: &[&std::ffi::OsStr]| {
        let o = Command::new(bin()).args(args).output().expect("run");
        assert!(o.status.success(), "{args:?}: {}", String::from_utf8_lossy(&o.stderr));
    };
    let p = |s: &str| dir.join(s).into_os_string();
    ok(&["dataset".as_ref(), &p("spec.toml"), "-o".as_ref(), &p("ds")]);
    ok(&["detect".as_ref(), &p("ds/images"), "--target".as_ref(), "chessboard:8x6".as_ref(), "--json".as_ref(), &p("det.json")]);
    let cal = |extra: &[&str]| {
        Command::new(bin())
            .arg("calibrate")
            .arg(p("det.json"))
            .args(["--target", "chessboard:8x6", "--square", "0.04", "--model", "fisheye"])
            .args(extra)
            .output()
            .expect("run")
    };
    let files = ["cal.json", "cv.yaml", "ros.yaml", "kalibr.yaml"].map(|f| dir.join(f).to_string_lossy().into_owned());
    let o = cal(&["--json", &files[0], "--opencv-yaml", &files[1], "--ros-yaml", &files[2], "--kalibr-yaml", &files[3]]);
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    let r: serde_json::Value = serde_json::from_slice(&std::fs::read(&files[0]).expect("json")).expect("parse");
    assert_eq!(r["model"], "fisheye");
    assert_eq!(r["dist"].as_array().map(Vec::len), Some(4));
    let k = &r["K"];
    let fx = k[0][0].as_f64().expect("fx");
    // 10 views, noise 1: the issue's 0.3 px bound on fx, fy, cx, cy.
    for (got, truth) in [(fx, 200.0), (k[1][1].as_f64().expect("fy"), 201.0), (k[0][2].as_f64().expect("cx"), 319.5), (k[1][2].as_f64().expect("cy"), 255.5)] {
        assert!((got - truth).abs() < 0.3, "{got} vs {truth}");
    }
    for f in &files[1..] {
        let cam = synthcam::camera::formats::read(&std::fs::read_to_string(f).expect("read")).expect("our reader");
        assert_eq!(cam.lens.kind().name(), "fisheye", "{f}");
        assert!((cam.intrinsics.fx - fx).abs() < 1e-9, "{f}");
    }
    if let Some(v) = opencv_reads(std::path::Path::new(&files[1])) {
        assert_eq!(v.len(), 13, "{v:?}");
        assert!((v[0] - fx).abs() < 1e-9 && (v[9] - r["dist"][0].as_f64().expect("k1")).abs() < 1e-12, "{v:?}");
    }
    // Cross-validation (5 folds of 2 views): the fisheye model holds out near its fit, the
    // 5-coefficient pinhole model does not; 1 fold is a bad option, and nothing is written.
    let cv = |model: &str, folds: &str| {
        let out = dir.join(format!("cv-{model}-{folds}.json"));
        let o = Command::new(bin())
            .arg("calibrate")
            .arg(p("det.json"))
            .args(["--target", "chessboard:8x6", "--square", "0.04", "--model", model, "--cross-validate", folds, "--json"])
            .arg(&out)
            .output()
            .expect("run");
        (o, out)
    };
    let held_out = |model: &str| {
        let (o, out) = cv(model, "5");
        assert!(o.status.success(), "{model}: {}", String::from_utf8_lossy(&o.stderr));
        let v: serde_json::Value = serde_json::from_slice(&std::fs::read(out).expect("json")).expect("parse");
        let c = &v["cross_validation"];
        assert_eq!(c["folds"], 5);
        assert!(c["per_fold"].as_array().is_some_and(|f| f.len() == 5 && f.iter().all(|f| f["held_out"].as_array().map(Vec::len) == Some(2))), "{c}");
        (c["held_out_rms_px"].as_f64().expect("held out"), v["rms_px"].as_f64().expect("rms"))
    };
    let (fisheye, fit) = held_out("fisheye");
    let (pinhole, pinhole_fit) = held_out("opencv5");
    eprintln!("cross-validation, 10 fisheye renders: fisheye held-out {fisheye:.4} px (fit {fit:.4}), opencv5 {pinhole:.4} (fit {pinhole_fit:.4})");
    assert!(fisheye < 1.5 * fit && pinhole > 2.0 * fisheye, "fisheye {fisheye} (fit {fit}), opencv5 {pinhole}");
    let (o, out) = cv("fisheye", "1");
    assert!(!o.status.success() && String::from_utf8_lossy(&o.stderr).contains("bad option"), "{}", String::from_utf8_lossy(&o.stderr));
    assert!(!out.exists());
    // mrcal has no fisheye model: an error naming it, and no output at all.
    let json2 = dir.join("cal2.json").to_string_lossy().into_owned();
    let o = cal(&["--json", &json2, "--mrcal", &dir.join("m.cameramodel").to_string_lossy()]);
    assert!(!o.status.success());
    assert!(String::from_utf8_lossy(&o.stderr).contains("mrcal"), "{}", String::from_utf8_lossy(&o.stderr));
    assert!(!dir.join("cal2.json").exists() && !dir.join("m.cameramodel").exists());
}

/// Coded boards through the command line (issue 17): `dataset` renders partial ChArUco views,
/// `detect` writes each point's id, `calibrate` reads them back by id; bad target strings and
/// views with too few points are explained, not fatal.
#[test]
fn charuco_partial_views_detect_and_calibrate_by_id() {
    let dir = std::env::temp_dir().join(format!("synthcam-charuco-cli-{}", std::process::id()));
    let _ = std::fs::remove_dir_all(&dir);
    let spec = concat!(env!("CARGO_MANIFEST_DIR"), "/assets/specs/charuco_partial_1280.toml");
    let o = Command::new(bin()).arg("dataset").arg(spec).arg("-o").arg(&dir).output().expect("run");
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    let target = "charuco:11x8:DICT_5X5_100:0.733";
    let det = dir.join("det.json");
    let o = Command::new(bin()).arg("detect").arg(dir.join("images")).args(["--target", target, "--json"]).arg(&det).output().expect("run");
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    let v: serde_json::Value = serde_json::from_slice(&std::fs::read(&det).expect("json")).expect("parses");
    assert_eq!(v["target"]["kind"], "charuco");
    for im in v["images"].as_array().expect("images") {
        let (ids, pts) = (im["ids"].as_array().expect("ids"), im["points_px"].as_array().expect("points"));
        assert!(ids.len() == pts.len() && ids.len() > 20 && ids.len() < 70, "{}: {} ids", im["file"], ids.len());
    }
    // A view reduced to 5 points is skipped with its reason; the others calibrate.
    let mut v2 = v.clone();
    v2["images"][0]["ids"] = serde_json::json!(v["images"][0]["ids"].as_array().expect("ids")[..5]);
    v2["images"][0]["points_px"] = serde_json::json!(v["images"][0]["points_px"].as_array().expect("points")[..5]);
    let det2 = dir.join("det2.json");
    std::fs::write(&det2, serde_json::to_vec(&v2).expect("json")).expect("write");
    let cal = dir.join("cal.json");
    let o = Command::new(bin()).arg("calibrate").arg(&det2).args(["--target", target, "--square", "0.04", "--json"]).arg(&cal).output().expect("run");
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    let c: serde_json::Value = serde_json::from_slice(&std::fs::read(&cal).expect("json")).expect("parses");
    assert_eq!(c["used"], 5);
    assert!(c["skipped"][0]["reason"].as_str().expect("reason").contains("only 5 points"), "{}", c["skipped"]);
    let k = &c["K"];
    let err = [
        k[0][0].as_f64().expect("fx") - 1500.0,
        k[1][1].as_f64().expect("fy") - 1500.0,
        k[0][2].as_f64().expect("cx") - 639.5,
        k[1][2].as_f64().expect("cy") - 511.5,
    ];
    assert!(err.iter().all(|e| e.abs() < 0.3), "{err:?}");
    for bad in ["charuco:11x8:DICT_5X5_100", "charuco:11x8:DICT_9X9_1:0.7", "aprilgrid:6x6:tag36h11:2.0", "charuco:11x8:DICT_5X5_100:0.7:upside-down"] {
        let o = Command::new(bin()).arg("detect").arg(dir.join("images")).args(["--target", bad]).output().expect("run");
        assert!(!o.status.success() && String::from_utf8_lossy(&o.stderr).contains("--target"), "{bad}: {}", String::from_utf8_lossy(&o.stderr));
    }
    let _ = std::fs::remove_dir_all(&dir);
}
