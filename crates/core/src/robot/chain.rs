//! Any serial arm from URDF: the chain of joints from a base link to a tip link, with forward
//! kinematics and the geometric Jacobian.
//!
//! URDF is parsed by `urdf-rs` (openrr). The kinematics are written here on nalgebra 0.35 rather
//! than taken from openrr's `k`: `k` 0.32 pins nalgebra 0.30, so its poses and Jacobians would be
//! another crate's types (converted element by element) and a second nalgebra would be compiled
//! into every build. The chain is a product of fixed joint origins and joint motions, exactly as
//! URDF defines it (ROS REP 103 / the URDF joint specification): `origin` is the child frame in
//! the parent frame at q = 0, `rpy` is `Rz(yaw) Ry(pitch) Rx(roll)`, and the joint rotates about
//! (or slides along) `axis` in the child frame.

use std::collections::HashMap;

use nalgebra::{Isometry3, Matrix6xX, Translation3, Unit, UnitQuaternion, Vector3};

use super::{check_count, Robot, RobotError};

/// How a joint moves.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum JointKind {
    /// About its axis (URDF `revolute` or `continuous`).
    Revolute,
    /// Along its axis (URDF `prismatic`).
    Prismatic,
}

/// One actuated joint of a chain.
#[derive(Debug, Clone, PartialEq)]
pub struct ChainJoint {
    /// The URDF joint name.
    pub name: String,
    /// The joint frame in the previous joint's frame at q = 0 (fixed joints in between folded in).
    pub parent_from_joint: Isometry3<f64>,
    /// Unit axis in the joint frame.
    pub axis: Unit<Vector3<f64>>,
    /// Revolute or prismatic.
    pub kind: JointKind,
    /// Position limits (infinite for `continuous`).
    pub limits: [f64; 2],
    /// Velocity limit (infinite where the URDF gives none).
    pub velocity: f64,
}

/// A serial chain of joints from a base link to a tip link.
#[derive(Debug, Clone, PartialEq)]
pub struct SerialChain {
    /// The URDF robot name.
    pub name: String,
    /// The actuated joints, base first.
    pub joints: Vec<ChainJoint>,
    /// The tip link's frame in the last joint's frame (the fixed joints after it).
    pub last_from_tip: Isometry3<f64>,
}

/// The IRB 1200-5/0.9 URDF shipped in `assets/robots/`.
pub const IRB1200_URDF: &str = include_str!("../../assets/robots/irb1200_5_90.urdf");
/// The UR5e URDF shipped in `assets/robots/`.
pub const UR5E_URDF: &str = include_str!("../../assets/robots/ur5e.urdf");

fn pose(p: &urdf_rs::Pose) -> Isometry3<f64> {
    let [r, pi, y] = p.rpy.0;
    Isometry3::from_parts(Translation3::from(Vector3::from(p.xyz.0)), UnitQuaternion::from_euler_angles(r, pi, y))
}

