//! Visual servoing laws of the course (course-scenario 3.7 PBVS, 3.8 IBVS) on the IRB 1200, with
//! the exact image Jacobian d(pixels)/d(q) (tested against finite differences).
//!
//! Frames: `world_from_cam(q) = world_from_base * base_from_tool(q) * tool_from_cam`. The robot
//! Jacobian's rows are [angular; linear] about the tool origin in base coordinates.
//! Reference: F. Chaumette, S. Hutchinson, "Visual servo control, Part I: basic approaches", IEEE
//! RAM 13(4), 2006 (PBVS, IBVS, interaction matrix); the course's PBVS/IBVS drivers.

use nalgebra::{DMatrix, DVector, Isometry3, Matrix3, Matrix6, Point2, Point3, SMatrix, Vector3, Vector6};

use crate::camera::CameraModel;
use crate::robot::{base_from_tool, jacobian, wrap, Joints};

/// PBVS parameters (course defaults: gain 0.3, weights (1, 1, 1, 10, 10, 10), damping 0.01).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct PbvsParams {
    /// Step gain alpha.
    pub gain: f64,
    /// Weights of (rotation, translation) errors; the damping matrix is `damping * diag(1 / w)`.
    pub weights: [f64; 6],
    /// Damping scale.
    pub damping: f64,
}

impl Default for PbvsParams {
    fn default() -> Self {
        Self { gain: 0.3, weights: [1.0, 1.0, 1.0, 10.0, 10.0, 10.0], damping: 0.01 }
    }
}

/// Vector part of the unit quaternion of `r` (sin(theta/2) k); the axis where the angle is pi.
pub fn quaternion_vector(r: &Matrix3<f64>) -> Vector3<f64> {
    let q0 = 0.5 * (r.trace() + 1.0).max(0.0).sqrt();
    let v = Vector3::new(r[(2, 1)] - r[(1, 2)], r[(0, 2)] - r[(2, 0)], r[(1, 0)] - r[(0, 1)]);
    if q0 > 1e-9 {
        v / (4.0 * q0)
    } else {
        nalgebra::Rotation3::from_matrix_unchecked(*r).axis().map_or(Vector3::x(), |a| a.into_inner())
    }
}

/// The PBVS error [qv(R_est R*^T); p_est - p*] of the tool pose.
pub fn pbvs_error(base_from_tool_est: &Isometry3<f64>, base_from_tool_goal: &Isometry3<f64>) -> Vector6<f64> {
    let r = base_from_tool_est.rotation.to_rotation_matrix().into_inner() * base_from_tool_goal.rotation.to_rotation_matrix().into_inner().transpose();
    let qv = quaternion_vector(&r);
    let dp = base_from_tool_est.translation.vector - base_from_tool_goal.translation.vector;
    Vector6::new(qv.x, qv.y, qv.z, dp.x, dp.y, dp.z)
}

/// One PBVS step: q+ = wrap(q - gain J^T (J J^T + D)^-1 e).
pub fn pbvs_step(q: &Joints, error: &Vector6<f64>, params: &PbvsParams) -> Option<Joints> {
    let j = jacobian(q);
    let d = Matrix6::from_diagonal(&Vector6::from_iterator(params.weights.iter().map(|w| params.damping / w)));
    let x = (j * j.transpose() + d).try_inverse()? * error;
    Some((q - params.gain * j.transpose() * x).map(wrap))
}

/// IBVS parameters (course defaults: gain 0.03, halved when sigma_min(J) < 0.1; damping 0.1).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct IbvsParams {
    /// Step gain.
    pub gain: f64,
    /// The gain is halved when the robot Jacobian's smallest singular value is below this.
    pub singular_threshold: f64,
    /// Damped least squares regulariser.
    pub damping: f64,
}

impl Default for IbvsParams {
    fn default() -> Self {
        Self { gain: 0.03, singular_threshold: 0.1, damping: 0.1 }
    }
}

/// Exact d(pixel_j)/d(q) for world points `points` (2N x 6): a world point fixed in space moves in
/// the camera frame as -w_c x p - v_c under the camera's twist, which the robot Jacobian gives.
pub fn image_jacobian(camera: &CameraModel, q: &Joints, world_from_base: &Isometry3<f64>, tool_from_cam: &Isometry3<f64>, points: &[Point3<f64>]) -> DMatrix<f64> {
    let bt = base_from_tool(q);
    let base_from_cam = bt * tool_from_cam;
    let cam_from_world = (world_from_base * base_from_cam).inverse();
    let j = jacobian(q);
    let r_bc = base_from_cam.rotation.to_rotation_matrix().into_inner();
    let lever = base_from_cam.translation.vector - bt.translation.vector;
    let mut out = DMatrix::zeros(2 * points.len(), 6);
    for (k, p) in points.iter().enumerate() {
        let pc = cam_from_world * p;
        let dq_dp: SMatrix<f64, 2, 3> = camera.dq_dp_cam(&pc);
        for i in 0..6 {
            let w = Vector3::new(j[(0, i)], j[(1, i)], j[(2, i)]);
            let v_tool = Vector3::new(j[(3, i)], j[(4, i)], j[(5, i)]);
            let v_cam = v_tool + w.cross(&lever);
            let (wc, vc) = (r_bc.transpose() * w, r_bc.transpose() * v_cam);
            let dp = -wc.cross(&pc.coords) - vc;
            let d = dq_dp * dp;
            out[(2 * k, i)] = d.x;
            out[(2 * k + 1, i)] = d.y;
        }
    }
    out
}

