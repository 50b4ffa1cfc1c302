//! Visual servoing laws of the course (course-scenario 3.7 PBVS, 3.8 IBVS) on the IRB 1200, with
//! the exact image Jacobian d(pixels)/d(q) (tested against finite differences).
//!
//! Frames: `world_from_cam(q) = world_from_base * base_from_tool(q) * tool_from_cam`. The robot
//! Jacobian's rows are [angular; linear] about the tool origin in base coordinates.
//! Reference: F. Chaumette, S. Hutchinson, "Visual servo control, Part I: basic approaches", IEEE
//! RAM 13(4), 2006 (PBVS, IBVS, interaction matrix); the course's PBVS/IBVS drivers.

use nalgebra::{DMatrix, DVector, Isometry3, Matrix3, Matrix6, Matrix6xX, Point2, Point3, SMatrix, Vector3, Vector6};

use synthcam_core::camera::CameraModel;
use synthcam_core::robot::{base_from_tool, jacobian, wrap, Joints};

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

/// One PBVS step on the IRB 1200: q+ = wrap(q + [`pbvs_increment`]).
pub fn pbvs_step(q: &Joints, error: &Vector6<f64>, params: &PbvsParams) -> Option<Joints> {
    let j = Matrix6xX::from_column_slice(jacobian(q).as_slice());
    let dq = pbvs_increment(&j, error, params)?;
    Some(Joints::from_iterator((0..6).map(|i| wrap(q[i] + dq[i]))))
}

/// The PBVS joint increment of any arm: `-gain J^T (J J^T + D)^-1 e`, `J` the 6 x n geometric
/// Jacobian ([`synthcam_core::robot::Robot::jacobian`]), `e` from [`pbvs_error`]. Divided by the control
/// period it is the joint-velocity command. `None` when `J J^T + D` is singular.
pub fn pbvs_increment(j: &Matrix6xX<f64>, error: &Vector6<f64>, params: &PbvsParams) -> Option<DVector<f64>> {
    let d = Matrix6::from_diagonal(&Vector6::from_iterator(params.weights.iter().map(|w| params.damping / w)));
    let x = (j * j.transpose() + d).try_inverse()? * error;
    Some(-params.gain * (j.transpose() * x))
}

/// Step gain of IBVS: the course's constant, or ViSP's adaptive gain (`vpAdaptiveGain`),
/// `lambda(x) = (l0 - linf) exp(-slope x / (l0 - linf)) + linf`, with `x` the RMS pixel error:
/// `linf` far from the goal, rising to `l0` near it, so the last pixels converge quickly.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum Gain {
    /// A constant gain.
    Constant(f64),
    /// ViSP's adaptive gain.
    Adaptive {
        /// Gain at zero error.
        at_zero: f64,
        /// Gain at infinite error.
        at_infinity: f64,
        /// Slope of the gain at zero error, per pixel.
        slope_at_zero: f64,
    },
}

impl Gain {
    /// The gain at RMS pixel error `x`.
    pub fn at(&self, x: f64) -> f64 {
        match *self {
            Gain::Constant(g) => g,
            Gain::Adaptive { at_zero, at_infinity, slope_at_zero } => {
                let span = at_zero - at_infinity;
                if span.abs() < 1e-12 {
                    at_infinity
                } else {
                    span * (-slope_at_zero * x / span).exp() + at_infinity
                }
            }
        }
    }
}

/// Where the interaction matrix's depths and point coordinates come from (Chaumette-Hutchinson
/// 2006, section IV-B): the current pose estimate, the desired pose, or the mean of both matrices.
#[derive(Debug, Clone, Copy, PartialEq, Eq, serde::Serialize, serde::Deserialize)]
#[serde(rename_all = "kebab-case")]
pub enum InteractionFrom {
    /// `L(s)` at the current pose estimate (the course).
    Current,
    /// `L(s*)` at the desired pose.
    Desired,
    /// `(L(s) + L(s*)) / 2`.
    Mean,
}

/// IBVS parameters. Course: constant gain 0.03, halved when sigma_min(J) < 0.1, damping 0.1 px^2,
/// current interaction matrix. The default keeps the course's gain far from the goal and rises to
/// 0.3 near it (adaptive gain), so that 200 steps reach sub-pixel error; and damps with 100 px^2:
/// from the course's start the pixel-straight-line motion passes within sigma_min(J) ~ 3e-4 of
/// the shoulder singularity (step ~19), where 0.1 px^2 lets one step swing joint 1 by 1.5 rad and
/// lose the target, while 100 px^2 (sigma_min of the image Jacobian is ~120 px/rad at the goal)
/// bounds the step and barely slows the convergence.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct IbvsParams {
    /// Step gain.
    pub gain: Gain,
    /// The gain is halved when the robot Jacobian's smallest singular value is below this.
    pub singular_threshold: f64,
    /// Damped least squares regulariser.
    pub damping: f64,
    /// Interaction matrix.
    pub interaction: InteractionFrom,
}

