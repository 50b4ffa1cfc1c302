//! Tests of the lens models: outside values (OpenCV's `projectPoints` and `fisheye.projectPoints`,
//! the Double Sphere paper's formula evaluated in numpy), Jacobians against central differences,
//! round trips over the valid region.

use nalgebra::{DMatrix, DVector, Point2, Point3, Vector2};

use crate::camera::{CameraModel, Distortion, DoubleSphere, Fisheye, ImageSize, Intrinsics, Lens, FISHEYE_MAX_ANGLE_RAD};
use crate::math::numdiff::central_diff;

const OPENCV14: [f64; 14] = [-0.2, 0.05, 0.001, -0.002, 0.01, 0.03, -0.01, 0.002, 1e-3, -2e-4, 5e-4, 3e-4, 0.02, -0.015];

fn camera(k: [f64; 4], lens: Lens) -> CameraModel {
    CameraModel { size: ImageSize { width: 1280, height: 1024 }, intrinsics: Intrinsics { fx: k[0], fy: k[1], cx: k[2], cy: k[3], skew: 0.0 }, lens }
}

fn lenses() -> Vec<Lens> {
    vec![
        Lens::OpenCv(Distortion::from_coefficients(OPENCV14)),
        Lens::OpenCv(Distortion::from_array([-0.25, 0.12, 1e-3, -5e-4, 0.01])),
        Lens::Fisheye(Fisheye { k: [0.05, -0.01, 0.002, -0.0005] }),
        Lens::DoubleSphere(DoubleSphere { xi: -0.2, alpha: 0.6 }),
        Lens::DoubleSphere(DoubleSphere { xi: 0.3, alpha: 0.4 }),
    ]
}

fn check_pixels(cam: &CameraModel, points: &[[f64; 3]], expect: &[[f64; 2]]) {
    for (p, e) in points.iter().zip(expect) {
        let q = cam.project(&Point3::new(p[0], p[1], p[2]));
        // Same formulas in f64, a different evaluation order: rounding ~1e-12 px.
        assert!((q.pixel_px.x - e[0]).abs() < 1e-9 && (q.pixel_px.y - e[1]).abs() < 1e-9, "{p:?}: {q:?} vs {e:?}");
        assert!(q.in_front);
    }
}

#[test]
fn opencv14_matches_opencv_project_points() {
    // cv2.projectPoints(P, 0, 0, K = [[800, 0, 320], [0, 820, 240]], OPENCV14), OpenCV 4.x.
    let cam = camera([800.0, 820.0, 320.0, 240.0], Lens::OpenCv(Distortion::from_coefficients(OPENCV14)));
    check_pixels(&cam, &[[0.2, -0.1, 2.0], [-0.5, 0.4, 1.2]], &[[399.7695690448284, 199.1493324716761], [5.478450493451817, 498.00635629018774]]);
}

#[test]
fn fisheye_matches_opencv_fisheye_project_points() {
    // cv2.fisheye.projectPoints(P, 0, 0, K = [[400, 0, 639.5], [0, 410, 511.5]], D), OpenCV 4.x;
    // the last point is 79 degrees off the axis.
    let cam = camera([400.0, 410.0, 639.5, 511.5], Lens::Fisheye(Fisheye { k: [0.05, -0.01, 0.002, -0.0005] }));
    let pts = [[0.2, -0.1, 2.0], [1.5, 0.8, 0.6], [-2.0, 0.3, 0.4]];
    check_pixels(&cam, &pts, &[[679.3592023171514, 491.0721588124599], [1098.9931726628006, 762.6896010556644], [59.49420042534962, 600.6758916846024]]);
}

