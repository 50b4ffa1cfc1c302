//! Stereo rectification as OpenCV's `stereoRectify` computes it with its defaults
//! (`CALIB_ZERO_DISPARITY`, `alpha = -1`): Bouguet's rotations (each camera turned by half the
//! relative rotation, then both about the axis that brings the baseline onto x, or onto y for a
//! vertical pair), one focal length for both (the mean of the cameras' `fy`, or `fx` for a
//! vertical pair), principal points that centre the image corners' undistorted rays, shared by
//! both cameras. `R`, `T` are OpenCV's: `x1 = R x0 + T` (`cam1_from_cam0`).
//!
//! Reference: J.-Y. Bouguet, Camera Calibration Toolbox for Matlab, `rectify_stereo_pair.m`;
//! OpenCV `cvStereoRectify` (calib3d/src/calibration.cpp). The corners are undistorted exactly
//! here (OpenCV iterates a fixed number of times), so strongly distorted corners may move the
//! principal point by a little; fisheye cameras go through the same formulas with their own
//! unprojection (`cv::fisheye::stereoRectify`'s `balance` and `fov_scale` are not modelled).

use nalgebra::{Isometry3, Matrix3, Matrix3x4, Matrix4, Point2, UnitQuaternion, Vector3};
use synthcam_core::camera::CameraModel;

use super::CalibError;

/// What `stereoRectify` returns, OpenCV's names.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct StereoRectification {
    /// `rect0_from_cam0`.
    pub r1: Matrix3<f64>,
    /// `rect1_from_cam1`.
    pub r2: Matrix3<f64>,
    /// Camera 0's projection in the rectified frame, `[f 0 cx 0; 0 f cy 0; 0 0 1 0]`.
    pub p1: Matrix3x4<f64>,
    /// Camera 1's, with `f * baseline` in column 3 of row 0 (row 1 for a vertical pair).
    pub p2: Matrix3x4<f64>,
    /// Disparity-to-depth mapping.
    pub q: Matrix4<f64>,
    /// Whether the baseline is mostly vertical (OpenCV's `idx == 1`).
    pub vertical: bool,
}

impl StereoRectification {
    /// The rectified focal length, px.
    pub fn focal_px(&self) -> f64 {
        self.p1[(0, 0)]
    }
}

/// Bouguet's two rotations and the baseline in the rectified frame (`R2 T`).
fn bouguet_rotations(cam1_from_cam0: &Isometry3<f64>) -> (UnitQuaternion<f64>, UnitQuaternion<f64>, Vector3<f64>, usize) {
    let r_r = UnitQuaternion::from_scaled_axis(-0.5 * cam1_from_cam0.rotation.scaled_axis());
    let t = r_r * cam1_from_cam0.translation.vector;
    let idx = if t.x.abs() > t.y.abs() { 0 } else { 1 };
    let mut uu = Vector3::zeros();
    uu[idx] = if t[idx] > 0.0 { 1.0 } else { -1.0 };
    let ww = t.cross(&uu);
    let w_r = match ww.norm() {
        n if n > 0.0 => UnitQuaternion::from_scaled_axis(ww * ((t[idx].abs() / t.norm()).clamp(-1.0, 1.0).acos() / n)),
        _ => UnitQuaternion::identity(),
    };
    let (r1, r2) = (w_r * r_r.inverse(), w_r * r_r);
    (r1, r2, r2 * cam1_from_cam0.translation.vector, idx)
}

/// The principal point that centres `cam`'s four image corners (`(0, 0)`, `(w-1, 0)`, `(0, h-1)`,
/// `(w-1, h-1)`) after rotation by `rot` and projection with focal `f` (OpenCV's `cc_new`).
fn centring_point(cam: &CameraModel, rot: &UnitQuaternion<f64>, f: f64) -> Result<[f64; 2], CalibError> {
    let (nx, ny) = (f64::from(cam.size.width), f64::from(cam.size.height));
    let mut sum = [0.0; 2];
    for (x, y) in [(0.0, 0.0), (nx - 1.0, 0.0), (0.0, ny - 1.0), (nx - 1.0, ny - 1.0)] {
        let ray =
            cam.unproject_ray(&Point2::new(x, y)).map_err(|e| CalibError::Degenerate { reason: format!("rectification: image corner ({x}, {y}): {e}") })?;
        let v = rot * ray;
        if !(v.z > 0.0) {
            return Err(CalibError::Degenerate { reason: format!("rectification: image corner ({x}, {y}) looks behind the rectified camera") });
        }
        sum[0] += f * v.x / v.z;
        sum[1] += f * v.y / v.z;
    }
    Ok([(nx - 1.0) / 2.0 - sum[0] / 4.0, (ny - 1.0) / 2.0 - sum[1] / 4.0])
}