impl Default for IbvsParams {
    fn default() -> Self {
        Self {
            gain: Gain::Adaptive { at_zero: 0.3, at_infinity: 0.03, slope_at_zero: 0.03 },
            damping: 100.0,
            singular_threshold: 0.1,
            interaction: InteractionFrom::Current,
        }
    }
}

/// The camera's twist per joint rate at `q` on the IRB 1200 ([`cam_twist_jacobian_of`]).
pub fn cam_twist_jacobian(q: &Joints, tool_from_cam: &Isometry3<f64>) -> Matrix6<f64> {
    let j = Matrix6xX::from_column_slice(jacobian(q).as_slice());
    Matrix6::from_column_slice(cam_twist_jacobian_of(&base_from_tool(q), &j, tool_from_cam).as_slice())
}

/// The camera's twist per joint rate of any arm, in camera coordinates: column i is (v_c; w_c)
/// of joint i (translation of the camera centre, then rotation), from the arm's tool pose
/// `base_from_tool` and its geometric Jacobian `j` (6 x n, [angular; linear] about the tool).
pub fn cam_twist_jacobian_of(base_from_tool: &Isometry3<f64>, j: &Matrix6xX<f64>, tool_from_cam: &Isometry3<f64>) -> Matrix6xX<f64> {
    let base_from_cam = base_from_tool * tool_from_cam;
    let r_bc = base_from_cam.rotation.to_rotation_matrix().into_inner();
    let lever = base_from_cam.translation.vector - base_from_tool.translation.vector;
    let mut out = Matrix6xX::zeros(j.ncols());
    for i in 0..j.ncols() {
        let w = Vector3::new(j[(0, i)], j[(1, i)], j[(2, i)]);
        let v_tool = Vector3::new(j[(3, i)], j[(4, i)], j[(5, i)]);
        let (vc, wc) = (r_bc.transpose() * (v_tool + w.cross(&lever)), r_bc.transpose() * w);
        out.fixed_view_mut::<3, 1>(0, i).copy_from(&vc);
        out.fixed_view_mut::<3, 1>(3, i).copy_from(&wc);
    }
    out
}

/// d(pixels)/d(camera twist) (2N x 6) for points `points_cam` given in camera coordinates: a
/// point fixed in space moves in the camera frame as `-w x p - v` (the interaction matrix of
/// Chaumette-Hutchinson 2006 through the full camera model, distortion included).
pub fn interaction_matrix(camera: &CameraModel, points_cam: &[Point3<f64>]) -> DMatrix<f64> {
    let mut out = DMatrix::zeros(2 * points_cam.len(), 6);
    for (k, pc) in points_cam.iter().enumerate() {
        let dq_dp: SMatrix<f64, 2, 3> = camera.dq_dp_cam(pc);
        let p = pc.coords;
        // dp/dv = -I, dp/dw_i = p x e_i.
        let dp_dtwist = SMatrix::<f64, 3, 6>::from_columns(&[
            -Vector3::x(),
            -Vector3::y(),
            -Vector3::z(),
            p.cross(&Vector3::x()),
            p.cross(&Vector3::y()),
            p.cross(&Vector3::z()),
        ]);
        out.fixed_view_mut::<2, 6>(2 * k, 0).copy_from(&(dq_dp * dp_dtwist));
    }
    out
}

/// Exact d(pixel_j)/d(q) for world points `points` (2N x 6) seen from the camera at `q`.
pub fn image_jacobian(
    camera: &CameraModel,
    q: &Joints,
    world_from_base: &Isometry3<f64>,
    tool_from_cam: &Isometry3<f64>,
    points: &[Point3<f64>],
) -> DMatrix<f64> {
    let cam_from_world = (world_from_base * base_from_tool(q) * tool_from_cam).inverse();
    let pc: Vec<Point3<f64>> = points.iter().map(|p| cam_from_world * p).collect();
    joint_image_jacobian(&interaction_matrix(camera, &pc), &cam_twist_jacobian(q, tool_from_cam))
}

/// d(pixels)/d(q) = interaction matrix (2N x 6, per camera twist) times the camera twist per
/// joint rate (6 x n).
pub fn joint_image_jacobian<C: nalgebra::Dim, S: nalgebra::storage::Storage<f64, nalgebra::U6, C>>(
    l_cam: &DMatrix<f64>,
    twist: &nalgebra::Matrix<f64, nalgebra::U6, C, S>,
) -> DMatrix<f64> {
    let prod = l_cam * twist;
    DMatrix::from_column_slice(l_cam.nrows(), twist.ncols(), prod.as_slice())
}

/// One IBVS step from measured and desired pixels (same order):
/// q+ = wrap(q - gain (L^T L + damping I)^-1 L^T (s - s*)), the gain taken at the RMS pixel error
/// and halved near a robot singularity. Returns the new joints and the gain used.
pub fn ibvs_step(q: &Joints, l: &DMatrix<f64>, measured: &[Point2<f64>], desired: &[Point2<f64>], params: &IbvsParams) -> Option<(Joints, f64)> {
    let smin = jacobian(q).singular_values().min();
    let (dq, gain) = ibvs_increment(smin, l, measured, desired, params)?;
    Some((Joints::from_iterator((0..6).map(|i| wrap(q[i] + dq[i]))), gain))
}

