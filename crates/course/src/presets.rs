//! The course's own choices, named here so that the layers below need not know them.

use nalgebra::{Isometry3, Matrix3, Translation3, UnitQuaternion, Vector3};
use rand::Rng;
use rand_chacha::ChaCha8Rng;
use rand_distr::{Distribution, Normal};
use synthcam_core::camera::CameraModel;
use synthcam_geometry::handeye::{linear_known_rotations, HandEyeError, HandEyeResult};
use synthcam_geometry::servo::{Gain, IbvsParams, InteractionFrom};

/// The course camera: [`CameraModel::sxga_1500px`] (1280 x 1024 pixels, `fx = fy = 1500`,
/// `cx = 640`, `cy = 512`, no distortion, no skew).
pub fn camera() -> CameraModel {
    CameraModel::sxga_1500px()
}

/// The course's IBVS law exactly: constant gain 0.03, the gain halved below a robot-Jacobian
/// singular value of 0.1, damping 0.1, the interaction matrix at the current features.
pub fn ibvs_params() -> IbvsParams {
    IbvsParams { gain: Gain::Constant(0.03), singular_threshold: 0.1, damping: 0.1, interaction: InteractionFrom::Current }
}

/// The course's linear hand-eye solver (course-scenario 1.7, 3.6): the translations of
/// `tool_from_cam` and `world_from_base` with the rotations `r_tool_cam` and `R_0B = I` known,
/// `[R_BT,i  I] [p_TC; p_0B] = p_0C,i - p_BT,i`.
///
/// # Errors
/// Fewer than 2 views, or views whose tool rotations do not separate the two translations.
pub fn handeye_linear(base_from_tool: &[Isometry3<f64>], world_from_cam: &[Isometry3<f64>], r_tool_cam: &Matrix3<f64>) -> Result<HandEyeResult, HandEyeError> {
    linear_known_rotations(base_from_tool, world_from_cam, r_tool_cam, &Matrix3::identity())
}

/// `cam_from_target` of one course calibration view (course-scenario 1.3): a rotation of uniform
/// angle in [0, pi/10] about a uniform random axis, the camera at (x, y) uniform in [-0.4, 0.4] m
/// and z uniform in [-6, -3] m in the target frame (the target centred at its origin).
pub fn calibration_pose(rng: &mut ChaCha8Rng) -> Isometry3<f64> {
    let n = Normal::new(0.0, 1.0).unwrap_or_else(|_| unreachable!());
    let axis = nalgebra::Unit::new_normalize(Vector3::new(n.sample(rng), n.sample(rng), n.sample(rng)));
    let rot = UnitQuaternion::from_axis_angle(&axis, rng.random_range(0.0..std::f64::consts::PI / 10.0));
    let p = Vector3::new(rng.random_range(-0.4..0.4), rng.random_range(-0.4..0.4), rng.random_range(-6.0..-3.0));
    Isometry3::from_parts(Translation3::from(p), rot).inverse()
}

#[cfg(test)]
mod tests {
    use super::*;
    use rand::SeedableRng;

    #[test]
    fn calibration_poses_stay_in_the_courses_ranges() {
        let mut rng = ChaCha8Rng::seed_from_u64(7);
        for _ in 0..200 {
            let target_from_cam = calibration_pose(&mut rng).inverse();
            let p = target_from_cam.translation.vector;
            assert!(p.x.abs() <= 0.4 && p.y.abs() <= 0.4 && (-6.0..=-3.0).contains(&p.z), "{p:?}");
            assert!(target_from_cam.rotation.angle() <= std::f64::consts::PI / 10.0 + 1e-12);
        }
    }
}
