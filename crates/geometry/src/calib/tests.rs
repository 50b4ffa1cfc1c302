//! Calibration tests: OpenCV parity on its own corners, noise-free recovery, bad input.

use nalgebra::{Isometry3, Point2, Point3, Translation3, UnitQuaternion, Vector3};
use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;

use super::*;
use synthcam_core::camera::{Distortion, Intrinsics, Lens};

use super::testdata::board;

fn synthetic(cam: &CameraModel, n_views: usize, seed: u64) -> Vec<View> {
    synthetic_spread(cam, n_views, seed, 0.05)
}

/// Views with the board centre up to `spread_m` off the axis (0.3 m at 0.35-0.6 m: up to 40
/// degrees, what a wide-angle model needs to be observable).
pub(super) fn synthetic_spread(cam: &CameraModel, n_views: usize, seed: u64, spread_m: f64) -> Vec<View> {
    let mut rng = ChaCha8Rng::seed_from_u64(seed);
    let pts = board(8, 6, 0.03);
    let mut views = Vec::new();
    while views.len() < n_views {
        let axis = nalgebra::Unit::new_normalize(Vector3::new(rng.random_range(-1.0..1.0), rng.random_range(-1.0..1.0), rng.random_range(-0.3..0.3)));
        let rot = UnitQuaternion::from_axis_angle(&axis, rng.random_range(0.2..0.7));
        let centre = Vector3::new(0.105, 0.075, 0.0);
        let t = Vector3::new(rng.random_range(-spread_m..spread_m), rng.random_range(-spread_m..spread_m), rng.random_range(0.35..0.6)) - rot * centre;
        let pose = Isometry3::from_parts(Translation3::from(t), rot);
        let v: View = pts.iter().map(|p| (*p, cam.project(&(pose * p)))).filter(|(_, pr)| pr.visible()).map(|(p, pr)| (p, pr.pixel_px)).collect();
        if v.len() == pts.len() {
            views.push(v);
        }
    }
    views
}

fn strong_camera(skew: f64) -> CameraModel {
    CameraModel {
        size: ImageSize { width: 1280, height: 1024 },
        intrinsics: Intrinsics { fx: 1000.0, fy: 1005.0, cx: 645.0, cy: 508.0, skew },
        lens: Lens::OpenCv(Distortion::from_array([-0.25, 0.12, 1e-3, -5e-4, 0.01])),
    }
}

#[test]
fn noise_free_views_recover_the_camera_to_1e_8() {
    for (skew, estimate) in [(0.0, false), (0.8, true)] {
        let truth = strong_camera(skew);
        let views = synthetic(&truth, 12, 7);
        let r = calibrate(&views, truth.size, &CalibParams { estimate_skew: estimate, ..Default::default() }).unwrap();
        let k = r.camera.intrinsics;
        let kt = truth.intrinsics;
        for (a, b) in [(k.fx, kt.fx), (k.fy, kt.fy), (k.cx, kt.cx), (k.cy, kt.cy)] {
            assert!(((a - b) / b).abs() < 1e-8, "{a} vs {b}");
        }
        assert!((k.skew - kt.skew).abs() < 1e-6);
        for (a, b) in r.camera.distortion().to_array().iter().zip(truth.distortion().to_array()) {
            // Relative for the large coefficients, absolute 1e-10 for the small tangential ones.
            assert!((a - b).abs() <= 1e-8 * b.abs().max(1e-2), "{a} vs {b}");
        }
        assert!(r.rms_px < 1e-6, "rms {}", r.rms_px);
    }
}

#[test]
fn thousand_views_are_fast() {
    let truth = strong_camera(0.0);
    let mut views = synthetic(&truth, 1000, 3);
    let mut rng = ChaCha8Rng::seed_from_u64(4);
    for v in &mut views {
        for (_, q) in v.iter_mut() {
            *q += nalgebra::Vector2::new(rng.random_range(-0.2..0.2), rng.random_range(-0.2..0.2));
        }
    }
    let t0 = std::time::Instant::now();
    let r = calibrate(&views, truth.size, &CalibParams::default()).unwrap();
    eprintln!("1000 views x 48 points: {:.2} s, {} iterations, rms {:.4} px", t0.elapsed().as_secs_f64(), r.iterations, r.rms_px);
    assert!((r.camera.intrinsics.fx - 1000.0).abs() < 0.5);
}

