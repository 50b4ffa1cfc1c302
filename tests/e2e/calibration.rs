//! Calibration on rendered and detected pixels: 20 views of an 8 x 6 inner-corner board,
//! 1280 x 1024, f = 1000 px, k1 = -0.25, k2 = 0.12, noise sigma 1, tilts 10-45 degrees.
//! Issue targets: fx, fy, cx, cy within 0.3 px of the truth; RMS within 20 % of the detector's
//! own error level.

use nalgebra::{Isometry3, Point2, Point3, Translation3, UnitQuaternion, Vector3};
use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;
use synthcam::calib::{calibrate, CalibParams, View};
use synthcam::detect::{find_chessboard, ChessboardParams, ImageF32};
use synthcam::scene::truth::truth_labels;

use crate::chessboard_accuracy::{nn_errors, rms};
use crate::common::{camera, chessboard_scene, renderer};

#[test]
fn calibration_from_rendered_and_detected_corners() {
    let truth_cam = camera(1280, 1024, 1000.0, [-0.25, 0.12, 0.0, 0.0, 0.0]);
    let mut rng = ChaCha8Rng::seed_from_u64(21);
    let square = 0.025;
    let (mut views, mut det_errs) = (Vec::<View>::new(), Vec::new());
    while views.len() < 20 {
        let axis = nalgebra::Unit::new_normalize(Vector3::new(rng.random_range(-1.0..1.0), rng.random_range(-1.0..1.0), 0.0));
        let rot = UnitQuaternion::from_axis_angle(&Vector3::z_axis(), rng.random_range(-0.3..0.3))
            * UnitQuaternion::from_axis_angle(&axis, rng.random_range(10f64..45.0).to_radians());
        let mut scene = chessboard_scene(truth_cam, [9, 7], square, 0.0, 0.5, [0.0, 0.0]);
        let centre = Vector3::new(4.5 * square, 3.5 * square, 0.0);
        let offset = Vector3::new(rng.random_range(-0.08..0.08), rng.random_range(-0.06..0.06), rng.random_range(0.35..0.55));
        scene.cam_from_target = Isometry3::from_parts(Translation3::from(offset - rot * centre), rot);
        scene.render.noise_sigma = 1.0;
        scene.render.seed = views.len() as u64;
        let truth = truth_labels(&scene);
        if !truth.features.iter().all(|f| f.visible) {
            continue;
        }
        let img = renderer().render(&scene).expect("render");
        let img = ImageF32::from_u8(1280, 1024, &img.to_u8()).expect("image");
        let Some(b) = find_chessboard(&img, &ChessboardParams::new(8, 6)).expect("valid") else { continue };
        // Label the detected corners with the truth's board points (order-agnostic matching).
        let mut view = View::new();
        for f in &truth.features {
            let t = Point2::from(f.pixel_px);
            let p = b.points_px.iter().min_by(|a, c| (*a - t).norm().total_cmp(&(*c - t).norm())).copied().unwrap_or(t);
            view.push((Point3::from(f.point_target_m), p));
        }
        det_errs.extend(nn_errors(&b.points_px, &truth.features.iter().map(|f| Point2::from(f.pixel_px)).collect::<Vec<_>>()));
        views.push(view);
    }
    let t0 = std::time::Instant::now();
    let r = calibrate(&views, truth_cam.size, &CalibParams::default()).expect("calibrate");
    let k = r.camera.intrinsics;
    let kt = truth_cam.intrinsics;
    let det_rms = rms(&det_errs);
    eprintln!(
        "20 rendered views: fx {:.3} fy {:.3} cx {:.3} cy {:.3} (truth {} {} {} {}), dist {:?}, RMS {:.4} px, detector error RMS {det_rms:.4} px, {:.1} ms",
        k.fx,
        k.fy,
        k.cx,
        k.cy,
        kt.fx,
        kt.fy,
        kt.cx,
        kt.cy,
        r.camera.distortion().to_array(),
        r.rms_px,
        t0.elapsed().as_secs_f64() * 1e3
    );
    for (a, b) in [(k.fx, kt.fx), (k.fy, kt.fy), (k.cx, kt.cx), (k.cy, kt.cy)] {
        assert!((a - b).abs() <= 0.3, "{a} vs {b}");
    }
    assert!((r.rms_px - det_rms).abs() <= 0.2 * det_rms, "RMS {} vs detector {det_rms}", r.rms_px);
}
