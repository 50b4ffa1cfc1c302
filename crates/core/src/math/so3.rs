//! Rotation utilities on SO(3): the skew (hat) operator, Rodrigues vectors in
//! OpenCV's `rvec` convention (axis * angle, angle in [0, pi]) that stay
//! accurate near 0 and near pi, and projection of a 3x3 matrix onto SO(3).
//!
//! Reference: OpenCV calib3d docs, `cv::Rodrigues`; Murray, Li & Sastry, "A
//! Mathematical Introduction to Robotic Manipulation" (1994), sec. 2.2;
//! Arun, Huang & Blostein 1987 (SVD projection onto SO(3)).

use nalgebra::{Matrix3, Rotation3, Vector3};

/// Skew-symmetric (hat) matrix of `v`, so that `skew(v) * w == v.cross(&w)`.
pub fn skew(v: &Vector3<f64>) -> Matrix3<f64> {
    Matrix3::new(0.0, -v.z, v.y, v.z, 0.0, -v.x, -v.y, v.x, 0.0)
}

/// Rotation matrix of the Rodrigues vector `rvec` (axis * angle in radians),
/// `R = I + A [r]x + B [r]x^2` with `A = sin t / t`, `B = (1 - cos t) / t^2`.
///
/// Uses Taylor series for small angles, so it is smooth at `rvec = 0`.
/// Non-finite input yields a non-finite matrix (no panic).
pub fn rotation_from_rvec(rvec: &Vector3<f64>) -> Rotation3<f64> {
    let t2 = rvec.norm_squared();
    let t = t2.sqrt();
    let (a, b) = if t < 1e-4 {
        // Truncation error of the series is O(t^4) < 1e-16.
        (1.0 - t2 / 6.0, 0.5 - t2 / 24.0)
    } else {
        (t.sin() / t, (1.0 - t.cos()) / t2)
    };
    let k = skew(rvec);
    Rotation3::from_matrix_unchecked(Matrix3::identity() + k * a + k * k * b)
}

/// Rodrigues vector (OpenCV `rvec`: unit axis times angle in [0, pi]) of `r`.
///
/// The angle is computed with `atan2(|w|, (tr R - 1) / 2)` where `w` is the
/// axial vector of the antisymmetric part; for angles near pi the axis is taken
/// from the symmetric part `(R + R^T)/2 - cos(t) I = (1 - cos t) a a^T`, which
/// stays well conditioned there. At exactly pi the sign of the axis is
/// arbitrary (both vectors describe the same rotation).
pub fn rvec_from_rotation(r: &Rotation3<f64>) -> Vector3<f64> {
    let m = r.matrix();
    let w = Vector3::new(0.5 * (m[(2, 1)] - m[(1, 2)]), 0.5 * (m[(0, 2)] - m[(2, 0)]), 0.5 * (m[(1, 0)] - m[(0, 1)]));
    let c = (0.5 * (m.trace() - 1.0)).clamp(-1.0, 1.0);
    let s = w.norm();
    let theta = s.atan2(c);
    if c > -0.5 {
        // theta < 120 degrees: sin(theta) is not small unless theta is small.
        let factor = if s < 1e-6 { 1.0 + theta * theta / 6.0 } else { theta / s };
        return w * factor;
    }
    // Near pi: recover the axis from the symmetric part.
    let sym = 0.5 * (m + m.transpose()) - Matrix3::identity() * c;
    let mut best = 0;
    for i in 1..3 {
        if sym[(i, i)] > sym[(best, best)] {
            best = i;
        }
    }
    let col: Vector3<f64> = sym.column(best).into_owned();
    let n = col.norm();
    if n.is_nan() || n <= 0.0 {
        return w; // non-finite input; propagate without panicking
    }
    let mut axis = col / n;
    if axis.dot(&w) < 0.0 {
        axis = -axis;
    }
    axis * theta
}

/// Closest rotation to `m` in the Frobenius norm: `U diag(1, 1, det(U V^T)) V^T`
/// from the SVD `m = U S V^T`, so the result always has determinant +1.
///
/// If the SVD fails (non-finite input) the identity is returned; callers that
/// can receive non-finite data should check `m` first.
pub fn project_to_so3(m: &Matrix3<f64>) -> Rotation3<f64> {
    if !m.iter().all(|v| v.is_finite()) {
        return Rotation3::identity();
    }
    let Some(svd) = m.try_svd(true, true, f64::EPSILON, 0) else {
        return Rotation3::identity();
    };
    let (Some(u), Some(vt)) = (svd.u, svd.v_t) else {
        return Rotation3::identity();
    };
    let d = (u * vt).determinant();
    let sign = if d < 0.0 { -1.0 } else { 1.0 };
    let mid = Matrix3::from_diagonal(&Vector3::new(1.0, 1.0, sign));
    Rotation3::from_matrix_unchecked(u * mid * vt)
}

