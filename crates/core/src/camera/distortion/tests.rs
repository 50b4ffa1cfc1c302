//! Tests of `distortion`.

use super::*;
use crate::math::numdiff::central_diff;
use nalgebra::{DMatrix, DVector};
use proptest::prelude::*;

fn strong() -> Distortion {
    Distortion::from_array([-0.25, 0.12, 1e-3, -5e-4, 0.01])
}

/// Max abs difference, scaled by 1 + |numeric| entries.
fn rel_err(a: &DMatrix<f64>, n: &DMatrix<f64>) -> f64 {
    (a - n).amax() / (1.0 + n.amax())
}

const PTS: [[f64; 2]; 6] = [[0.0, 0.0], [0.3, -0.2], [-0.5, 0.4], [0.7, 0.6], [-0.05, -0.9], [1.0, 0.0]];

#[test]
fn array_round_trip_and_zero() {
    let d = strong();
    assert_eq!(Distortion::from_array(d.to_array()), d);
    assert!(Distortion::default().is_zero());
    assert!(!d.is_zero());
    let p = Vector2::new(0.3, -0.4);
    assert_eq!(Distortion::default().distort(&p), p);
}

#[test]
fn distort_hand_value() {
    // x = 0.1, y = -0.05, r2 = 0.0125; k1=-0.2, k2=0.05, p1=1e-3, p2=-2e-3, k3=0.01.
    // g = 1 - 0.0025 + 0.05*1.5625e-4 + 0.01*1.953125e-6 = 0.99750783203125
    // xd = 0.0997507832... + 2e-3*(-0.005) - 2e-3*0.0325 = 0.099675783203125
    // yd = -0.04987539160... + 1e-3*0.0175 + 2*(-2e-3)*(-0.005) = -0.0498378916015625
    let d = Distortion::from_array([-0.2, 0.05, 1e-3, -2e-3, 0.01]);
    let xd = d.distort(&Vector2::new(0.1, -0.05));
    assert!((xd.x - 0.099675783203125).abs() < 1e-15);
    assert!((xd.y - (-0.0498378916015625)).abs() < 1e-15);
}

#[test]
fn dxd_dxu_matches_central_diff() {
    // h = 1e-6: truncation O(h^2 * |f'''|) ~ 1e-12 * O(10), rounding
    // ~ eps/h ~ 1e-10. Tolerance 1e-7 relative is 3 orders above that and
    // far below any wrong term (the smallest, p2 x ~ 5e-4 * 0.3, is 1.5e-4).
    for d in [strong(), Distortion::from_array([0.1, -0.02, -2e-3, 3e-3, -0.004])] {
        for p in PTS {
            let xu = Vector2::new(p[0], p[1]);
            let a = d.dxd_dxu(&xu);
            let n = central_diff(
                |v| {
                    let r = d.distort(&Vector2::new(v[0], v[1]));
                    DVector::from_vec(vec![r.x, r.y])
                },
                &DVector::from_vec(vec![p[0], p[1]]),
                1e-6,
            );
            let a = DMatrix::from_iterator(2, 2, a.iter().copied());
            assert!(rel_err(&a, &n) < 1e-7, "at {p:?}: {a} vs {n}");
        }
    }
}

#[test]
fn dxd_dcoeffs_matches_central_diff() {
    // Linear in the coefficients: central difference exact up to
    // rounding ~1e-10; 1e-8 catches any wrong column (entries >= 1e-3
    // at these points except at the origin where everything is zero).
    let d = strong();
    for p in PTS {
        let xu = Vector2::new(p[0], p[1]);
        let a = d.dxd_dcoeffs(&xu).fixed_view::<2, 5>(0, 0).into_owned();
        let n = central_diff(
            |c| {
                let dd = Distortion::from_array([c[0], c[1], c[2], c[3], c[4]]);
                let r = dd.distort(&xu);
                DVector::from_vec(vec![r.x, r.y])
            },
            &DVector::from_row_slice(&d.to_array()),
            1e-6,
        );
        let a = DMatrix::from_iterator(2, 5, a.iter().copied());
        assert!(rel_err(&a, &n) < 1e-8, "at {p:?}: {a} vs {n}");
    }
}