/// The IBVS joint increment of any arm: `-gain (L^T L + damping I)^-1 L^T (s - s*)`, `L` the
/// 2N x n image Jacobian d(pixels)/d(q), the gain taken at the RMS pixel error and halved when
/// `sigma_min_robot` (the smallest singular value of the arm's Jacobian) is below the threshold.
/// Returns the increment and the gain; `None` for a singular system or mismatched lengths.
pub fn ibvs_increment(
    sigma_min_robot: f64,
    l: &DMatrix<f64>,
    measured: &[Point2<f64>],
    desired: &[Point2<f64>],
    params: &IbvsParams,
) -> Option<(DVector<f64>, f64)> {
    if measured.len() != desired.len() || l.nrows() != 2 * measured.len() || measured.is_empty() {
        return None;
    }
    let e = DVector::from_iterator(2 * measured.len(), measured.iter().zip(desired).flat_map(|(m, d)| [m.x - d.x, m.y - d.y]));
    let rms = (e.norm_squared() / measured.len() as f64).sqrt();
    let g = params.gain.at(rms);
    let gain = if sigma_min_robot < params.singular_threshold { 0.5 * g } else { g };
    let n = l.ncols();
    let a = l.transpose() * l + DMatrix::identity(n, n) * params.damping;
    let dq = a.try_inverse()? * (l.transpose() * e);
    Some((-gain * dq, gain))
}

#[cfg(test)]
mod tests {
    use super::*;
    use nalgebra::{Translation3, UnitQuaternion};
    use synthcam_core::math::numdiff::central_diff;
    use synthcam_core::target::spherical_s;

    fn variant_a() -> (Isometry3<f64>, Isometry3<f64>) {
        let r_tc = Matrix3::from_columns(&[Vector3::y(), Vector3::z(), Vector3::x()]);
        (
            Isometry3::from_parts(Translation3::new(2.5, 0.0, 0.0), UnitQuaternion::identity()),
            Isometry3::from_parts(Translation3::new(0.0, 0.0, 0.05), UnitQuaternion::from_matrix(&r_tc)),
        )
    }

    #[test]
    fn image_jacobian_matches_finite_differences() {
        let cam = CameraModel::sxga_1500px();
        let (wb, x) = variant_a();
        let pts = spherical_s().points_m;
        let q = Joints::from_row_slice(&[0.1, 1.6, 3.5 - std::f64::consts::TAU, 3.0, 2.0, 0.0]);
        let f = |v: &DVector<f64>| {
            let qq = Joints::from_column_slice(v.as_slice());
            let cw = (wb * base_from_tool(&qq) * x).inverse();
            DVector::from_iterator(
                2 * pts.len(),
                pts.iter().flat_map(|p| {
                    let u = cam.project_unchecked(&(cw * p));
                    [u.x, u.y]
                }),
            )
        };
        let num = central_diff(f, &DVector::from_column_slice(q.as_slice()), 1e-7);
        let ana = image_jacobian(&cam, &q, &wb, &x, &pts);
        let scale = ana.abs().max();
        // Central differences with h = 1e-7 rad: relative error ~1e-7 of pixel derivatives ~1e3.
        let diff = (num - &ana).abs().max();
        assert!(diff < 1e-5 * scale, "{diff}");
    }

    #[test]
    fn pbvs_converges_in_the_noise_free_spec_setting() {
        // course-scenario 1.8 / 3.9: from q0, 30 steps of the PBVS law reduce the error ~190 x.
        let (wb, x) = variant_a();
        let goal_world_from_cam = Isometry3::from_parts(
            Translation3::new(1.8, 0.0, 0.55),
            UnitQuaternion::from_matrix(&Matrix3::from_columns(&[-Vector3::y(), Vector3::z(), -Vector3::x()])),
        );
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
    fn adaptive_gain_matches_its_definition() {
        let g = IbvsParams::default().gain;
        assert!((g.at(0.0) - 0.3).abs() < 1e-12);
        assert!((g.at(1e6) - 0.03).abs() < 1e-12);
        // Slope at zero: (g(h) - g(0)) / h -> -0.03 per px.
        let h = 1e-6;
        assert!(((g.at(h) - g.at(0.0)) / h + 0.03).abs() < 1e-6);
        assert_eq!(Gain::Constant(0.03).at(123.0), 0.03);
    }

    #[test]
    fn quaternion_vector_of_known_rotations() {
        let r = nalgebra::Rotation3::from_axis_angle(&Vector3::z_axis(), 0.4).into_inner();
        assert!((quaternion_vector(&r) - Vector3::new(0.0, 0.0, 0.2f64.sin())).norm() < 1e-12);
        let half_turn = nalgebra::Rotation3::from_axis_angle(&Vector3::x_axis(), std::f64::consts::PI).into_inner();
        assert!((quaternion_vector(&half_turn).norm() - 1.0).abs() < 1e-9);
    }
}
