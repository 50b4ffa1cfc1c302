//! Tests of `project`.

use super::*;
use crate::camera::{Distortion, ImageSize, Intrinsics, Lens};
use crate::math::numdiff::central_diff;
use nalgebra::{DMatrix, DVector};
use proptest::prelude::*;

fn strong_cam() -> CameraModel {
    CameraModel {
        size: ImageSize { width: 1280, height: 1024 },
        intrinsics: Intrinsics { fx: 1000.0, fy: 1010.0, cx: 639.5, cy: 511.5, skew: 0.5 },
        lens: Lens::OpenCv(Distortion::from_array([-0.25, 0.12, 1e-3, -5e-4, 0.01])),
    }
}

fn params(c: &CameraModel) -> DVector<f64> {
    let k = c.intrinsics;
    let d = c.distortion().to_array();
    DVector::from_vec(vec![k.fx, k.fy, k.cx, k.cy, k.skew, d[0], d[1], d[2], d[3], d[4]])
}

fn with_params(c: &CameraModel, v: &DVector<f64>) -> CameraModel {
    CameraModel {
        size: c.size,
        intrinsics: Intrinsics { fx: v[0], fy: v[1], cx: v[2], cy: v[3], skew: v[4] },
        lens: Lens::OpenCv(Distortion::from_array([v[5], v[6], v[7], v[8], v[9]])),
    }
}

const POINTS: [[f64; 3]; 5] = [[0.0, 0.0, 1.0], [0.3, -0.2, 1.5], [-0.8, 0.6, 2.0], [1.2, 1.0, 1.7], [-0.02, -3.0, 4.0]];

#[test]
fn dq_dp_cam_matches_central_diff() {
    // Pixels ~1e3 * normalised; h = 1e-6 m gives rounding ~eps*1e3/1e-6
    // ~ 2e-7 px/m and truncation ~1e-9. Entries are ~1e2..1e3, so a
    // relative tolerance of 1e-7 (~1e-4 absolute) is well above noise and
    // below any wrong term (e.g. skew 0.5 * dyd/dz ~ 0.1).
    for cam in [strong_cam(), CameraModel::sxga_1500px()] {
        for p in POINTS {
            let pt = Point3::new(p[0], p[1], p[2]);
            let a = cam.dq_dp_cam(&pt);
            let n = central_diff(
                |v| {
                    let q = cam.project_unchecked(&Point3::new(v[0], v[1], v[2]));
                    DVector::from_vec(vec![q.x, q.y])
                },
                &DVector::from_vec(p.to_vec()),
                1e-6,
            );
            let a = DMatrix::from_iterator(2, 3, a.iter().copied());
            let err = (&a - &n).amax() / (1.0 + n.amax());
            assert!(err < 1e-7, "{p:?}: {a} vs {n}");
        }
    }
}

#[test]
fn dq_dintrinsics_matches_central_diff() {
    // Step 1e-6 on every parameter (fx ~1e3 so the relative step there is
    // 1e-9). The projection is linear in fx..skew and polynomial in the
    // coefficients; rounding ~eps*|q|/h ~ 1e-7 px per unit, entries up to
    // ~1e3, relative tolerance 1e-7 is well above noise, and far below the
    // effect of any wrong column (smallest nonzero entry ~ 1e-3).
    let cam = strong_cam();
    let x0 = params(&cam);
    for p in POINTS {
        let pt = Point3::new(p[0], p[1], p[2]);
        let a = cam.dq_dintrinsics(&pt).fixed_view::<2, 10>(0, 0).into_owned();
        let n = central_diff(
            |v| {
                let q = with_params(&cam, v).project_unchecked(&pt);
                DVector::from_vec(vec![q.x, q.y])
            },
            &x0,
            1e-6,
        );
        let a = DMatrix::from_iterator(2, 10, a.iter().copied());
        let err = (&a - &n).amax() / (1.0 + n.amax());
        assert!(err < 1e-7, "{p:?}: {a} vs {n}");
    }
    let names = intrinsic_names(crate::camera::LensKind::OpenCv);
    assert_eq!(names.len(), 19);
    assert_eq!(names[4], "skew");
    assert_eq!(names[5], "k1");
}