/// Rectify a stereo pair (module documentation). `cam1_from_cam0` is OpenCV's `(R, T)`.
///
/// # Errors
/// [`CalibError::Degenerate`] for a zero baseline, non-finite input, or an image corner whose
/// ray the rectified camera cannot see.
pub fn stereo_rectify(cam0: &CameraModel, cam1: &CameraModel, cam1_from_cam0: &Isometry3<f64>) -> Result<StereoRectification, CalibError> {
    let t_in = cam1_from_cam0.translation.vector;
    if !(t_in.norm() > 0.0) || !cam1_from_cam0.rotation.coords.iter().all(|v| v.is_finite()) {
        return Err(CalibError::Degenerate { reason: format!("rectification needs a finite, non-zero baseline, got {t_in:?}") });
    }
    let (r1, r2, t, idx) = bouguet_rotations(cam1_from_cam0);
    let fk = |c: &CameraModel| if idx == 0 { c.intrinsics.fy } else { c.intrinsics.fx };
    let f = 0.5 * (fk(cam0) + fk(cam1));
    let (c0, c1) = (centring_point(cam0, &r1, f)?, centring_point(cam1, &r2, f)?);
    let cc = [0.5 * (c0[0] + c1[0]), 0.5 * (c0[1] + c1[1])];
    let p1 = Matrix3x4::new(f, 0.0, cc[0], 0.0, 0.0, f, cc[1], 0.0, 0.0, 0.0, 1.0, 0.0);
    let mut p2 = p1;
    p2[(idx, 3)] = t[idx] * f;
    // Zero disparity: both principal points are the same, so Q's last entry is 0.
    #[rustfmt::skip]
    let q = Matrix4::new(
        1.0, 0.0, 0.0, -cc[0],
        0.0, 1.0, 0.0, -cc[1],
        0.0, 0.0, 0.0, f,
        0.0, 0.0, -1.0 / t[idx], 0.0,
    );
    Ok(StereoRectification { r1: *r1.to_rotation_matrix().matrix(), r2: *r2.to_rotation_matrix().matrix(), p1, p2, q, vertical: idx == 1 })
}

/// The essential and fundamental matrices of `cam1_from_cam0` (OpenCV's `E = [T]x R`,
/// `F = K1^-T E K0^-1`, normalised so that `F[2][2] = 1` where it is not zero, as
/// `stereoCalibrate` returns it).
pub fn essential_fundamental(cam0: &CameraModel, cam1: &CameraModel, cam1_from_cam0: &Isometry3<f64>) -> (Matrix3<f64>, Matrix3<f64>) {
    let t = cam1_from_cam0.translation.vector;
    let e = t.cross_matrix() * cam1_from_cam0.rotation.to_rotation_matrix().matrix();
    let inv = |m: Matrix3<f64>| m.try_inverse().unwrap_or(Matrix3::from_element(f64::NAN));
    let mut f = inv(cam1.intrinsics.matrix()).transpose() * e * inv(cam0.intrinsics.matrix());
    if f[(2, 2)].abs() > 0.0 {
        f /= f[(2, 2)];
    }
    (e, f)
}

#[cfg(test)]
mod tests {
    use super::*;
    use nalgebra::{Matrix3x4, Translation3};
    use synthcam_core::camera::{Distortion, ImageSize, Intrinsics, Lens};

    fn camera(fx: f64, fy: f64, cx: f64, cy: f64, d: [f64; 5]) -> CameraModel {
        CameraModel {
            size: ImageSize { width: 1280, height: 1024 },
            intrinsics: Intrinsics { fx, fy, cx, cy, skew: 0.0 },
            lens: Lens::OpenCv(Distortion::from_array(d)),
        }
    }

    fn assert_close<const R: usize, const C: usize>(what: &str, got: &nalgebra::SMatrix<f64, R, C>, want: &[f64], tol: f64) {
        let want = nalgebra::SMatrix::<f64, R, C>::from_row_slice(want);
        assert!((got - want).abs().max() <= tol, "{what}: got {got}, OpenCV {want}");
    }

