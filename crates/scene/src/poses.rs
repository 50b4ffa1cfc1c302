//! Pose samplers shared by experiments and datasets.

use nalgebra::{Isometry3, Translation3, UnitQuaternion, Vector3};
use rand::Rng;
use rand_chacha::ChaCha8Rng;
use rand_distr::{Distribution, Normal};

/// `cam_from_target` of one course calibration view (course-scenario 1.3): a rotation of uniform
/// angle in [0, pi/10] about a uniform random axis, the camera at (x, y) uniform in [-0.4, 0.4] m
/// and z uniform in [-6, -3] m in the target frame (the target centred at its origin).
pub fn course_pose(rng: &mut ChaCha8Rng) -> Isometry3<f64> {
    let n = Normal::new(0.0, 1.0).unwrap_or_else(|_| unreachable!());
    let axis = nalgebra::Unit::new_normalize(Vector3::new(n.sample(rng), n.sample(rng), n.sample(rng)));
    let rot = UnitQuaternion::from_axis_angle(&axis, rng.random_range(0.0..std::f64::consts::PI / 10.0));
    let p = Vector3::new(rng.random_range(-0.4..0.4), rng.random_range(-0.4..0.4), rng.random_range(-6.0..-3.0));
    Isometry3::from_parts(Translation3::from(p), rot).inverse()
}