#[cfg(test)]
mod tests {
    use super::*;
    use std::f64::consts::{FRAC_PI_2, PI};

    fn rot_err(a: &Rotation3<f64>, b: &Rotation3<f64>) -> f64 {
        (a.matrix() - b.matrix()).amax()
    }

    #[test]
    fn skew_is_cross_product() {
        let v = Vector3::new(0.3, -1.2, 2.0);
        let w = Vector3::new(-0.7, 0.4, 0.9);
        assert!((skew(&v) * w - v.cross(&w)).amax() < 1e-15);
    }

    #[test]
    fn known_rotation_about_z() {
        // 90 degrees about +z maps x to y: exact matrix, rounding ~1e-16.
        let r = rotation_from_rvec(&Vector3::new(0.0, 0.0, FRAC_PI_2));
        let expect = Matrix3::new(0.0, -1.0, 0.0, 1.0, 0.0, 0.0, 0.0, 0.0, 1.0);
        assert!((r.matrix() - expect).amax() < 1e-15);
        let back = rvec_from_rotation(&r);
        assert!((back - Vector3::new(0.0, 0.0, FRAC_PI_2)).amax() < 1e-15);
    }

    #[test]
    fn matches_nalgebra_scaled_axis() {
        // Independent implementation; rounding-level agreement expected.
        let v = Vector3::new(0.4, -0.9, 1.3);
        let r = rotation_from_rvec(&v);
        let n = Rotation3::from_scaled_axis(v);
        assert!(rot_err(&r, &n) < 1e-14);
    }

    #[test]
    fn round_trips_generic_small_and_near_pi() {
        let axes =
            [Vector3::new(1.0, 0.0, 0.0), Vector3::new(0.0, -1.0, 0.0), Vector3::new(0.3, -0.5, 0.81).normalize(), Vector3::new(-0.6, 0.2, -0.3).normalize()];
        let angles = [0.0, 1e-12, 1e-7, 1e-4, 0.3, 1.5, 2.5, 3.0, PI - 1e-4, PI - 1e-8];
        for a in &axes {
            for &t in &angles {
                let v = a * t;
                let back = rvec_from_rotation(&rotation_from_rvec(&v));
                // Near pi the axis is recovered from a rank-1 matrix whose
                // scale is ~2, so the error stays at rounding level; 1e-9 is
                // loose enough for atan2 conditioning, tight enough to catch
                // a sign flip or a wrong branch (errors of order t).
                assert!((back - v).amax() < 1e-9, "axis {a:?} angle {t}: got {back:?}");
            }
        }
    }

    #[test]
    fn exactly_pi_gives_equivalent_rotation() {
        let v = Vector3::new(0.0, 0.6, 0.8) * PI;
        let r = rotation_from_rvec(&v);
        let back = rvec_from_rotation(&r);
        assert!((back.norm() - PI).abs() < 1e-12);
        assert!(rot_err(&rotation_from_rvec(&back), &r) < 1e-12);
    }

    #[test]
    fn projection_onto_so3() {
        let r = rotation_from_rvec(&Vector3::new(0.2, -0.4, 0.7));
        let noisy = r.matrix() + Matrix3::new(1e-3, -2e-3, 0.0, 5e-4, 0.0, 1e-3, 0.0, -1e-3, 2e-3);
        let p = project_to_so3(&noisy);
        let m = p.matrix();
        assert!((m.transpose() * m - Matrix3::identity()).amax() < 1e-12);
        assert!((m.determinant() - 1.0).abs() < 1e-12);
        // Perturbation is O(1e-3); the projection must stay within that.
        assert!(rot_err(&p, &r) < 3e-3);
        // Exact rotation is a fixed point.
        assert!(rot_err(&project_to_so3(r.matrix()), &r) < 1e-12);
        // A reflection is mapped to a proper rotation.
        let refl = Matrix3::from_diagonal(&Vector3::new(1.0, 1.0, -1.0));
        assert!((project_to_so3(&refl).matrix().determinant() - 1.0).abs() < 1e-12);
        // Non-finite input does not panic.
        let _ = project_to_so3(&Matrix3::from_element(f64::NAN));
    }
}
