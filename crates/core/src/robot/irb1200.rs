//! The ABB IRB 1200-5/0.9 as a product of exponentials (course-scenario 1.5): forward kinematics
//! `base_from_tool(q)`, the 6 x 6 geometric Jacobian, joint limits.
//!
//! Conventions: joint axes H = [ez, ey, ey, ex, ey, ex]; link vectors P (metres) in the frame of
//! the previous joint; the tool frame at q = 0 has the base orientation and sits at
//! (0.533, 0, 0.8891). The Jacobian's rows are **[angular; linear]** (the course's and the
//! general-robotics-toolbox order), in base coordinates, about the tool origin.
//! Reference: Lynch & Park, Modern Robotics, 2017, ch. 4-5 (POE, space Jacobian); ABB IRB 1200
//! product specification and ROS-Industrial `abb_irb1200_support` (limits).

use nalgebra::{Isometry3, Matrix6, Matrix6xX, SVector, Translation3, Unit, UnitQuaternion, Vector3};

#[cfg(test)]
use super::wrap;
use super::{joints6, Robot, RobotError};

/// Joint vector.
pub type Joints = SVector<f64, 6>;

/// Joint axes in their own frames (all revolute).
pub const AXES: [[f64; 3]; 6] = [[0.0, 0.0, 1.0], [0.0, 1.0, 0.0], [0.0, 1.0, 0.0], [1.0, 0.0, 0.0], [0.0, 1.0, 0.0], [1.0, 0.0, 0.0]];
/// Link vectors p01 .. p56 and p6T, metres.
pub const LINKS: [[f64; 3]; 7] = [[0.0, 0.0, 0.3991], [0.0; 3], [0.0, 0.0, 0.448], [0.451, 0.0, 0.042], [0.0; 3], [0.0; 3], [0.082, 0.0, 0.0]];
/// Lower and upper position limits, radians (course-scenario 1.5 table, as published: +-6.283 is
/// the datasheet's rounded 360 degrees, not TAU).
#[allow(clippy::approx_constant)]
pub const LIMITS_RAD: [[f64; 2]; 6] = [[-2.967, 2.967], [-1.745, 2.269], [-3.491, 1.222], [-4.712, 4.712], [-2.269, 2.269], [-6.283, 6.283]];
/// Velocity limits, rad/s.
pub const VEL_LIMITS: [f64; 6] = [5.027, 4.189, 5.236, 6.981, 7.069, 10.472];
/// Acceleration limits, rad/s^2.
pub const ACC_LIMITS: [f64; 6] = [10.0, 15.0, 15.0, 20.0, 20.0, 20.0];

/// Check every joint against [`LIMITS_RAD`].
///
/// # Errors
/// The first joint out of its limits, or not finite.
pub fn check_limits(q: &Joints) -> Result<(), RobotError> {
    for (joint, (v, [lo, hi])) in q.iter().zip(LIMITS_RAD).enumerate() {
        if !v.is_finite() {
            return Err(RobotError::NonFinite { joint });
        }
        if *v < lo || *v > hi {
            return Err(RobotError::OutOfLimits { joint, value_rad: *v, lower: lo, upper: hi });
        }
    }
    Ok(())
}

/// Frames of every joint and of the tool in the base frame: `base_from_joint[i]` for i = 0..6
/// (joint i+1's frame, after its rotation) and the tool as the last entry.
pub fn forward_chain(q: &Joints) -> [Isometry3<f64>; 7] {
    let mut t = Isometry3::identity();
    let mut out = [Isometry3::identity(); 7];
    for i in 0..6 {
        let axis = Unit::new_normalize(Vector3::from(AXES[i]));
        t = t * Translation3::from(Vector3::from(LINKS[i])) * UnitQuaternion::from_axis_angle(&axis, q[i]);
        out[i] = t;
    }
    out[6] = t * Translation3::from(Vector3::from(LINKS[6]));
    out
}

/// `base_from_tool(q)`.
pub fn base_from_tool(q: &Joints) -> Isometry3<f64> {
    forward_chain(q)[6]
}

/// Geometric Jacobian, rows [angular; linear], base coordinates, about the tool origin:
/// column i = [h_i; h_i x (p_tool - p_i)].
pub fn jacobian(q: &Joints) -> Matrix6<f64> {
    let chain = forward_chain(q);
    let p_tool = chain[6].translation.vector;
    let mut j = Matrix6::zeros();
    for i in 0..6 {
        let h = chain[i].rotation * Vector3::from(AXES[i]);
        let p = chain[i].translation.vector;
        let v = h.cross(&(p_tool - p));
        j.fixed_view_mut::<3, 1>(0, i).copy_from(&h);
        j.fixed_view_mut::<3, 1>(3, i).copy_from(&v);
    }
    j
}

