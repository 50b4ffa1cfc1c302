//! Hand-eye calibration of a camera on the robot's tool (eye-in-hand).
//!
//! Unknowns: `tool_from_cam` (X) and `world_from_base`. Per view i the robot gives
//! `base_from_tool_i` (forward kinematics) and PnP gives `cam_from_world_i`, and
//! `world_from_base * base_from_tool_i * tool_from_cam * cam_from_world_i = I`.
//!
//! - [`linear_known_rotations`]: linear least squares for the two translations when the
//!   rotations `R_TC` and `R_0B` are known; with `R_0B = I`:
//!   `[R_BT,i  I] [p_TC; p_0B] = p_0C,i - p_BT,i`.
//! - [`park_martin`]: rotations unknown: AX = XB over all view pairs, with A = tool motion and
//!   B = camera motion; rotation by Park-Martin's closed form (log-map correlation), then the
//!   translation by linear least squares; `world_from_base` follows by averaging.
//!
//! Reference: F. C. Park, B. J. Martin, "Robot sensor calibration: solving AX = XB on the
//! Euclidean group", IEEE T-RA 10(5), 1994; Tsai & Lenz 1989 (pair formulation).

pub mod refine;

use nalgebra::{DMatrix, DVector, Isometry3, Matrix3, Translation3, UnitQuaternion, Vector3};

use synthcam_core::math::so3::rvec_from_rotation;

/// Errors of the hand-eye solvers.
#[derive(Debug, thiserror::Error, Clone, PartialEq)]
#[non_exhaustive]
pub enum HandEyeError {
    /// Not enough views.
    #[error("hand-eye calibration needs at least {required} views, got {actual}")]
    TooFewViews {
        /// Needed.
        required: usize,
        /// Given.
        actual: usize,
    },
    /// The motions do not determine the unknowns.
    #[error("degenerate motions: {reason}")]
    Degenerate {
        /// Why.
        reason: String,
    },
}

/// Estimate with per-view residuals.
#[derive(Debug, Clone, PartialEq)]
pub struct HandEyeResult {
    /// `tool_from_cam`.
    pub tool_from_cam: Isometry3<f64>,
    /// `world_from_base`.
    pub world_from_base: Isometry3<f64>,
    /// Per view: position residual of the closed loop, metres.
    pub residual_m: Vec<f64>,
    /// Per view: rotation residual of the closed loop, radians.
    pub residual_rad: Vec<f64>,
}

fn residuals(base_from_tool: &[Isometry3<f64>], world_from_cam: &[Isometry3<f64>], x: &Isometry3<f64>, wb: &Isometry3<f64>) -> (Vec<f64>, Vec<f64>) {
    base_from_tool
        .iter()
        .zip(world_from_cam)
        .map(|(bt, wc)| {
            let e = wc.inverse() * wb * bt * x;
            (e.translation.vector.norm(), e.rotation.angle())
        })
        .unzip()
}

fn lstsq(a: &DMatrix<f64>, b: &DVector<f64>) -> Result<DVector<f64>, HandEyeError> {
    let svd = a.clone().svd(true, true);
    let s = &svd.singular_values;
    let (smax, smin) = (s.max(), s.min());
    if !(smin > 1e-9 * smax) {
        return Err(HandEyeError::Degenerate { reason: format!("least-squares system is rank deficient (singular values {smin:.2e} / {smax:.2e})") });
    }
    svd.solve(b, 1e-12 * smax).map_err(|e| HandEyeError::Degenerate { reason: e.to_string() })
}

/// The linear solver for any known base rotation `r_world_base`: with
/// `world_from_cam_i = W B_i X`, `R_WB^T p_WC,i - p_B,i = R_B,i t_X + R_WB^T t_W` is linear in the
/// two translations (stacked over the views, solved by least squares).
///
/// # Errors
/// Fewer than 2 views, or views whose tool rotations do not separate the two translations.
pub fn linear_known_rotations(
    base_from_tool: &[Isometry3<f64>],
    world_from_cam: &[Isometry3<f64>],
    r_tool_cam: &Matrix3<f64>,
    r_world_base: &Matrix3<f64>,
) -> Result<HandEyeResult, HandEyeError> {
    let m = base_from_tool.len().min(world_from_cam.len());
    if m < 2 {
        return Err(HandEyeError::TooFewViews { required: 2, actual: m });
    }
    let mut a = DMatrix::zeros(3 * m, 6);
    let mut b = DVector::zeros(3 * m);
    for (i, (bt, wc)) in base_from_tool.iter().zip(world_from_cam).enumerate() {
        let r = bt.rotation.to_rotation_matrix().into_inner();
        a.view_mut((3 * i, 0), (3, 3)).copy_from(&r);
        a.view_mut((3 * i, 3), (3, 3)).copy_from(&Matrix3::identity());
        b.rows_mut(3 * i, 3).copy_from(&(r_world_base.transpose() * wc.translation.vector - bt.translation.vector));
    }
    let x = lstsq(&a, &b)?;
    let t_world_base = r_world_base * Vector3::new(x[3], x[4], x[5]);
    let tool_from_cam = Isometry3::from_parts(Translation3::new(x[0], x[1], x[2]), UnitQuaternion::from_matrix(r_tool_cam));
    let world_from_base = Isometry3::from_parts(Translation3::from(t_world_base), UnitQuaternion::from_matrix(r_world_base));
    let (residual_m, residual_rad) = residuals(base_from_tool, world_from_cam, &tool_from_cam, &world_from_base);
    Ok(HandEyeResult { tool_from_cam, world_from_base, residual_m, residual_rad })
}