#[test]
fn matches_opencv_on_its_own_corners() {
    let path = concat!(env!("CARGO_MANIFEST_DIR"), "/../../../shared/data/opencv_left/opencv_reference.json");
    let Ok(text) = std::fs::read_to_string(path) else {
        eprintln!("skipped: ../shared absent ({path})");
        return;
    };
    let j: serde_json::Value = serde_json::from_str(&text).unwrap();
    let files: Vec<String> = j["files"].as_array().unwrap().iter().map(|f| f.as_str().unwrap().to_string()).collect();
    let pts = board(9, 6, 1.0);
    let views: Vec<View> = files
        .iter()
        .map(|f| {
            let c = j["per_image"][f]["corners"]["classic"].as_array().unwrap();
            pts.iter().zip(c).map(|(p, q)| (*p, Point2::new(q[0].as_f64().unwrap(), q[1].as_f64().unwrap()))).collect()
        })
        .collect();
    let size = ImageSize { width: 640, height: 480 };
    let robust = calibrate(&views, size, &CalibParams::default()).unwrap();
    eprintln!("with outlier rejection: {:?}, rms {:.6}", robust.rejection, robust.rms_px);
    for (i, v) in robust.views.iter().enumerate() {
        let d: Vec<String> = v.outliers.iter().map(|&j| format!("{j}:{:.2}", v.residuals_px[j].norm())).collect();
        eprintln!("view {i} rms {:.3} dropped {}", v.rms_px, d.join(" "));
    }
    // OpenCV keeps every point.
    let t0 = std::time::Instant::now();
    let r = calibrate(&views, size, &CalibParams { outlier_threshold: None, ..Default::default() }).unwrap();
    let ms = t0.elapsed().as_secs_f64() * 1e3;
    let cv = &j["calibration"]["classic"];
    let kk = &cv["K"];
    let k = r.camera.intrinsics;
    let d = r.camera.distortion().to_array();
    eprintln!(
        "ours: fx {:.4} fy {:.4} cx {:.4} cy {:.4} dist {:?} rms {:.6} ({} iterations, {ms:.1} ms); std fx {:.3} k1 {:.4}",
        k.fx, k.fy, k.cx, k.cy, d, r.rms_px, r.iterations, r.std[0], r.std[5]
    );
    let cvk = [kk[0][0].as_f64().unwrap(), kk[1][1].as_f64().unwrap(), kk[0][2].as_f64().unwrap(), kk[1][2].as_f64().unwrap()];
    for (a, b) in [k.fx, k.fy, k.cx, k.cy].iter().zip(cvk) {
        assert!((a - b).abs() < 0.01, "{a} vs OpenCV {b}");
    }
    let cvd: Vec<f64> = cv["dist_k1_k2_p1_p2_k3"].as_array().unwrap().iter().map(|v| v.as_f64().unwrap()).collect();
    for (i, (a, b)) in d.iter().zip(&cvd).enumerate() {
        let tol = if i == 4 { 1e-3 } else { 1e-4 };
        assert!((a - b).abs() < tol, "coefficient {i}: {a} vs OpenCV {b}");
    }
    assert!((r.rms_px - cv["rms"].as_f64().unwrap()).abs() < 1e-4, "rms {}", r.rms_px);
    // Standard deviations: OpenCV 5.0 reports fx 0.9280, fy 0.9720, cx 0.9715, cy 1.0706, k1 0.01164.
    let cv_std: Vec<f64> = cv["std_fx_fy_cx_cy_k1_k2_p1_p2_k3"].as_array().unwrap().iter().map(|v| v.as_f64().unwrap()).collect();
    let ours = [r.std[0], r.std[1], r.std[2], r.std[3], r.std[5], r.std[6], r.std[7], r.std[8], r.std[9]];
    for (a, b) in ours.iter().zip(&cv_std) {
        assert!(((a - b) / b).abs() < 0.01, "std {a} vs OpenCV {b}");
    }
}

#[test]
fn bad_input_gives_typed_errors() {
    let truth = strong_camera(0.0);
    let views = synthetic(&truth, 4, 1);
    let size = truth.size;
    assert!(matches!(calibrate(&views[..2], size, &CalibParams::default()), Err(CalibError::TooFewViews { .. })));
    let mut nan = views.clone();
    nan[1][3].1.x = f64::NAN;
    assert!(matches!(calibrate(&nan, size, &CalibParams::default()), Err(CalibError::NonFinite { view: 1, index: 3 })));
    let mut collinear = views.clone();
    for (i, (x, _)) in collinear[0].iter_mut().enumerate() {
        *x = Point3::new(i as f64 * 0.01, 0.0, 0.0);
    }
    assert!(matches!(calibrate(&collinear, size, &CalibParams::default()), Err(CalibError::Degenerate { .. })));
    let parallel = vec![views[0].clone(); 5];
    assert!(matches!(calibrate(&parallel, size, &CalibParams::default()), Err(CalibError::Degenerate { .. })));
    let few = vec![views[0][..3].to_vec(), views[1].clone(), views[2].clone()];
    assert!(matches!(calibrate(&few, size, &CalibParams::default()), Err(CalibError::TooFewPoints { view: 0, .. })));
}