#[test]
fn double_sphere_matches_the_paper_formula() {
    // Usenko et al. 2018 eq. 40-42 evaluated in numpy: xi = -0.2, alpha = 0.6, fx 380, fy 385.
    let cam = camera([380.0, 385.0, 639.5, 511.5], Lens::DoubleSphere(DoubleSphere { xi: -0.2, alpha: 0.6 }));
    let pts = [[0.2, -0.1, 2.0], [1.5, 0.8, 0.6], [-2.0, 0.3, 0.4]];
    check_pixels(&cam, &pts, &[[686.7974532701884, 487.54010590918085], [1145.7859406941961, 785.0720521645832], [10.633276796926907, 607.0711928025723]]);
}

const XU: [[f64; 2]; 6] = [[0.0, 0.0], [1e-7, -2e-7], [0.3, -0.2], [-0.5, 0.4], [0.7, 0.6], [-1.9, 1.2]];

#[test]
fn dxd_dxu_matches_central_differences() {
    // h = 1e-6 on values of order 1: rounding ~1e-10, truncation ~1e-12; 1e-7 (relative) is far
    // below any wrong term (tilt and prism terms are >= 1e-4 here).
    for lens in lenses() {
        for p in XU {
            let a = lens.dxd_dxu(&Vector2::new(p[0], p[1]));
            let n = central_diff(|v| DVector::from_column_slice(lens.distort(&Vector2::new(v[0], v[1])).as_slice()), &DVector::from_column_slice(&p), 1e-6);
            let a = DMatrix::from_column_slice(2, 2, a.as_slice());
            assert!((&a - &n).amax() / (1.0 + n.amax()) < 1e-7, "{lens:?} at {p:?}: {a} vs {n}");
        }
    }
}

#[test]
fn dxd_dparams_matches_central_differences() {
    for lens in lenses() {
        let kind = lens.kind();
        let n_p = lens.n_params();
        for p in XU {
            let xu = Vector2::new(p[0], p[1]);
            let a = lens.dxd_dparams(&xu);
            let n = central_diff(
                |v| DVector::from_column_slice(kind.lens(v.as_slice()).distort(&xu).as_slice()),
                &DVector::from_column_slice(&lens.params()[..n_p]),
                1e-6,
            );
            let a = DMatrix::from_fn(2, n_p, |i, j| a[(i, j)]);
            assert!((&a - &n).amax() / (1.0 + n.amax()) < 1e-7, "{lens:?} at {p:?}: {a} vs {n}");
        }
    }
}

#[test]
fn dq_dp_cam_matches_central_differences_for_every_model() {
    for lens in lenses() {
        let cam = camera([400.0, 410.0, 639.5, 511.5], lens);
        for p in [[0.2, -0.1, 2.0], [1.5, 0.8, 0.6], [-0.3, 0.3, 0.7]] {
            check_dq_dp(&cam, p);
        }
    }
}

/// `dq_dp_cam` against central differences of `project_unchecked` at `p`.
fn check_dq_dp(cam: &CameraModel, p: [f64; 3]) {
    let a = cam.dq_dp_cam(&Point3::new(p[0], p[1], p[2]));
    let n = central_diff(
        |v| DVector::from_column_slice(cam.project_unchecked(&Point3::new(v[0], v[1], v[2])).coords.as_slice()),
        &DVector::from_column_slice(&p),
        1e-6,
    );
    let a = DMatrix::from_column_slice(2, 3, a.as_slice());
    assert!((&a - &n).amax() / (1.0 + n.amax()) < 1e-7, "{:?} at {p:?}: {a} vs {n}", cam.lens);
}

/// unproject(project(x)) over the valid region: rays on a grid of angles up to `max_deg`.
fn round_trip(cam: &CameraModel, max_deg: f64) -> f64 {
    let mut worst: f64 = 0.0;
    for i in 0..=40 {
        let th = (max_deg * f64::from(i) / 40.0).to_radians();
        for j in 0..24 {
            let phi = std::f64::consts::TAU * f64::from(j) / 24.0;
            let d = nalgebra::Vector3::new(th.sin() * phi.cos(), th.sin() * phi.sin(), th.cos());
            let q = cam.project_unchecked(&Point3::from(d));
            let Ok(ray) = cam.unproject(&q) else { panic!("{:?}: no ray at {th} rad", cam.lens) };
            worst = worst.max((ray.normalize() - d).norm());
        }
    }
    worst
}