#[test]
fn max_monotonic_radius_values() {
    // k1 only: d(r - 0.25 r^3)/dr = 1 - 0.75 r^2 = 0 at r = sqrt(4/3).
    let d = Distortion::from_array([-0.25, 0.0, 0.0, 0.0, 0.0]);
    let r = d.max_monotonic_radius().unwrap_or(f64::NAN);
    assert!((r - (4.0f64 / 3.0).sqrt()).abs() < 1e-12);
    // k1=-0.25, k2=0.12: 1 - 0.75 s + 0.6 s^2 has no real root -> None.
    assert_eq!(Distortion::from_array([-0.25, 0.12, 0.0, 0.0, 0.0]).max_monotonic_radius(), None);
    assert_eq!(Distortion::default().max_monotonic_radius(), None);
    // Pincushion with negative k3: must find a root and slope must vanish there.
    let d = Distortion::from_array([0.5, 0.0, 0.0, 0.0, -0.3]);
    let r = d.max_monotonic_radius().unwrap_or(f64::NAN);
    assert!(r > 1.0 && r < 1.1, "{r}");
    assert!(d.radial_slope(r * r).abs() < 1e-12);
    // Positive k1 with a late fold from negative k2:
    // 1 + 0.3 s - 0.05 s^2 = 0 -> s = (0.3 + sqrt(0.09+0.2))/0.1 = 8.385...
    let d = Distortion::from_array([0.1, -0.01, 0.0, 0.0, 0.0]);
    let s: f64 = (0.3 + 0.29f64.sqrt()) / 0.1;
    let r = d.max_monotonic_radius().unwrap_or(f64::NAN);
    assert!((r - s.sqrt()).abs() < 1e-12, "{r} vs {}", s.sqrt());
}

#[test]
fn undistort_round_trip_points() {
    let d = strong();
    for p in PTS {
        let xu = Vector2::new(p[0], p[1]);
        let back = d.undistort(&d.distort(&xu));
        assert!(matches!(back, Ok(b) if (b - xu).amax() < 1e-10), "{p:?}: {back:?}");
    }
}

#[test]
fn folded_model_is_not_invertible() {
    // k1 = -0.6: r - 0.6 r^3 peaks at r = sqrt(1/1.8) = 0.745 with
    // distorted radius 0.497; xd at radius 0.6 has no preimage.
    let d = Distortion::from_array([-0.6, 0.0, 0.0, 0.0, 0.0]);
    let r = d.undistort(&Vector2::new(0.6, 0.0));
    assert!(matches!(r, Err(CameraError::NotInvertible { .. })), "{r:?}");
    let r = d.undistort(&Vector2::new(3.0, -4.0));
    assert!(matches!(r, Err(CameraError::NotInvertible { .. })), "{r:?}");
    // A point beyond the fold (r = 1.0 -> 0.4) undistorts to the first
    // branch, never to a folded solution.
    let xd = d.distort(&Vector2::new(1.0, 0.0));
    let rf = d.max_monotonic_radius().unwrap_or(0.0);
    let xu = d.undistort(&xd);
    assert!(matches!(xu, Ok(v) if v.norm() < rf && (d.distort(&v) - xd).norm() < 1e-10), "{xu:?}");
}

#[test]
fn restart_recovers_first_branch() {
    // Pincushion then fold (fold ~1.04, peak distorted radius ~1.21).
    // Newton from xd = 1.1 starts beyond the fold and runs to the outer
    // root; the restart must return the inner root instead.
    let d = Distortion::from_array([0.5, 0.0, 0.0, 0.0, -0.3]);
    let rf = d.max_monotonic_radius().unwrap_or(0.0);
    let xd = Vector2::new(1.1, 0.0);
    let xu = d.undistort(&xd);
    assert!(matches!(xu, Ok(v) if v.norm() < rf && (d.distort(&v) - xd).norm() < 1e-10), "{xu:?}");
}

#[test]
fn non_finite_input_is_error() {
    let d = strong();
    for v in [Vector2::new(f64::NAN, 0.0), Vector2::new(0.0, f64::INFINITY)] {
        assert!(matches!(d.undistort(&v), Err(CameraError::NonFinite { .. })));
    }
    // NaN coefficients: error, no panic / infinite loop.
    let bad = Distortion::from_array([f64::NAN, 0.0, 0.0, 0.0, 0.0]);
    assert!(bad.undistort(&Vector2::new(0.1, 0.1)).is_err());
}

proptest! {
    #[test]
    fn prop_round_trip(x in -1.0f64..1.0, y in -1.0f64..1.0) {
        // Strong model is monotonic (no fold) on this square; the
        // Jacobian's smallest singular value is > 0.5 there, so a
        // residual of 1e-12 means an error of at most ~2e-12.
        let d = strong();
        let xu = Vector2::new(x, y);
        let back = d.undistort(&d.distort(&xu));
        prop_assert!(back.is_ok());
        if let Ok(b) = back {
            prop_assert!((b - xu).amax() <= 1e-10);
        }
    }
}
