//! Robots: the [`Robot`] trait (joint count, limits, forward kinematics `base_from_tool`, the
//! geometric Jacobian), the course's ABB IRB 1200 ([`Irb1200`], product of exponentials), any
//! serial chain read from URDF ([`SerialChain`]; `assets/robots/` ships the IRB 1200-5/0.9 and a
//! UR5e), and the robot cell ([`Cell`]: the base in the world, the camera on the tool).
//!
//! Jacobian convention, every implementation: 6 x n, rows **[angular; linear]**, in base
//! coordinates, the linear rows the velocity of the tool origin; column i is joint i's
//! contribution, `[h_i; h_i x (p_tool - p_i)]` for a revolute joint about the unit axis `h_i`
//! through `p_i`, `[0; h_i]` for a prismatic one.

pub mod cell;
pub mod chain;
pub mod irb1200;

pub use cell::{variant_a, Cell};
pub use chain::SerialChain;
pub use irb1200::{base_from_tool, check_limits, forward_chain, jacobian, Irb1200, Joints, ACC_LIMITS, AXES, LIMITS_RAD, LINKS, VEL_LIMITS};

use nalgebra::{Isometry3, Matrix6xX};

/// A serial robot arm: what a simulation, a servo law or a hand-eye experiment needs of it.
///
/// Joint vectors are slices of [`Robot::dof`] values (radians for revolute joints, metres for
/// prismatic ones); a wrong length is [`RobotError::JointCount`], never a panic.
pub trait Robot: std::fmt::Debug + Send + Sync {
    /// A short name (`irb1200`, the URDF's robot name).
    fn name(&self) -> &str;
    /// Number of actuated joints.
    fn dof(&self) -> usize;
    /// Lower and upper position limit of every joint.
    fn limits_rad(&self) -> Vec<[f64; 2]>;
    /// Velocity limit of every joint (rad/s or m/s; infinite where the model has none).
    fn velocity_limits(&self) -> Vec<f64>;
    /// Forward kinematics: the tool frame in the base frame.
    ///
    /// # Errors
    /// [`RobotError::JointCount`] for a vector of the wrong length.
    fn base_from_tool(&self, q: &[f64]) -> Result<Isometry3<f64>, RobotError>;
    /// The geometric Jacobian (module docs: 6 x n, rows [angular; linear], base coordinates,
    /// about the tool origin).
    ///
    /// # Errors
    /// [`RobotError::JointCount`] for a vector of the wrong length.
    fn jacobian(&self, q: &[f64]) -> Result<Matrix6xX<f64>, RobotError>;
    /// Check the length, finiteness and position limits of `q`.
    ///
    /// # Errors
    /// The first violation.
    fn check_limits(&self, q: &[f64]) -> Result<(), RobotError> {
        check_count(self.name(), self.dof(), q)?;
        for (joint, (v, [lo, hi])) in q.iter().zip(self.limits_rad()).enumerate() {
            if !v.is_finite() {
                return Err(RobotError::NonFinite { joint });
            }
            if *v < lo || *v > hi {
                return Err(RobotError::OutOfLimits { joint, value_rad: *v, lower: lo, upper: hi });
            }
        }
        Ok(())
    }
}

fn check_count(robot: &str, expected: usize, q: &[f64]) -> Result<(), RobotError> {
    if q.len() == expected {
        Ok(())
    } else {
        Err(RobotError::JointCount { robot: robot.to_string(), expected, got: q.len() })
    }
}

/// A 6-vector from a slice, for the 6-joint models.
fn joints6(q: &[f64]) -> Result<Joints, RobotError> {
    check_count("irb1200", 6, q)?;
    Ok(Joints::from_column_slice(q))
}

/// Errors of the robot model.
#[derive(Debug, thiserror::Error, Clone, PartialEq)]
#[non_exhaustive]
pub enum RobotError {
    /// A joint is outside its limits.
    #[error("joint {joint} at {value_rad:.4} rad is outside [{lower:.3}, {upper:.3}]")]
    OutOfLimits {
        /// Joint index, 0-based.
        joint: usize,
        /// Value.
        value_rad: f64,
        /// Lower limit.
        lower: f64,
        /// Upper limit.
        upper: f64,
    },
    /// A joint value is NaN or infinite.
    #[error("joint {joint} is not finite")]
    NonFinite {
        /// Joint index.
        joint: usize,
    },
    /// A joint vector of the wrong length.
    #[error("{robot} has {expected} joints, got a vector of {got}")]
    JointCount {
        /// The robot's name.
        robot: String,
        /// Its joint count.
        expected: usize,
        /// The vector's length.
        got: usize,
    },
    /// A URDF text that does not parse.
    #[error("URDF does not parse: {0}")]
    Urdf(String),
    /// A URDF whose links do not form a serial chain from the base to the tip link.
    #[error("URDF chain {base} -> {tip}: {reason}")]
    Chain {
        /// Base link.
        base: String,
        /// Tip link.
        tip: String,
        /// Why.
        reason: String,
    },
}

/// Wrap an angle into (-pi, pi].
pub fn wrap(a: f64) -> f64 {
    let t = (a + std::f64::consts::PI).rem_euclid(std::f64::consts::TAU) - std::f64::consts::PI;
    if t <= -std::f64::consts::PI {
        t + std::f64::consts::TAU
    } else {
        t
    }
}
