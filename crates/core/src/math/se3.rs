//! The exponential map of SE(3): the pose reached after moving with a constant body twist.
//!
//! Reference: Murray, Li & Sastry, "A Mathematical Introduction to Robotic Manipulation" (1994),
//! sec. 2.3 (eq. 2.36): for a twist `(w, v)` held for time `t`, the rotation is `exp(skew(w t))`
//! and the translation `V(w t) v t` with
//! `V(phi) = I + (1 - cos|phi|) / |phi|^2 skew(phi) + (|phi| - sin|phi|) / |phi|^3 skew(phi)^2`.

use nalgebra::{Isometry3, Matrix3, Translation3, UnitQuaternion, Vector3};

use super::so3::{rotation_from_rvec, skew};

/// The pose `start_from_now` after moving for `t` seconds with the constant body twist
/// `[wx, wy, wz, vx, vy, vz]` (rad/s, m/s, in the moving frame's own axes): a point `p` given
/// in the moving frame at time `t` is `start_from_now * p` in the frame at time 0.
/// Smooth at zero angular velocity (Taylor series); non-finite input gives non-finite poses.
pub fn exp_twist(twist: &[f64; 6], t: f64) -> Isometry3<f64> {
    let phi = Vector3::new(twist[0], twist[1], twist[2]) * t;
    let rho = Vector3::new(twist[3], twist[4], twist[5]) * t;
    let a2 = phi.norm_squared();
    let a = a2.sqrt();
    let (b, c) = if a < 1e-4 { (0.5 - a2 / 24.0, 1.0 / 6.0 - a2 / 120.0) } else { ((1.0 - a.cos()) / a2, (a - a.sin()) / (a2 * a)) };
    let k = skew(&phi);
    let v = Matrix3::identity() + k * b + k * k * c;
    let rot = UnitQuaternion::from_rotation_matrix(&rotation_from_rvec(&phi));
    Isometry3::from_parts(Translation3::from(v * rho), rot)
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Integrating the body twist with many small steps (the definition of the exponential)
    /// reaches the closed form's pose.
    #[test]
    fn exp_twist_matches_stepwise_integration() {
        let twist = [0.3, -0.7, 1.1, 0.2, 0.05, -0.4];
        let t = 0.8;
        let n = 20_000;
        let mut pose = Isometry3::identity();
        for _ in 0..n {
            let dt = t / f64::from(n);
            let w = Vector3::new(twist[0], twist[1], twist[2]) * dt;
            let step = Isometry3::from_parts(Translation3::new(twist[3] * dt, twist[4] * dt, twist[5] * dt), UnitQuaternion::from_scaled_axis(w));
            pose *= step;
        }
        let closed = exp_twist(&twist, t);
        assert!((closed.translation.vector - pose.translation.vector).norm() < 1e-4, "{closed} vs {pose}");
        assert!(closed.rotation.angle_to(&pose.rotation) < 1e-6);
        // Pure translation and the small-angle branch.
        let p = exp_twist(&[0.0, 0.0, 0.0, 1.0, 2.0, 3.0], 0.5);
        assert!((p.translation.vector - Vector3::new(0.5, 1.0, 1.5)).norm() < 1e-15);
    }
}