/// The course's IRB 1200-5/0.9 as a [`Robot`] (the free functions of this module behind the trait).
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq)]
pub struct Irb1200;

impl Robot for Irb1200 {
    fn name(&self) -> &str {
        "irb1200"
    }

    fn dof(&self) -> usize {
        6
    }

    fn limits_rad(&self) -> Vec<[f64; 2]> {
        LIMITS_RAD.to_vec()
    }

    fn velocity_limits(&self) -> Vec<f64> {
        VEL_LIMITS.to_vec()
    }

    fn base_from_tool(&self, q: &[f64]) -> Result<Isometry3<f64>, RobotError> {
        Ok(base_from_tool(&joints6(q)?))
    }

    fn jacobian(&self, q: &[f64]) -> Result<Matrix6xX<f64>, RobotError> {
        Ok(Matrix6xX::from_column_slice(jacobian(&joints6(q)?).as_slice()))
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::math::numdiff::central_diff;
    use crate::math::so3::rvec_from_rotation;
    use nalgebra::DVector;

    #[test]
    fn zero_pose_matches_the_spec() {
        // course-scenario 1.5 / 3.9: q = 0 puts the tool at (0.533, 0, 0.8891) with R = I.
        let t = base_from_tool(&Joints::zeros());
        assert!((t.translation.vector - Vector3::new(0.533, 0.0, 0.8891)).norm() < 1e-12);
        assert!(t.rotation.angle() < 1e-12);
    }

    #[test]
    fn jacobian_matches_finite_differences() {
        for q in [Joints::from_row_slice(&[0.1, 1.6, 3.5, 3.0, 2.0, 0.0]), Joints::from_row_slice(&[0.3, -0.4, 0.7, 1.2, -0.9, 2.5])] {
            let t0 = base_from_tool(&q);
            // Linear rows: finite differences of the position. Angular rows: of the rotation
            // vector of R(q) R(q0)^T (the spatial angular velocity).
            let f = |x: &DVector<f64>| {
                let t = base_from_tool(&Joints::from_column_slice(x.as_slice()));
                let w = rvec_from_rotation(&(t.rotation * t0.rotation.inverse()).to_rotation_matrix());
                DVector::from_column_slice(&[w.x, w.y, w.z, t.translation.x, t.translation.y, t.translation.z])
            };
            let num = central_diff(f, &DVector::from_column_slice(q.as_slice()), 1e-6);
            let ana = jacobian(&q);
            // h = 1e-6 central differences: ~1e-10 truncation error at these link lengths.
            assert!((num - nalgebra::DMatrix::from_column_slice(6, 6, ana.as_slice())).abs().max() < 1e-8);
        }
    }

    #[test]
    fn limits_and_wrapping() {
        assert!(check_limits(&Joints::zeros()).is_ok());
        let q0 = Joints::from_row_slice(&[0.1, 1.6, 3.5, 3.0, 2.0, 0.0]);
        assert!(matches!(check_limits(&q0), Err(RobotError::OutOfLimits { joint: 2, .. })));
        // Wrapped, the course's start is inside the limits (course-scenario 1.5 note).
        let wrapped = q0.map(wrap);
        assert!((wrapped[2] - (3.5 - std::f64::consts::TAU)).abs() < 1e-12);
        assert!(check_limits(&wrapped).is_ok());
        assert!(matches!(check_limits(&Joints::from_row_slice(&[f64::NAN, 0.0, 0.0, 0.0, 0.0, 0.0])), Err(RobotError::NonFinite { joint: 0 })));
        assert_eq!(wrap(std::f64::consts::PI), std::f64::consts::PI);
        assert!((wrap(-std::f64::consts::PI) - std::f64::consts::PI).abs() < 1e-15);
    }

    #[test]
    fn variant_a_camera_pose_at_q0() {
        // course-scenario 3.9: variant A at q0 puts the camera at about (2.992, 0.063, 0.866).
        let q0 = Joints::from_row_slice(&[0.1, 1.6, 3.5, 3.0, 2.0, 0.0]);
        let world_from_base = Isometry3::from_parts(Translation3::new(2.5, 0.0, 0.0), UnitQuaternion::identity());
        let r_tc = nalgebra::Matrix3::from_columns(&[Vector3::y(), Vector3::z(), Vector3::x()]);
        let tool_from_cam = Isometry3::from_parts(Translation3::new(0.0, 0.0, 0.05), UnitQuaternion::from_matrix(&r_tc));
        let world_from_cam = world_from_base * base_from_tool(&q0) * tool_from_cam;
        let p = world_from_cam.translation.vector;
        assert!((p - Vector3::new(2.992, 0.063, 0.866)).norm() < 2e-3, "{p}");
    }
}