/// One IBVS step from measured and desired pixels (same order):
/// q+ = wrap(q - gain (L^T L + damping I)^-1 L^T (s - s*)).
pub fn ibvs_step(q: &Joints, l: &DMatrix<f64>, measured: &[Point2<f64>], desired: &[Point2<f64>], params: &IbvsParams) -> Option<Joints> {
    let e = DVector::from_iterator(2 * measured.len(), measured.iter().zip(desired).flat_map(|(m, d)| [m.x - d.x, m.y - d.y]));
    let smin = jacobian(q).singular_values().min();
    let gain = if smin < params.singular_threshold { 0.5 * params.gain } else { params.gain };
    let a = l.transpose() * l + DMatrix::identity(6, 6) * params.damping;
    let dq = a.try_inverse()? * (l.transpose() * e);
    Some(Joints::from_iterator((0..6).map(|i| wrap(q[i] - gain * dq[i]))))
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::math::numdiff::central_diff;
    use crate::target::course_s_path;
    use nalgebra::{Translation3, UnitQuaternion};

    fn variant_a() -> (Isometry3<f64>, Isometry3<f64>) {
        let r_tc = Matrix3::from_columns(&[Vector3::y(), Vector3::z(), Vector3::x()]);
        (
            Isometry3::from_parts(Translation3::new(2.5, 0.0, 0.0), UnitQuaternion::identity()),
            Isometry3::from_parts(Translation3::new(0.0, 0.0, 0.05), UnitQuaternion::from_matrix(&r_tc)),
        )
    }

    #[test]
    fn image_jacobian_matches_finite_differences() {
        let cam = CameraModel::course_default();
        let (wb, x) = variant_a();
        let pts = course_s_path().points_m;
        let q = Joints::from_row_slice(&[0.1, 1.6, 3.5 - std::f64::consts::TAU, 3.0, 2.0, 0.0]);
        let f = |v: &DVector<f64>| {
            let qq = Joints::from_column_slice(v.as_slice());
            let cw = (wb * base_from_tool(&qq) * x).inverse();
            DVector::from_iterator(2 * pts.len(), pts.iter().flat_map(|p| {
                let u = cam.project_unchecked(&(cw * p));
                [u.x, u.y]
            }))
        };
        let num = central_diff(f, &DVector::from_column_slice(q.as_slice()), 1e-7);
        let ana = image_jacobian(&cam, &q, &wb, &x, &pts);
        let scale = ana.abs().max();
        // Central differences with h = 1e-7 rad: relative error ~1e-7 of pixel derivatives ~1e3.
        let diff = (num - &ana).abs().max();
        assert!(diff < 1e-5 * scale, "{diff}");
    }

    #[test]
    fn pbvs_converges_in_the_noise_free_course_setting() {
        // course-scenario 1.8 / 3.9: from q0, 30 steps of the PBVS law reduce the error ~190 x.
        let (wb, x) = variant_a();
        let goal_world_from_cam = Isometry3::from_parts(Translation3::new(1.8, 0.0, 0.55), UnitQuaternion::from_matrix(&Matrix3::from_columns(&[-Vector3::y(), Vector3::z(), -Vector3::x()])));
        let goal = wb.inverse() * goal_world_from_cam * x.inverse();
        let mut q = Joints::from_row_slice(&[0.1, 1.6, 3.5, 3.0, 2.0, 0.0]).map(wrap);
        let e0 = pbvs_error(&base_from_tool(&q), &goal).norm();
        for _ in 0..30 {
            let e = pbvs_error(&base_from_tool(&q), &goal);
            q = pbvs_step(&q, &e, &PbvsParams::default()).unwrap();
        }
        let e1 = pbvs_error(&base_from_tool(&q), &goal).norm();
        let final_cam = wb * base_from_tool(&q) * x;
        let dp = (final_cam.translation.vector - goal_world_from_cam.translation.vector).norm();
        eprintln!("PBVS 30 steps: error {e0:.4} -> {e1:.6}, camera position error {:.3} mm", dp * 1e3);
        assert!(e1 < e0 / 100.0);
        assert!(dp < 2e-3);
    }

    #[test]
    fn quaternion_vector_of_known_rotations() {
        let r = nalgebra::Rotation3::from_axis_angle(&Vector3::z_axis(), 0.4).into_inner();
        assert!((quaternion_vector(&r) - Vector3::new(0.0, 0.0, 0.2f64.sin())).norm() < 1e-12);
        let half_turn = nalgebra::Rotation3::from_axis_angle(&Vector3::x_axis(), std::f64::consts::PI).into_inner();
        assert!((quaternion_vector(&half_turn).norm() - 1.0).abs() < 1e-9);
    }
}