impl SerialChain {
    /// The chain of `urdf` (URDF XML text) from link `base` to link `tip`.
    ///
    /// # Errors
    /// [`RobotError::Urdf`] when the text does not parse; [`RobotError::Chain`] when `tip` does
    /// not hang below `base`, a joint on the way is neither fixed, revolute, continuous nor
    /// prismatic, or an axis is zero or not finite.
    ///
    /// ```
    /// use synthcam_core::robot::{chain::UR5E_URDF, Robot, SerialChain};
    /// let ur5e = SerialChain::from_urdf(UR5E_URDF, "base_link", "tool0")?;
    /// let tool = ur5e.base_from_tool(&[0.0; 6])?;
    /// // The published zero pose of the UR5e flange: (a2 + a3, -(d4 + d6), d1 - d5).
    /// assert!((tool.translation.vector - nalgebra::Vector3::new(-0.8172, -0.2329, 0.0628)).norm() < 1e-9);
    /// # Ok::<(), synthcam_core::robot::RobotError>(())
    /// ```
    pub fn from_urdf(urdf: &str, base: &str, tip: &str) -> Result<Self, RobotError> {
        let robot = urdf_rs::read_from_string(urdf).map_err(|e| RobotError::Urdf(e.to_string()))?;
        let fail = |reason: String| RobotError::Chain { base: base.to_string(), tip: tip.to_string(), reason };
        let by_child: HashMap<&str, &urdf_rs::Joint> = robot.joints.iter().map(|j| (j.child.link.as_str(), j)).collect();
        // Walk from the tip up to the base, then reverse.
        let mut path = Vec::new();
        let mut link = tip;
        while link != base {
            let joint = by_child.get(link).ok_or_else(|| fail(format!("link {link} has no parent joint on the way to {base}")))?;
            if path.len() > robot.joints.len() {
                return Err(fail("the joints form a loop".into()));
            }
            path.push(*joint);
            link = joint.parent.link.as_str();
        }
        path.reverse();
        let mut joints = Vec::new();
        let mut pending = Isometry3::identity();
        for j in path {
            let kind = match j.joint_type {
                urdf_rs::JointType::Fixed => {
                    pending *= pose(&j.origin);
                    continue;
                }
                urdf_rs::JointType::Revolute | urdf_rs::JointType::Continuous => JointKind::Revolute,
                urdf_rs::JointType::Prismatic => JointKind::Prismatic,
                ref other => return Err(fail(format!("joint {} is {other:?}, not a serial-chain joint", j.name))),
            };
            let axis = Vector3::from(j.axis.xyz.0);
            if !axis.iter().all(|v| v.is_finite()) || axis.norm() < 1e-12 {
                return Err(fail(format!("joint {} has a zero or non-finite axis", j.name)));
            }
            let limits = if j.joint_type == urdf_rs::JointType::Continuous { [f64::NEG_INFINITY, f64::INFINITY] } else { [j.limit.lower, j.limit.upper] };
            let velocity = if j.limit.velocity > 0.0 { j.limit.velocity } else { f64::INFINITY };
            joints.push(ChainJoint {
                name: j.name.clone(),
                parent_from_joint: pending * pose(&j.origin),
                axis: Unit::new_normalize(axis),
                kind,
                limits,
                velocity,
            });
            pending = Isometry3::identity();
        }
        if joints.is_empty() {
            return Err(fail("no actuated joint between the links".into()));
        }
        Ok(Self { name: robot.name, joints, last_from_tip: pending })
    }

    /// `base_from_joint` of every joint (after its motion) and the tip as the last entry.
    fn frames(&self, q: &[f64]) -> Result<Vec<Isometry3<f64>>, RobotError> {
        check_count(&self.name, self.joints.len(), q)?;
        let mut t = Isometry3::identity();
        let mut out = Vec::with_capacity(self.joints.len() + 1);
        for (j, v) in self.joints.iter().zip(q) {
            let motion = match j.kind {
                JointKind::Revolute => Isometry3::from_parts(Translation3::identity(), UnitQuaternion::from_axis_angle(&j.axis, *v)),
                JointKind::Prismatic => Isometry3::from_parts(Translation3::from(j.axis.into_inner() * *v), UnitQuaternion::identity()),
            };
            t = t * j.parent_from_joint * motion;
            out.push(t);
        }
        out.push(t * self.last_from_tip);
        Ok(out)
    }
}

impl Robot for SerialChain {
    fn name(&self) -> &str {
        &self.name
    }

    fn dof(&self) -> usize {
        self.joints.len()
    }

    fn limits_rad(&self) -> Vec<[f64; 2]> {
        self.joints.iter().map(|j| j.limits).collect()
    }

    fn velocity_limits(&self) -> Vec<f64> {
        self.joints.iter().map(|j| j.velocity).collect()
    }

    fn base_from_tool(&self, q: &[f64]) -> Result<Isometry3<f64>, RobotError> {
        let frames = self.frames(q)?;
        Ok(frames[frames.len() - 1])
    }

    fn jacobian(&self, q: &[f64]) -> Result<Matrix6xX<f64>, RobotError> {
        let frames = self.frames(q)?;
        let p_tool = frames[frames.len() - 1].translation.vector;
        let mut jac = Matrix6xX::zeros(self.joints.len());
        for (i, (j, f)) in self.joints.iter().zip(&frames).enumerate() {
            let h = f.rotation * j.axis.into_inner();
            let (w, v) = match j.kind {
                JointKind::Revolute => (h, h.cross(&(p_tool - f.translation.vector))),
                JointKind::Prismatic => (Vector3::zeros(), h),
            };
            jac.fixed_view_mut::<3, 1>(0, i).copy_from(&w);
            jac.fixed_view_mut::<3, 1>(3, i).copy_from(&v);
        }
        Ok(jac)
    }
}

#[cfg(test)]
mod tests;