#[test]
fn opencv_project_points_hand_computed() {
    // cv2 is not available here; expected value computed by hand from the
    // projectPoints model in the OpenCV calib3d docs
    // ("Camera Calibration and 3D Reconstruction"), no skew:
    // K: fx=800, fy=820, cx=320, cy=240; dist (k1,k2,p1,p2,k3) =
    // (-0.2, 0.05, 0.001, -0.002, 0.01); rvec = tvec = 0; X = (0.2, -0.1, 2).
    // x' = 0.1, y' = -0.05, r2 = 0.0125, r4 = 1.5625e-4, r6 = 1.953125e-6
    // radial = 1 - 0.2*0.0125 + 0.05*1.5625e-4 + 0.01*1.953125e-6
    //        = 0.99750783203125
    // x'' = 0.1*radial + 2*0.001*0.1*(-0.05) + (-0.002)*(0.0125 + 2*0.01)
    //     = 0.099750783203125 - 0.00001 - 0.000065 = 0.099675783203125
    // y'' = -0.05*radial + 0.001*(0.0125 + 2*0.0025) + 2*(-0.002)*0.1*(-0.05)
    //     = -0.0498753916015625 + 0.0000175 + 0.00002 = -0.0498378916015625
    // u = 800*x'' + 320 = 399.7406265625
    // v = 820*y'' + 240 = 199.13292888671875
    // Tolerance 1e-9 px: double rounding on values ~400 is ~1e-13.
    let cam = CameraModel {
        size: ImageSize { width: 640, height: 480 },
        intrinsics: Intrinsics { fx: 800.0, fy: 820.0, cx: 320.0, cy: 240.0, skew: 0.0 },
        lens: Lens::OpenCv(Distortion::from_array([-0.2, 0.05, 0.001, -0.002, 0.01])),
    };
    let pr = cam.project(&Point3::new(0.2, -0.1, 2.0));
    assert!((pr.pixel_px.x - 399.7406265625).abs() < 1e-9, "{pr:?}");
    assert!((pr.pixel_px.y - 199.13292888671875).abs() < 1e-9, "{pr:?}");
    assert!(pr.visible());
}

#[test]
fn sxga_camera_known_point() {
    // u = 1500 * 0.1/1.5 + 640 = 740, v = 1500 * (-0.05/1.5) + 512 = 462.
    // Rounding only (~1e-13 px).
    let cam = CameraModel::sxga_1500px();
    let pr = cam.project(&Point3::new(0.1, -0.05, 1.5));
    assert!((pr.pixel_px.x - 740.0).abs() < 1e-9);
    assert!((pr.pixel_px.y - 462.0).abs() < 1e-9);
    assert!(pr.in_front && pr.in_image && pr.visible());
    // Course alpha mapping: u = fx (xd + alpha yd) + u0 with skew = alpha fx.
    let mut c2 = cam;
    let alpha = 0.01;
    c2.intrinsics.skew = alpha * c2.intrinsics.fx;
    let q = c2.project_unchecked(&Point3::new(0.1, -0.05, 1.5));
    let expect = 1500.0 * (0.1 / 1.5 + alpha * (-0.05 / 1.5)) + 640.0;
    assert!((q.x - expect).abs() < 1e-9);
}

#[test]
fn behind_and_degenerate_points_do_not_panic() {
    let cam = strong_cam();
    let pr = cam.project(&Point3::new(0.1, 0.1, -2.0));
    assert!(!pr.in_front && !pr.visible());
    assert!(pr.pixel_px.x.is_finite() && pr.pixel_px.y.is_finite());
    let pr = cam.project(&Point3::new(0.1, 0.1, 0.0));
    assert!(!pr.in_front && !pr.in_image);
    let pr = cam.project(&Point3::new(f64::NAN, 0.1, 1.0));
    assert!(!pr.visible());
    // Outside the image.
    let pr = cam.project(&Point3::new(5.0, 0.0, 1.0));
    assert!(pr.in_front && !pr.in_image);
}

