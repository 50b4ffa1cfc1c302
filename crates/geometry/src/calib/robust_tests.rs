//! Tests of the global search, the outlier rejection and the projection uncertainty, on views
//! projected through known lenses (the truth is the outside value).

use nalgebra::{Isometry3, Point2, Vector2, Vector3};

use super::refine::{BoardExtent, Warp};
use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;

use super::testdata::{wide_scene, with_noise};
use super::*;
use synthcam_core::camera::{DoubleSphere, Fisheye, Intrinsics, Lens};

fn wide_camera(fx: f64, lens: Lens) -> CameraModel {
    CameraModel { size: ImageSize { width: 1280, height: 1024 }, intrinsics: Intrinsics { fx, fy: fx + 0.4, cx: 639.5, cy: 511.5, skew: 0.0 }, lens }
}

/// The Double Sphere lens of the report (fx 348.7, xi -0.21, alpha 0.59).
fn reported_ds() -> CameraModel {
    wide_camera(348.7, Lens::DoubleSphere(DoubleSphere { xi: -0.21, alpha: 0.59 }))
}

/// RMS distance between two view sets' pixels (the detections' error against the truth).
fn rms_between(a: &[View], b: &[View]) -> f64 {
    let d: Vec<f64> = a.iter().flatten().zip(b.iter().flatten()).map(|((_, p), (_, q))| (p - q).norm_squared()).collect();
    (d.iter().sum::<f64>() / d.len() as f64).sqrt()
}

fn pixels(views: &[View]) -> Vec<Point2<f64>> {
    views.iter().flatten().map(|(_, q)| *q).collect()
}

/// The acceptance for one calibration: fit RMS at most 1.02 x the detections' RMS
/// against the truth, and every observed ray within 0.1 px of the true lens's projection.
fn assert_global(truth: &CameraModel, clean: &[View], noisy: &[View], params: &CalibParams, what: &str) {
    let r = calibrate(noisy, truth.size, params).unwrap_or_else(|e| panic!("{what}: {e}"));
    let detection_rms = rms_between(clean, noisy);
    let diff = projection_diff(truth, &r.camera, &pixels(clean));
    assert!(r.rms_px <= 1.02 * detection_rms, "{what}: fit {} vs detections {detection_rms} ({:?}, {:?})", r.rms_px, r.camera, r.search);
    assert!(diff.max_px <= 0.1, "{what}: projection differs by {} px", diff.max_px);
    assert_eq!(diff.compared, pixels(clean).len(), "{what}");
}

#[test]
fn double_sphere_reaches_the_global_optimum_where_one_start_did_not() {
    // From the reported local minimum (fx 633.9, xi 0.437, alpha 0.763), Levenberg-Marquardt
    // alone stays in it: the cost is 4x the truth's (RMS 0.026 against 0.0135 px with seed 9).
    let bad = wide_camera(633.9, Lens::DoubleSphere(DoubleSphere { xi: 0.437, alpha: 0.763 }));
    for (lens, seeds) in [(reported_ds(), 0..4u64), (wide_camera(350.0, Lens::DoubleSphere(DoubleSphere { xi: 0.6, alpha: 0.6 })), 9..12)] {
        for seed in seeds {
            let mut rng = ChaCha8Rng::seed_from_u64(seed);
            let (clean, _) = wide_scene(&lens, 20, 70.0, &mut rng);
            let noisy = with_noise(&clean, 0.01, &mut rng);
            let params = CalibParams { model: CalibModel::DoubleSphere, outlier_threshold: None, ..Default::default() };
            assert_global(&lens, &clean, &noisy, &params, &format!("seed {seed}"));
            // A user's start in the wrong basin is one start among the others.
            assert_global(&lens, &clean, &noisy, &CalibParams { initial: Some(bad), ..params }, &format!("seed {seed}, bad initial"));
        }
    }
}

