//! A robot cell: the robot's base in the world, the camera on its tool, and where it looks from.

use nalgebra::{Isometry3, Matrix3, Translation3, UnitQuaternion, Vector3};

/// A robot cell (the TOML of `assets/scenarios/course.toml`): where the robot's base stands in the
/// world, where the camera is mounted on the tool, and the joint region the robot looks from.
#[derive(Debug, Clone, PartialEq, serde::Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Cell {
    /// Centre of the joint sampling, radians.
    pub q0_rad: [f64; 6],
    /// Uniform perturbation per joint, radians.
    pub spread_rad: f64,
    /// Translation of `world_from_base` (rotation identity), metres.
    pub base_t_m: [f64; 3],
    /// Translation of `tool_from_cam`, metres.
    pub tool_from_cam_t_m: [f64; 3],
    /// Rotation of `tool_from_cam`, rows.
    #[serde(rename = "tool_from_cam_R")]
    pub tool_from_cam_r: [[f64; 3]; 3],
}

impl Default for Cell {
    /// Course variant A.
    fn default() -> Self {
        Self {
            q0_rad: [0.0, 1.6, 3.0, 3.0, 2.0, 0.0],
            spread_rad: 0.25,
            base_t_m: [2.5, 0.0, 0.0],
            tool_from_cam_t_m: [0.0, 0.0, 0.05],
            tool_from_cam_r: [[0.0, 0.0, 1.0], [1.0, 0.0, 0.0], [0.0, 1.0, 0.0]],
        }
    }
}

impl Cell {
    /// The true `tool_from_cam` and `world_from_base`.
    pub fn truth(&self) -> (Isometry3<f64>, Isometry3<f64>) {
        let r = crate::math::so3::project_to_so3(&Matrix3::from_fn(|i, j| self.tool_from_cam_r[i][j]));
        (
            Isometry3::from_parts(Translation3::from(Vector3::from(self.tool_from_cam_t_m)), UnitQuaternion::from_rotation_matrix(&r)),
            Isometry3::from_parts(Translation3::from(Vector3::from(self.base_t_m)), UnitQuaternion::identity()),
        )
    }
}

/// Course variant A truth: `tool_from_cam` and `world_from_base`.
pub fn variant_a() -> (Isometry3<f64>, Isometry3<f64>) {
    Cell::default().truth()
}