/// AX = XB with unknown rotations (Park-Martin), over all pairs of views.
///
/// # Errors
/// Fewer than 3 views, or motions about a single axis (the rotation is then undetermined).
pub fn park_martin(base_from_tool: &[Isometry3<f64>], world_from_cam: &[Isometry3<f64>]) -> Result<HandEyeResult, HandEyeError> {
    let m = base_from_tool.len().min(world_from_cam.len());
    if m < 3 {
        return Err(HandEyeError::TooFewViews { required: 3, actual: m });
    }
    // Pairs (i, j), i < j: A = T_j^-1 T_i (tool), B = C_j C_i^-1 with C = cam_from_world.
    let mut pairs = Vec::new();
    for i in 0..m {
        for j in i + 1..m {
            let a = base_from_tool[j].inverse() * base_from_tool[i];
            let b = world_from_cam[j].inverse() * world_from_cam[i];
            pairs.push((a, b));
        }
    }
    let mut mm = Matrix3::zeros();
    for (a, b) in &pairs {
        let al = rvec_from_rotation(&a.rotation.to_rotation_matrix());
        let be = rvec_from_rotation(&b.rotation.to_rotation_matrix());
        mm += be * al.transpose();
    }
    // R_X = (M^T M)^(-1/2) M^T.
    let mtm = mm.transpose() * mm;
    let eig = mtm.symmetric_eigen();
    let (emin, emax) = (eig.eigenvalues.min(), eig.eigenvalues.max());
    if !(emin > 1e-10 * emax) {
        return Err(HandEyeError::Degenerate { reason: "all motions rotate about one axis: the hand-eye rotation is undetermined".into() });
    }
    let inv_sqrt = eig.eigenvectors * Matrix3::from_diagonal(&eig.eigenvalues.map(|v| 1.0 / v.sqrt())) * eig.eigenvectors.transpose();
    let rx = inv_sqrt * mm.transpose();
    let rx = synthcam_core::math::so3::project_to_so3(&rx).into_inner();
    // (R_A - I) t_X = R_X t_B - t_A.
    let mut a = DMatrix::zeros(3 * pairs.len(), 3);
    let mut b = DVector::zeros(3 * pairs.len());
    for (k, (pa, pb)) in pairs.iter().enumerate() {
        let ra = pa.rotation.to_rotation_matrix().into_inner();
        a.view_mut((3 * k, 0), (3, 3)).copy_from(&(ra - Matrix3::identity()));
        b.rows_mut(3 * k, 3).copy_from(&(rx * pb.translation.vector - pa.translation.vector));
    }
    let t = lstsq(&a, &b)?;
    let tool_from_cam = Isometry3::from_parts(Translation3::new(t[0], t[1], t[2]), UnitQuaternion::from_matrix(&rx));
    // world_from_base = world_from_cam * (base_from_tool * tool_from_cam)^-1, averaged.
    let estimates: Vec<Isometry3<f64>> = base_from_tool.iter().zip(world_from_cam).map(|(bt, wc)| wc * (bt * tool_from_cam).inverse()).collect();
    let tmean = estimates.iter().fold(Vector3::zeros(), |s, e| s + e.translation.vector) / m as f64;
    let rsum = estimates.iter().fold(Matrix3::zeros(), |s, e| s + e.rotation.to_rotation_matrix().into_inner());
    let rmean = synthcam_core::math::so3::project_to_so3(&rsum).into_inner();
    let world_from_base = Isometry3::from_parts(Translation3::from(tmean), UnitQuaternion::from_matrix(&rmean));
    let (residual_m, residual_rad) = residuals(base_from_tool, world_from_cam, &tool_from_cam, &world_from_base);
    Ok(HandEyeResult { tool_from_cam, world_from_base, residual_m, residual_rad })
}

#[cfg(test)]
mod tests {
    use super::*;
    use rand::{Rng, SeedableRng};
    use rand_chacha::ChaCha8Rng;
    use synthcam_core::robot::{base_from_tool, Joints};

    /// (base_from_tool per view, world_from_cam per view, tool_from_cam, world_from_base).
    type Views = (Vec<Isometry3<f64>>, Vec<Isometry3<f64>>, Isometry3<f64>, Isometry3<f64>);