#[test]
fn every_model_recovers_its_camera_from_noise_free_views() {
    use synthcam_core::camera::{DoubleSphere, Fisheye};
    let wide = |lens| CameraModel {
        size: ImageSize { width: 1280, height: 1024 },
        intrinsics: Intrinsics { fx: 400.0, fy: 401.0, cx: 641.0, cy: 510.0, skew: 0.0 },
        lens,
    };
    let cases = [
        (
            CalibModel::OpenCv8,
            CameraModel {
                lens: Lens::OpenCv(Distortion::from_coefficients([-0.2, 0.05, 1e-3, -5e-4, 0.01, 0.1, -0.02, 0.003, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0])),
                ..strong_camera(0.0)
            },
        ),
        (CalibModel::Fisheye, wide(Lens::Fisheye(Fisheye { k: [0.05, -0.01, 0.002, -0.0005] }))),
        (CalibModel::DoubleSphere, wide(Lens::DoubleSphere(DoubleSphere { xi: -0.2, alpha: 0.6 }))),
    ];
    for (model, truth) in cases {
        let views = synthetic_spread(&truth, 12, 11, if model == CalibModel::OpenCv8 { 0.05 } else { 0.3 });
        let r = calibrate(&views, truth.size, &CalibParams { model, ..Default::default() }).unwrap_or_else(|e| panic!("{model}: {e}"));
        let (k, kt) = (r.camera.intrinsics, truth.intrinsics);
        for (a, b) in [(k.fx, kt.fx), (k.fy, kt.fy), (k.cx, kt.cx), (k.cy, kt.cy)] {
            assert!((a - b).abs() < 1e-5, "{model}: {a} vs {b}");
        }
        assert_eq!(r.camera.lens.kind(), truth.lens.kind());
        // The rational model's coefficients trade off (numerator against denominator) over the
        // radii a board covers; its projection is compared instead. The others are identifiable.
        if model != CalibModel::OpenCv8 {
            for (a, b) in r.camera.lens.params().iter().zip(truth.lens.params()) {
                assert!((a - b).abs() < 1e-6, "{model}: {a} vs {b}");
            }
        }
        for p in views.iter().flatten().map(|(_, q)| q) {
            let ray = truth.unproject(p).expect("ray");
            assert!((r.camera.project_unchecked(&Point3::from(ray)) - p).norm() < 1e-6, "{model}");
        }
        assert!(r.rms_px < 1e-6, "{model}: rms {}", r.rms_px);
    }
}

#[test]
fn a_fisheye_calibrates_from_boards_behind_its_camera_plane() {
    use synthcam_core::camera::Fisheye;
    // A 280-degree lens (reach 152 degrees); boards in front, and the same poses turned 85-115
    // degrees about the camera's y axis (many corners at z < 0).
    let truth = CameraModel {
        size: ImageSize { width: 1280, height: 1024 },
        intrinsics: Intrinsics { fx: 250.0, fy: 252.5, cx: 641.0, cy: 510.0, skew: 0.0 },
        lens: Lens::Fisheye(Fisheye { k: [0.02, -0.005, 0.001, 0.0] }),
    };
    let mut rng = ChaCha8Rng::seed_from_u64(5);
    let pts = board(8, 6, 0.03);
    let mut views = synthetic_spread(&truth, 6, 21, 0.2);
    let mut behind = 0;
    while views.len() < 14 {
        let tilt = UnitQuaternion::from_axis_angle(&Vector3::x_axis(), rng.random_range(-0.4..0.4));
        let t = Vector3::new(rng.random_range(-0.1..0.1), rng.random_range(-0.1..0.1), rng.random_range(0.3..0.5)) - tilt * Vector3::new(0.105, 0.075, 0.0);
        let yaw =
            UnitQuaternion::from_axis_angle(&Vector3::y_axis(), rng.random_range(85f64..115.0).to_radians() * if rng.random_bool(0.5) { 1.0 } else { -1.0 });
        let pose = Isometry3::from_parts(Translation3::identity(), yaw) * Isometry3::from_parts(Translation3::from(t), tilt);
        let v: View = pts.iter().map(|p| (*p, truth.project(&(pose * p)))).filter(|(_, pr)| pr.visible()).map(|(p, pr)| (p, pr.pixel_px)).collect();
        if v.len() == pts.len() {
            behind += pts.iter().filter(|p| (pose * *p).z < 0.0).count();
            views.push(v);
        }
    }
    assert!(behind >= 100, "only {behind} corners behind the camera plane");
    let r = calibrate(&views, truth.size, &CalibParams { model: CalibModel::Fisheye, ..Default::default() }).expect("calibrate");
    let (k, kt) = (r.camera.intrinsics, truth.intrinsics);
    for (a, b) in [(k.fx, kt.fx), (k.fy, kt.fy), (k.cx, kt.cx), (k.cy, kt.cy)] {
        assert!((a - b).abs() < 1e-5, "{a} vs {b}");
    }
    assert!(r.rms_px < 1e-6, "rms {}", r.rms_px);
}