#[test]
fn the_reported_local_minimum_is_one() {
    let truth = reported_ds();
    let mut rng = ChaCha8Rng::seed_from_u64(9);
    let (clean, _) = wide_scene(&truth, 20, 70.0, &mut rng);
    let noisy = with_noise(&clean, 0.01, &mut rng);
    let bad = wide_camera(633.9, Lens::DoubleSphere(DoubleSphere { xi: 0.437, alpha: 0.763 }));
    let params = CalibParams { model: CalibModel::DoubleSphere, outlier_threshold: None, ..Default::default() };
    let free = free_parameters(&params);
    let alone = refine::refine(truth.size, global::start_under(&bad, &noisy).expect("poses"), &noisy, &free, 200).expect("refine");
    let global = calibrate(&noisy, truth.size, &params).expect("calibrate");
    let n = pixels(&noisy).len() as f64;
    let rms_alone = (alone.cost / n).sqrt();
    assert!(rms_alone > 1.5 * global.rms_px, "alone {rms_alone}, global {}", global.rms_px);
    assert!((alone.state.a[0] - 348.7).abs() > 200.0, "{}", alone.state.a[0]);
    assert!((global.camera.intrinsics.fx - 348.7).abs() < 0.5, "{}", global.camera.intrinsics.fx);
}

/// `views` with `share` of their points moved 1-5 px in a random direction: the noisy views and,
/// per view, the indices moved.
fn inject(views: &[View], share: f64, rng: &mut impl Rng) -> (Vec<View>, Vec<Vec<usize>>) {
    let mut out = views.to_vec();
    let mut moved = vec![Vec::new(); views.len()];
    for (v, m) in out.iter_mut().zip(moved.iter_mut()) {
        for (j, (_, q)) in v.iter_mut().enumerate() {
            if rng.random_bool(share) {
                let (len, dir) = (rng.random_range(1.0..5.0), rng.random_range(0.0..std::f64::consts::TAU));
                *q += Vector2::new(dir.cos(), dir.sin()) * len;
                m.push(j);
            }
        }
    }
    (out, moved)
}

#[test]
fn injected_bad_corners_are_flagged_and_dropped() {
    let fisheye = wide_camera(400.0, Lens::Fisheye(Fisheye { k: [0.05, -0.01, 0.002, -0.0005] }));
    for (truth, model) in [(fisheye, CalibModel::Fisheye), (reported_ds(), CalibModel::DoubleSphere)] {
        for (seed, share) in [(1u64, 0.01), (2, 0.03)] {
            let mut rng = ChaCha8Rng::seed_from_u64(seed);
            let (clean, _) = wide_scene(&truth, 12, 65.0, &mut rng);
            let noisy = with_noise(&clean, 0.02, &mut rng);
            let (bad, moved) = inject(&noisy, share, &mut rng);
            let r = calibrate(&bad, truth.size, &CalibParams { model, ..Default::default() }).expect("calibrate");
            let flagged: Vec<Vec<usize>> = r.views.iter().map(|v| v.outliers.clone()).collect();
            let n_moved: usize = moved.iter().map(Vec::len).sum();
            assert!(n_moved >= 5, "{n_moved}");
            assert_eq!(flagged, moved, "{model} seed {seed}: every moved corner flagged, nothing else");
            assert_eq!(r.rejection.dropped, n_moved);
            let kept = calibrate(&bad, truth.size, &CalibParams { model, outlier_threshold: None, ..Default::default() }).expect("calibrate");
            let clean_fit = calibrate(&noisy, truth.size, &CalibParams { model, ..Default::default() }).expect("calibrate");
            // The noisy views' own fit keeps the moved corners' noise-only versions: close, not equal.
            assert!((r.rms_px / clean_fit.rms_px - 1.0).abs() < 0.05, "{model}: {} vs the fit without the bad corners {}", r.rms_px, clean_fit.rms_px);
            let diff = projection_diff(&clean_fit.camera, &r.camera, &pixels(&clean)).max_px;
            assert!(diff < 0.1, "{model}: {diff} px from the fit without the bad corners");
            assert!((r.rejection.rms_before_px - kept.rms_px).abs() < 1e-9 && kept.rms_px > 10.0 * r.rms_px, "{model}: before {}", kept.rms_px);
        }
    }
}

#[test]
fn nonsense_outlier_thresholds_are_bad_options() {
    let truth = reported_ds();
    let (views, _) = wide_scene(&truth, 4, 40.0, &mut ChaCha8Rng::seed_from_u64(3));
    for k in [0.0, -1.0, f64::NAN, f64::INFINITY] {
        let p = CalibParams { outlier_threshold: Some(k), ..Default::default() };
        assert!(matches!(calibrate(&views, truth.size, &p), Err(CalibError::BadOption { .. })), "{k}");
    }
}