    /// Course variant A (course-scenario 3.6): p_0B = (2.5, 0, 0), p_TC = (0, 0, 0.05),
    /// R_TC = [ey, ez, ex]; views at q = (0, 1.6, 3, 3, 2, 0) + U(-0.25, 0.25).
    fn variant_a(views: usize, seed: u64) -> Views {
        let r_tc = Matrix3::from_columns(&[Vector3::y(), Vector3::z(), Vector3::x()]);
        let x = Isometry3::from_parts(Translation3::new(0.0, 0.0, 0.05), UnitQuaternion::from_matrix(&r_tc));
        let wb = Isometry3::from_parts(Translation3::new(2.5, 0.0, 0.0), UnitQuaternion::identity());
        let mut rng = ChaCha8Rng::seed_from_u64(seed);
        let q0 = [0.0, 1.6, 3.0, 3.0, 2.0, 0.0];
        let (mut bt, mut wc) = (Vec::new(), Vec::new());
        for _ in 0..views {
            let q = Joints::from_iterator(q0.iter().map(|v| v + rng.random_range(-0.25..0.25)));
            let t = base_from_tool(&q);
            bt.push(t);
            wc.push(wb * t * x);
        }
        (bt, wc, x, wb)
    }

    #[test]
    fn both_solvers_recover_variant_a_exactly() {
        let (bt, wc, x, wb) = variant_a(5, 1);
        let r_tc = x.rotation.to_rotation_matrix().into_inner();
        for r in [linear_known_rotations(&bt, &wc, &r_tc, &Matrix3::identity()).unwrap(), park_martin(&bt, &wc).unwrap()] {
            assert!((r.tool_from_cam.translation.vector - x.translation.vector).norm() < 1e-9);
            assert!((r.tool_from_cam.rotation * x.rotation.inverse()).angle() < 1e-9);
            assert!((r.world_from_base.translation.vector - wb.translation.vector).norm() < 1e-9);
            assert!(r.residual_m.iter().all(|e| *e < 1e-9));
        }
    }

    #[test]
    fn the_linear_solver_takes_a_rotated_base() {
        // Variant A's views seen from a world rotated 90 degrees about z and shifted: the known
        // rotations give both translations exactly; assuming R_0B = I (the course's solver) does not.
        let (bt, wc, x, wb) = variant_a(5, 3);
        let w = Isometry3::from_parts(Translation3::new(0.3, -0.2, 0.1), UnitQuaternion::from_axis_angle(&Vector3::z_axis(), std::f64::consts::FRAC_PI_2));
        let wc: Vec<Isometry3<f64>> = wc.iter().map(|c| w * c).collect();
        let wb = w * wb;
        let r_tc = x.rotation.to_rotation_matrix().into_inner();
        let r = linear_known_rotations(&bt, &wc, &r_tc, &wb.rotation.to_rotation_matrix().into_inner()).unwrap();
        assert!((r.tool_from_cam.translation.vector - x.translation.vector).norm() < 1e-9);
        assert!((r.world_from_base.translation.vector - wb.translation.vector).norm() < 1e-9);
        assert!(r.residual_m.iter().all(|e| *e < 1e-9));
        let linear = linear_known_rotations(&bt, &wc, &r_tc, &Matrix3::identity()).unwrap();
        assert!((linear.world_from_base.translation.vector - wb.translation.vector).norm() > 0.1);
    }

    #[test]
    fn view_order_does_not_matter() {
        let (bt, wc, ..) = variant_a(6, 2);
        let a = park_martin(&bt, &wc).unwrap();
        let (mut bt2, mut wc2) = (bt.clone(), wc.clone());
        bt2.reverse();
        wc2.reverse();
        bt2.swap(1, 4);
        wc2.swap(1, 4);
        let b = park_martin(&bt2, &wc2).unwrap();
        assert!((a.tool_from_cam.translation.vector - b.tool_from_cam.translation.vector).norm() < 1e-9);
        assert!((a.tool_from_cam.rotation * b.tool_from_cam.rotation.inverse()).angle() < 1e-9);
    }

    #[test]
    fn degenerate_motions_are_rejected() {
        let (bt, wc, x, _) = variant_a(5, 3);
        assert!(matches!(park_martin(&bt[..2], &wc[..2]), Err(HandEyeError::TooFewViews { .. })));
        assert!(matches!(linear_known_rotations(&bt[..1], &wc[..1], &Matrix3::identity(), &Matrix3::identity()), Err(HandEyeError::TooFewViews { .. })));
        // Rotations about one axis only (joint 1 alone).
        let wb = Isometry3::identity();
        let (mut b1, mut c1) = (Vec::new(), Vec::new());
        for k in 0..5 {
            let t = base_from_tool(&Joints::from_row_slice(&[0.2 * f64::from(k), 0.3, 0.2, 0.0, 0.5, 0.0]));
            b1.push(t);
            c1.push(wb * t * x);
        }
        assert!(matches!(park_martin(&b1, &c1), Err(HandEyeError::Degenerate { .. })));
    }
}