#[test]
fn round_trips_hold_over_the_valid_region() {
    // The bound: 1e-10 (ray direction, unit vector).
    let cases: [(Lens, f64); 4] = [
        (Lens::OpenCv(Distortion::from_coefficients(OPENCV14)), 45.0),
        (Lens::Fisheye(Fisheye { k: [0.05, -0.01, 0.002, -0.0005] }), 89.0),
        (Lens::DoubleSphere(DoubleSphere { xi: -0.2, alpha: 0.6 }), 89.0),
        (Lens::DoubleSphere(DoubleSphere { xi: 0.3, alpha: 0.4 }), 89.0),
    ];
    for (lens, max_deg) in cases {
        let e = round_trip(&camera([400.0, 400.0, 639.5, 511.5], lens), max_deg);
        assert!(e < 1e-10, "{lens:?}: {e:e}");
    }
}

#[test]
fn outside_the_valid_region_is_not_visible_and_not_invertible() {
    // Fisheye whose theta_d stops growing at ~57 degrees (k1 = -0.3).
    let f = Fisheye { k: [-0.3, 0.0, 0.0, 0.0] };
    let t = f.theta_max();
    // d theta_d / d theta = 1 - 0.9 theta^2 = 0 at theta = sqrt(1/0.9).
    assert!((t - (1.0f64 / 0.9).sqrt()).abs() < 1e-9, "{t}");
    let cam = camera([400.0, 400.0, 639.5, 511.5], Lens::Fisheye(f));
    let beyond = Point3::new((t + 0.1).tan(), 0.0, 1.0);
    assert!(!cam.project(&beyond).in_image);
    let far = Point2::new(639.5 + 400.0 * 0.9, 511.5);
    assert!(cam.unproject(&far).is_err());
    // The (xu, yu, 1) form ends at 89.5 degrees; a fisheye's unit ray goes on to its reach.
    let eq = camera([400.0, 400.0, 639.5, 511.5], Lens::Fisheye(Fisheye::default()));
    assert!((Fisheye::default().theta_max() - FISHEYE_MAX_ANGLE_RAD).abs() < 1e-12);
    let at_100 = Point2::new(639.5 + 400.0 * 100f64.to_radians(), 511.5);
    assert!(eq.unproject(&at_100).is_err());
    let ray = eq.unproject_ray(&at_100).expect("ray at 100 degrees");
    assert!((ray.z.atan2(ray.x) - (-10f64).to_radians()).abs() < 1e-12, "{ray}");
    let ds = DoubleSphere { xi: -0.2, alpha: 0.6 };
    assert!(ds.undistort(&Vector2::new(5.0, 0.0)).is_err());
    assert!(Lens::Fisheye(Fisheye { k: [f64::NAN, 0.0, 0.0, 0.0] }).validate().is_err());
}

#[test]
fn opencv_vector_lengths() {
    assert!(Distortion::from_opencv(&[0.1; 6]).is_err());
    for n in [4, 5, 8, 12, 14] {
        let d = Distortion::from_opencv(&vec![0.01; n]).expect("valid length");
        assert_eq!(d.opencv_len(), n);
    }
    assert_eq!(Distortion::default().opencv_len(), 4);
}

/// A fisheye that reaches 152 degrees (k1 0.02, k2 -0.005).
fn wide_fisheye() -> CameraModel {
    camera([250.0, 252.5, 639.5, 511.5], Lens::Fisheye(Fisheye { k: [0.02, -0.005, 0.0, 0.0] }))
}

/// Points at 60 to 150 degrees from the axis, behind the camera plane from 90 on.
const WIDE_POINTS: [[f64; 3]; 5] = [[0.8, 0.3, 0.5], [0.7, -0.7, 1e-3], [0.9, 0.2, -0.3], [-0.4, 0.5, -0.6], [0.35, -0.2, -0.7]];