/// The 9 pixels of the uncertainty check: centre, edge middles and corners, 10 % inside.
fn nine_pixels(size: ImageSize) -> Vec<Point2<f64>> {
    let (w, h) = (f64::from(size.width), f64::from(size.height));
    [0.1, 0.5, 0.9].iter().flat_map(|&u| [0.1, 0.5, 0.9].iter().map(move |&v| Point2::new(u * w, v * h))).collect()
}

/// Where the calibrated camera `r` projects the point the true camera sees at `q` (at
/// infinity), carried through the boards' frames as the uncertainty's formulation does.
fn projected_through_boards(r: &CalibResult, truth: &CameraModel, poses: &[Isometry3<f64>], q: &Point2<f64>) -> Vector2<f64> {
    let v = truth.unproject_ray(q).expect("ray").normalize();
    let mut p = Vector3::zeros();
    for (view, pose) in r.views.iter().zip(poses) {
        let v_board = pose.rotation.inverse() * v;
        p += synthcam_core::math::so3::rotation_from_rvec(&view.rvec) * v_board;
    }
    r.camera.project_unchecked(&nalgebra::Point3::from(p / poses.len() as f64)).coords
}

mod slow {
    use super::*;

    /// Predicted projection sigma against the spread of 100 calibrations with fresh noise.
    fn monte_carlo(truth: &CameraModel, model: CalibModel, max_deg: f64, noise_px: f64) {
        let mut rng = ChaCha8Rng::seed_from_u64(5);
        let (clean, poses) = wide_scene(truth, 12, max_deg, &mut rng);
        let params = CalibParams { model, outlier_threshold: None, ..Default::default() };
        let qs = nine_pixels(truth.size);
        let mut samples: Vec<Vec<Vector2<f64>>> = vec![Vec::new(); qs.len()];
        let mut predicted = Vec::new();
        for k in 0..100 {
            let r = calibrate(&with_noise(&clean, noise_px, &mut rng), truth.size, &params).expect("calibrate");
            if k == 0 {
                predicted = qs.iter().map(|q| r.projection_sigma_px(q, None).expect("sigma")).collect();
            }
            for (s, q) in samples.iter_mut().zip(&qs) {
                s.push(projected_through_boards(&r, truth, &poses, q));
            }
        }
        let mut worst: f64 = 0.0;
        for ((s, q), pred) in samples.iter().zip(&qs).zip(&predicted) {
            let n = s.len() as f64;
            let mean = s.iter().sum::<Vector2<f64>>() / n;
            let cov = s.iter().map(|x| (x - mean) * (x - mean).transpose()).sum::<nalgebra::Matrix2<f64>>() / (n - 1.0);
            let mc = cov.symmetric_eigenvalues().max().sqrt();
            eprintln!("{model} at ({:.0}, {:.0}): predicted {pred:.4} px, Monte Carlo {mc:.4} px", q.x, q.y);
            worst = worst.max((pred / mc - 1.0).abs());
        }
        assert!(worst <= 0.25, "{model}: predicted and Monte Carlo sigma differ by {worst}");
    }

    #[test]
    fn predicted_projection_sigma_matches_monte_carlo() {
        let pinhole = CameraModel {
            lens: Lens::OpenCv(synthcam_core::camera::Distortion::from_array([-0.2, 0.08, 1e-3, -5e-4, 0.0])),
            ..wide_camera(1000.0, Lens::OpenCv(synthcam_core::camera::Distortion::default()))
        };
        monte_carlo(&pinhole, CalibModel::OpenCv5, 15.0, 0.1);
        monte_carlo(&wide_camera(400.0, Lens::Fisheye(Fisheye { k: [0.05, -0.01, 0.002, -0.0005] })), CalibModel::Fisheye, 65.0, 0.1);
        monte_carlo(&reported_ds(), CalibModel::DoubleSphere, 65.0, 0.02);
    }
}

/// `views` re-projected from a board warped by `k` (sag at the centre, metres) over the 8 x 6
/// board's extent, at the poses `poses`.
fn warped_views(truth: &CameraModel, views: &[View], poses: &[Isometry3<f64>], k: [f64; 2]) -> Vec<View> {
    let extent = BoardExtent::of(super::testdata::board(8, 6, 0.03)).expect("extent");
    let warp = Warp { k, extent: Some(extent) };
    views.iter().zip(poses).map(|(v, pose)| v.iter().map(|(x, _)| (*x, truth.project_unchecked(&(pose * warp.apply(x))))).collect()).collect()
}