#[test]
fn beyond_fold_is_not_in_image() {
    // Course camera with k1 = -0.6: fold at r = 0.745; a point at r = 1.0
    // maps back to distorted radius 0.4 (inside the image) but must not
    // be reported visible.
    let mut cam = CameraModel::sxga_1500px();
    cam.lens = Lens::OpenCv(Distortion { k1: -0.6, ..Distortion::default() });
    let pr = cam.project(&Point3::new(1.0, 0.0, 1.0));
    assert!(cam.size.contains_px(&pr.pixel_px));
    assert!(!pr.in_image && !pr.visible());
}

fn image_grid_round_trip(cam: &CameraModel, step: f64) {
    // Dense grid over the whole image including the borders/corners.
    let w = f64::from(cam.size.width) - 0.5;
    let h = f64::from(cam.size.height) - 0.5;
    let mut n = 0usize;
    let mut u = -0.5;
    while u <= w {
        let mut v = -0.5;
        while v <= h {
            for q in [Point2::new(u, v), Point2::new(w, v), Point2::new(u, h)] {
                let xd = cam.intrinsics.pixel_to_normalized(&q);
                let xu = cam.lens.undistort(&xd);
                let Ok(xu) = xu else {
                    panic!("undistort failed at {q:?}: {xu:?}");
                };
                // Spec: residual <= 1e-10 normalised units.
                assert!((cam.lens.distort(&xu) - xd).norm() <= 1e-10);
                // And the other direction: undistort(distort(xu)) == xu.
                let back = cam.lens.undistort(&cam.lens.distort(&xu));
                assert!(matches!(back, Ok(b) if (b - xu).norm() <= 1e-10), "{q:?}");
                n += 1;
            }
            v += step;
        }
        u += step;
    }
    assert!(n > 1000);
}

#[test]
fn undistort_round_trip_whole_image_strong() {
    let mut cam = strong_cam();
    cam.intrinsics = Intrinsics { fx: 1000.0, fy: 1000.0, cx: 639.5, cy: 511.5, skew: 0.0 };
    cam.lens = Lens::OpenCv(Distortion::from_array([-0.25, 0.12, 0.0, 0.0, 0.0]));
    image_grid_round_trip(&cam, 8.0);
}

#[test]
fn undistort_round_trip_whole_image_course_k1() {
    let cam = CameraModel::sxga_1500px().with_distortion([-0.25, 0.0, 0.0, 0.0, 0.0]);
    image_grid_round_trip(&cam, 8.0);
}

#[test]
fn unproject_gives_ray_direction() {
    let cam = strong_cam();
    for p in [[0.1, -0.2, 1.5], [0.0, 0.0, 3.0], [-0.4, 0.3, 1.0], [0.5, 0.4, 1.2]] {
        let pt = Point3::new(p[0], p[1], p[2]);
        let ray = cam.unproject(&cam.project(&pt).pixel_px);
        let Ok(ray) = ray else {
            panic!("{ray:?}");
        };
        assert_eq!(ray.z, 1.0);
        // Angle between ray and point direction: residual 1e-12 in
        // normalised coords -> ~1e-12 rad; 1e-10 leaves margin.
        let d = (ray.normalize() - pt.coords.normalize()).norm();
        assert!(d < 1e-10, "{p:?}: {d}");
    }
    assert!(matches!(cam.unproject(&Point2::new(f64::NAN, 1.0)), Err(CameraError::NonFinite { .. })));
    let mut bad = cam;
    bad.intrinsics.fy = 0.0;
    assert!(bad.unproject(&Point2::new(1.0, 1.0)).is_err());
}

proptest! {
    #[test]
    fn prop_unproject_project(u in -0.5f64..1279.5, v in -0.5f64..1023.5) {
        let cam = strong_cam();
        let q = Point2::new(u, v);
        let ray = cam.unproject(&q);
        prop_assert!(ray.is_ok());
        if let Ok(r) = ray {
            let q2 = cam.project_unchecked(&Point3::from(r * 2.5));
            // 1e-12 normalised residual * 1e3 px ~ 1e-9 px.
            prop_assert!((q2 - q).norm() < 1e-7);
        }
    }
}
