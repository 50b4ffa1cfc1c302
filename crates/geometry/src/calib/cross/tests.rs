//! Tests of `cross`: a model too simple for its lens shows in the held-out error; options.

use rand::SeedableRng;

use super::*;
use crate::calib::testdata::{wide_views, with_noise};
use crate::calib::CalibModel;
use synthcam_core::camera::{Fisheye, Intrinsics, Lens};

/// A fisheye lens (f 400 px) seen in 15 views up to 65 degrees off-axis, corners with noise of
/// `sigma` px.
fn fisheye_views(sigma: f64) -> (CameraModel, Vec<View>) {
    let truth = CameraModel {
        size: ImageSize { width: 1280, height: 1024 },
        intrinsics: Intrinsics { fx: 400.0, fy: 401.0, cx: 641.0, cy: 510.0, skew: 0.0 },
        lens: Lens::Fisheye(Fisheye { k: [0.05, -0.01, 0.002, -0.0005] }),
    };
    let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(3);
    let views = wide_views(&truth, 15, 65.0, &mut rng);
    (truth, with_noise(&views, sigma, &mut rng))
}

#[test]
fn the_right_model_holds_out_at_the_noise_and_a_wrong_one_does_not() {
    let (truth, views) = fisheye_views(0.1);
    let run = |model| {
        let params = CalibParams { model, ..Default::default() };
        let full = calibrate(&views, truth.size, &params).expect("calibrate");
        (cross_validate(&views, truth.size, &params, &full, 5).expect("cross-validate"), full)
    };
    let (right, full) = run(CalibModel::Fisheye);
    assert_eq!(right.folds.len(), 5);
    assert_eq!(right.folds.iter().map(|f| f.held_out.len()).sum::<usize>(), views.len());
    // Noise 0.1 px per axis (0.1 px RMS per axis is 0.141 as a 2-D RMS): held-out near the fit.
    assert!(right.held_out_rms_px < 1.3 * full.rms_px && right.held_out_rms_px < 0.2, "{} vs fit {}", right.held_out_rms_px, full.rms_px);
    // Folds of 12 views of a small board (about 200 px across at f 400): the folds' cameras differ
    // by 0.39 px RMS in projection over the covered cells, 0.70 px at most (at the edge).
    assert!(right.projection_diff_rms_px < 0.5 && right.projection_diff_max_px < 1.0, "{} / {}", right.projection_diff_rms_px, right.projection_diff_max_px);
    assert!(right.intrinsics_spread[0] < 1.0 && right.intrinsics_spread[4].is_nan(), "{:?}", right.intrinsics_spread);
    // Brown-Conrady with 5 coefficients cannot follow the fisheye over 65 degrees.
    let (wrong, full5) = run(CalibModel::OpenCv5);
    assert!(wrong.held_out_rms_px > 2.0 * right.held_out_rms_px, "opencv5 {} vs fisheye {}", wrong.held_out_rms_px, right.held_out_rms_px);
    assert!(wrong.held_out_rms_px > full5.rms_px, "{} vs fit {}", wrong.held_out_rms_px, full5.rms_px);
    eprintln!(
        "fisheye: held-out {:.4} fit {:.4} diff {:.3}/{:.3}; opencv5: held-out {:.4} fit {:.4} diff {:.3}/{:.3}",
        right.held_out_rms_px,
        full.rms_px,
        right.projection_diff_rms_px,
        right.projection_diff_max_px,
        wrong.held_out_rms_px,
        full5.rms_px,
        wrong.projection_diff_rms_px,
        wrong.projection_diff_max_px
    );
}

#[test]
fn folds_out_of_range_are_bad_options() {
    let (truth, views) = fisheye_views(0.0);
    let params = CalibParams { model: CalibModel::Fisheye, ..Default::default() };
    let full = calibrate(&views, truth.size, &params).expect("calibrate");
    for folds in [0, 1, 16] {
        assert!(matches!(cross_validate(&views, truth.size, &params, &full, folds), Err(CalibError::BadOption { .. })), "{folds} folds");
    }
    // 4 views in 2 folds leave 2 to fit.
    assert!(matches!(cross_validate(&views[..4], truth.size, &params, &full, 2), Err(CalibError::BadOption { .. })));
}