#[test]
fn a_fisheye_projects_behind_its_camera_plane_like_kannala_brandt() {
    let cam = wide_fisheye();
    let k = [0.02, -0.005];
    for p in WIDE_POINTS {
        // Kannala and Brandt 2006, eq. 6: theta is the angle of incidence.
        let r = (p[0] * p[0] + p[1] * p[1]).sqrt();
        let th = r.atan2(p[2]);
        let td = th * (1.0 + k[0] * th * th + k[1] * th.powi(4));
        let expect = [250.0 * td * p[0] / r + 639.5, 252.5 * td * p[1] / r + 511.5];
        let q = cam.project(&Point3::new(p[0], p[1], p[2]));
        assert!((q.pixel_px.x - expect[0]).abs() < 1e-9 && (q.pixel_px.y - expect[1]).abs() < 1e-9, "{p:?}: {q:?} vs {expect:?}");
        assert!(q.visible(), "{p:?} at {:.1} deg", th.to_degrees());
        assert_eq!(cam.project_unchecked(&Point3::new(p[0], p[1], p[2])), q.pixel_px);
    }
    // Beyond the reach (160 degrees) and straight behind: not visible, no panic.
    let th = 160f64.to_radians();
    assert!(!cam.project(&Point3::new(th.sin(), 0.0, th.cos())).visible());
    assert!(!cam.project(&Point3::new(0.0, 0.0, -1.0)).visible());
    // The pinhole models do not see behind the camera plane.
    let pin = camera([250.0, 250.0, 639.5, 511.5], Lens::OpenCv(Distortion::default()));
    assert!(!pin.project(&Point3::new(0.9, 0.2, -0.3)).in_front);
}

#[test]
fn wide_fisheye_jacobians_match_central_differences_behind_the_camera_plane() {
    let cam = wide_fisheye();
    for p in WIDE_POINTS {
        check_dq_dp(&cam, p);
        let pt = Point3::new(p[0], p[1], p[2]);
        let ai = cam.dq_dintrinsics(&pt);
        let x0 = [250.0, 252.5, 639.5, 511.5, 0.0, 0.02, -0.005, 0.0, 0.0];
        let ni = central_diff(
            |v| {
                let c = CameraModel {
                    intrinsics: Intrinsics { fx: v[0], fy: v[1], cx: v[2], cy: v[3], skew: v[4] },
                    lens: Lens::Fisheye(Fisheye { k: [v[5], v[6], v[7], v[8]] }),
                    ..cam
                };
                DVector::from_column_slice(c.project_unchecked(&pt).coords.as_slice())
            },
            &DVector::from_column_slice(&x0),
            1e-6,
        );
        let ai = DMatrix::from_fn(2, 9, |i, j| ai[(i, j)]);
        assert!((&ai - &ni).amax() / (1.0 + ni.amax()) < 1e-6, "{p:?}: {ai} vs {ni}");
    }
}

#[test]
fn wide_fisheye_round_trips_to_its_reach() {
    // unproject_ray(project(x)) on a grid of directions up to 150 degrees (the reach is 152):
    // the 1e-10 on the unit ray.
    let cam = wide_fisheye();
    let mut worst: f64 = 0.0;
    for i in 0..=60 {
        let th = (150.0 * f64::from(i) / 60.0).to_radians();
        for j in 0..24 {
            let phi = std::f64::consts::TAU * f64::from(j) / 24.0;
            let d = nalgebra::Vector3::new(th.sin() * phi.cos(), th.sin() * phi.sin(), th.cos());
            let q = cam.project_unchecked(&Point3::from(d));
            let ray = cam.unproject_ray(&q).unwrap_or_else(|e| panic!("no ray at {:.1} deg: {e}", th.to_degrees()));
            worst = worst.max((ray.normalize() - d).norm());
        }
    }
    assert!(worst < 1e-10, "{worst:e}");
}