#[test]
fn a_warped_board_is_estimated_and_its_warp_would_bias_k() {
    let extent = BoardExtent::of(super::testdata::board(8, 6, 0.03)).expect("extent");
    let fisheye = wide_camera(400.0, Lens::Fisheye(Fisheye { k: [0.05, -0.01, 0.002, -0.0005] }));
    let pinhole = CameraModel {
        lens: Lens::OpenCv(synthcam_core::camera::Distortion::from_array([-0.2, 0.08, 1e-3, -5e-4, 0.0])),
        ..wide_camera(1000.0, Lens::OpenCv(synthcam_core::camera::Distortion::default()))
    };
    for (truth, model, max_deg, k) in [(pinhole, CalibModel::OpenCv5, 15.0, [0.002, -0.001]), (fisheye, CalibModel::Fisheye, 60.0, [0.003, 0.0015])] {
        let mut rng = ChaCha8Rng::seed_from_u64(21);
        let (flat, poses) = wide_scene(&truth, 16, max_deg, &mut rng);
        let views = with_noise(&warped_views(&truth, &flat, &poses, k), 0.02, &mut rng);
        let params = CalibParams { model, board_warp: Some(extent), ..Default::default() };
        let r = calibrate(&views, truth.size, &params).expect("calibrate");
        for (est, sd, t) in r.board_warp.k.iter().zip(r.board_warp_std).zip(k).map(|((e, s), t)| (e, s, t)) {
            assert!((est - t).abs() <= 0.1 * t.abs(), "{model}: warp {est} vs {t}");
            assert!(sd.is_finite() && sd < 0.1 * t.abs(), "{model}: std {sd}");
        }
        let fx_err = (r.camera.intrinsics.fx - truth.intrinsics.fx).abs();
        let ignored = calibrate(&views, truth.size, &CalibParams { model, outlier_threshold: None, ..Default::default() }).expect("flat");
        let fx_err_flat = (ignored.camera.intrinsics.fx - truth.intrinsics.fx).abs();
        eprintln!(
            "{model}: warp {:?} (std {:?}); fx error {fx_err:.4} px with the warp, {fx_err_flat:.4} px without; RMS {:.4} vs {:.4}",
            r.board_warp.k, r.board_warp_std, r.rms_px, ignored.rms_px
        );
        assert!(fx_err_flat > 5.0 * fx_err && ignored.rms_px > 1.5 * r.rms_px, "{model}");
    }
}

#[test]
fn double_sphere_at_xi_zero_reports_its_exact_trade_as_undetermined() {
    // At xi = 0 the model's fx, xi and alpha trade exactly (a(alpha |p| + (1 - alpha) z) is matched
    // by a change of all three for every p): their sigmas are infinite, not a misleading number,
    // and the projection's uncertainty, which that trade does not move, stays finite.
    let truth = wide_camera(350.0, Lens::DoubleSphere(DoubleSphere { xi: 0.0, alpha: 0.6 }));
    let mut rng = ChaCha8Rng::seed_from_u64(2);
    let (views, _) = wide_scene(&truth, 12, 60.0, &mut rng);
    let r = calibrate(&views, truth.size, &CalibParams { model: CalibModel::DoubleSphere, ..Default::default() }).expect("calibrate");
    assert!(r.rms_px < 1e-6, "{}", r.rms_px);
    for i in [0, 1, 5, 6] {
        assert!(r.undetermined.contains(&i) && r.std[i] == f64::INFINITY, "{i}: {:?} {:?}", r.undetermined, r.std);
    }
    assert!(r.std[2].is_finite() && r.std[3].is_finite(), "{:?}", r.std);
    let sigma = r.projection_sigma_px(&Point2::new(900.0, 700.0), None).expect("sigma");
    assert!(sigma.is_finite(), "{sigma}");
    // Away from xi = 0 nothing is undetermined.
    let r = calibrate(
        &with_noise(&wide_scene(&reported_ds(), 12, 60.0, &mut rng).0, 0.01, &mut rng),
        truth.size,
        &CalibParams { model: CalibModel::DoubleSphere, ..Default::default() },
    )
    .expect("calibrate");
    assert!(r.undetermined.is_empty() && r.std.iter().take(4).all(|s| s.is_finite()), "{:?}", r.undetermined);
}