    /// Outside values: OpenCV 5.1.0 `cv2.stereoRectify(K1, D1, K2, D2, (1280, 1024), R, T)` with
    /// its defaults, `R = cv2.Rodrigues(np.array([0.005, 0.0349, -0.002]))[0]`, the cameras and `T`
    /// as below (`T` as a 3 x 1 array). OpenCV averages the corners in f32, hence 1e-3 px on the
    /// principal point.
    #[test]
    fn matches_opencv_stereo_rectify_for_horizontal_and_vertical_pairs() {
        let c0 = camera(1100.0, 1105.0, 640.3, 511.7, [-0.15, 0.05, 0.001, -0.0005, 0.0]);
        let c1 = camera(1120.0, 1118.0, 630.0, 520.0, [-0.1, 0.03, 0.0, 0.0, 0.0]);
        let rot = UnitQuaternion::from_scaled_axis(Vector3::new(0.005, 0.0349, -0.002));
        let horizontal = Isometry3::from_parts(Translation3::new(-0.12, 0.002, 0.004), rot);
        let r = stereo_rectify(&c0, &c1, &horizontal).expect("rectify");
        assert!(!r.vertical);
        #[rustfmt::skip]
        let (r1, r2) = (
            [0.9998900619324024, -0.014734839575845277, 0.0016578755955935186, 0.014738728417568037, 0.9998885976312346, -0.002358434157669653, -0.0016229397553616, 0.0023826098541293696, 0.9999958446097831],
            [0.9993062780989564, -0.016655104634982446, -0.03331020926996506, 0.016734036273346214, 0.9998577872637137, 0.0020921945685345405, 0.033270626414502825, -0.0026481574175374525, 0.9994428711438581],
        );
        assert_close("R1", &r.r1, &r1, 1e-12);
        assert_close("R2", &r.r2, &r2, 1e-12);
        let p1: Matrix3x4<f64> = Matrix3x4::new(1111.5, 0.0, 658.0931854248047, 0.0, 0.0, 1111.5, 517.1198043823242, 0.0, 0.0, 0.0, 1.0, 0.0);
        let mut p2 = p1;
        p2[(0, 3)] = -133.47259286085665;
        assert_close("P1", &r.p1, p1.transpose().as_slice(), 1e-3);
        assert_close("P2", &r.p2, p2.transpose().as_slice(), 1e-3);
        assert_close(
            "Q",
            &r.q,
            &[1.0, 0.0, 0.0, -658.0931854248047, 0.0, 1.0, 0.0, -517.1198043823242, 0.0, 0.0, 0.0, 1111.5, 0.0, 0.0, 8.327552317491303, 0.0],
            1e-3,
        );
        let vertical = Isometry3::from_parts(Translation3::new(0.003, -0.1, 0.002), rot);
        let v = stereo_rectify(&c0, &c1, &vertical).expect("rectify");
        assert!(v.vertical);
        #[rustfmt::skip]
        let vr1 = [0.9993550420371169, 0.03162495298179164, 0.017010652659192285, -0.031175802557209767, 0.9991743630602365, -0.026051133143964827, -0.017820473896787654, 0.025504010509529246, 0.9995158708885137];
        assert_close("vertical R1", &v.r1, &vr1, 1e-12);
        let vp2 = [1110.0, 0.0, 634.5289077758789, 0.0, 0.0, 1110.0, 548.8875770568848, -111.07212656647933, 0.0, 0.0, 1.0, 0.0];
        assert_close("vertical P2", &v.p2, &vp2, 1e-3);
        assert!((v.q[(3, 2)] - 9.993506330642175).abs() < 1e-9);
    }

    #[test]
    fn a_zero_baseline_is_a_named_error() {
        let c = camera(1000.0, 1000.0, 640.0, 512.0, [0.0; 5]);
        assert!(matches!(stereo_rectify(&c, &c, &Isometry3::identity()), Err(CalibError::Degenerate { .. })));
        let nan = Isometry3::from_parts(Translation3::new(f64::NAN, 0.0, 0.0), UnitQuaternion::identity());
        assert!(matches!(stereo_rectify(&c, &c, &nan), Err(CalibError::Degenerate { .. })));
    }

    /// E and F against their definition: a point seen by both cameras satisfies x1^T E x0 = 0 and
    /// q1^T F q0 = 0.
    #[test]
    fn epipolar_constraint_holds_for_a_projected_point() {
        let c = camera(1000.0, 1010.0, 640.0, 512.0, [0.0; 5]);
        let cam1_from_cam0 = Isometry3::from_parts(Translation3::new(-0.1, 0.01, 0.0), UnitQuaternion::from_scaled_axis(Vector3::new(0.01, 0.03, 0.0)));
        let (e, f) = essential_fundamental(&c, &c, &cam1_from_cam0);
        for p in [nalgebra::Point3::new(0.1, -0.2, 1.5), nalgebra::Point3::new(-0.3, 0.1, 2.5)] {
            let (x0, x1) = (p.coords / p.z, cam1_from_cam0 * p);
            let x1 = x1.coords / x1.z;
            assert!((x1.transpose() * e * x0)[0].abs() < 1e-12);
            let (q0, q1) = (c.project_unchecked(&p), c.project_unchecked(&(cam1_from_cam0 * p)));
            let (h0, h1) = (Vector3::new(q0.x, q0.y, 1.0), Vector3::new(q1.x, q1.y, 1.0));
            assert!((h1.transpose() * f * h0)[0].abs() < 1e-9);
        }
        assert_eq!(f[(2, 2)], 1.0);
    }
}
