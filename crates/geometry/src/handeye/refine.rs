//! Joint refinement of `tool_from_cam` and `world_from_base` on the pixel reprojection error of
//! every view (after a closed-form start): Levenberg-Marquardt over two 6-vectors of right-
//! multiplied increments (rotation vector, translation), Jacobian by central differences
//! (12 parameters; the reprojection Jacobians themselves are tested in `camera` and `pnp`).
//! Reference: Strobl & Hirzinger, "Optimal hand-eye calibration", IROS 2006 (reprojection form).

use nalgebra::{DMatrix, DVector, Isometry3, Point2, Point3, Translation3, UnitQuaternion, Vector3};

use super::HandEyeResult;
use synthcam_core::camera::CameraModel;

/// Observations of one view: target points (world frame) and their pixels.
pub type Observations = Vec<(Point3<f64>, Point2<f64>)>;

fn apply(t: &Isometry3<f64>, d: &[f64]) -> Isometry3<f64> {
    let dr = UnitQuaternion::from_scaled_axis(Vector3::new(d[0], d[1], d[2]));
    t * Isometry3::from_parts(Translation3::new(d[3], d[4], d[5]), dr)
}

fn residuals(cam: &CameraModel, bt: &[Isometry3<f64>], obs: &[Observations], x: &Isometry3<f64>, wb: &Isometry3<f64>) -> DVector<f64> {
    let n: usize = obs.iter().map(Vec::len).sum();
    let mut r = DVector::zeros(2 * n);
    let mut k = 0;
    for (b, o) in bt.iter().zip(obs) {
        let cam_from_world = (wb * b * x).inverse();
        for (p, q) in o {
            let e = cam.project_unchecked(&(cam_from_world * p)) - q;
            r[2 * k] = e.x;
            r[2 * k + 1] = e.y;
            k += 1;
        }
    }
    r
}

/// Result of [`refine_joint`].
#[derive(Debug, Clone, PartialEq)]
pub struct JointRefinement {
    /// `tool_from_cam`.
    pub tool_from_cam: Isometry3<f64>,
    /// `world_from_base`.
    pub world_from_base: Isometry3<f64>,
    /// Per view: RMS reprojection error, px.
    pub view_rms_px: Vec<f64>,
    /// Iterations run.
    pub iterations: usize,
}

/// Refine `init` on the reprojection error of all views.
pub fn refine_joint(cam: &CameraModel, base_from_tool: &[Isometry3<f64>], obs: &[Observations], init: &HandEyeResult) -> JointRefinement {
    let (mut x, mut wb) = (init.tool_from_cam, init.world_from_base);
    let eval = |x: &Isometry3<f64>, wb: &Isometry3<f64>| residuals(cam, base_from_tool, obs, x, wb);
    let mut r = eval(&x, &wb);
    let mut cost = r.norm_squared();
    let mut lambda = 1e-3;
    let mut iterations = 0;
    for _ in 0..50 {
        iterations += 1;
        let h = 1e-7;
        let mut j = DMatrix::zeros(r.len(), 12);
        for k in 0..12 {
            let mut d = [0.0; 12];
            d[k] = h;
            let (xp, wp) = (apply(&x, &d[..6]), apply(&wb, &d[6..]));
            d[k] = -h;
            let (xm, wm) = (apply(&x, &d[..6]), apply(&wb, &d[6..]));
            let col = (eval(&xp, &wp) - eval(&xm, &wm)) / (2.0 * h);
            j.set_column(k, &col);
        }
        let jtj = j.transpose() * &j;
        let g = j.transpose() * &r;
        let mut improved = false;
        for _ in 0..10 {
            let mut a = jtj.clone();
            for i in 0..12 {
                a[(i, i)] += lambda * jtj[(i, i)].max(1e-12);
            }
            let Some(step) = a.cholesky().map(|c| c.solve(&(-&g))) else {
                lambda *= 10.0;
                continue;
            };
            let (xn, wn) = (apply(&x, &step.as_slice()[..6]), apply(&wb, &step.as_slice()[6..]));
            let rn = eval(&xn, &wn);
            let cn = rn.norm_squared();
            if cn <= cost {
                let small = cost - cn <= 1e-14 * cost.max(1e-300);
                (x, wb, r, cost) = (xn, wn, rn, cn);
                lambda = (lambda * 0.3).max(1e-12);
                improved = !small;
                break;
            }
            lambda *= 10.0;
        }
        if !improved {
            break;
        }
    }
    let mut view_rms_px = Vec::with_capacity(obs.len());
    let mut k = 0;
    for o in obs {
        let ss: f64 = (0..o.len()).map(|i| r[2 * (k + i)].powi(2) + r[2 * (k + i) + 1].powi(2)).sum();
        view_rms_px.push((ss / o.len().max(1) as f64).sqrt());
        k += o.len();
    }
    JointRefinement { tool_from_cam: x, world_from_base: wb, view_rms_px, iterations }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::handeye::park_martin;
    use rand::{Rng, SeedableRng};
    use rand_chacha::ChaCha8Rng;
    use synthcam_core::robot::{base_from_tool, Joints};
    use synthcam_core::target::spherical_s;

    #[test]
    fn refinement_is_exact_on_ideal_data_and_independent_of_view_order() {
        let cam = CameraModel::sxga_1500px();
        let r_tc = nalgebra::Matrix3::from_columns(&[Vector3::y(), Vector3::z(), Vector3::x()]);
        let x = Isometry3::from_parts(Translation3::new(0.0, 0.0, 0.05), UnitQuaternion::from_matrix(&r_tc));
        let wb = Isometry3::from_parts(Translation3::new(2.5, 0.0, 0.0), UnitQuaternion::identity());
        let pts = spherical_s().points_m;
        let mut rng = ChaCha8Rng::seed_from_u64(5);
        let (mut bt, mut wc, mut obs) = (Vec::new(), Vec::new(), Vec::new());
        for _ in 0..5 {
            let q = Joints::from_iterator([0.0, 1.6, 3.0, 3.0, 2.0, 0.0].iter().map(|v| v + rng.random_range(-0.25..0.25)));
            let t = base_from_tool(&q);
            let world_from_cam = wb * t * x;
            // Start the solvers from slightly wrong PnP poses, refine on exact pixels.
            let jitter = Isometry3::from_parts(Translation3::new(1e-4, -2e-4, 1e-4), UnitQuaternion::from_euler_angles(1e-4, 0.0, -1e-4));
            bt.push(t);
            wc.push(world_from_cam * jitter);
            let cam_from_world = world_from_cam.inverse();
            obs.push(pts.iter().map(|p| (*p, cam.project_unchecked(&(cam_from_world * p)))).collect::<Observations>());
        }
        let start = park_martin(&bt, &wc).unwrap();
        let a = refine_joint(&cam, &bt, &obs, &start);
        assert!((a.tool_from_cam.translation.vector - x.translation.vector).norm() < 1e-9);
        assert!((a.tool_from_cam.rotation * x.rotation.inverse()).angle() < 1e-9);
        assert!((a.world_from_base.translation.vector - wb.translation.vector).norm() < 1e-9);
        let order = [3, 0, 4, 1, 2];
        let (bt2, wc2, obs2): (Vec<_>, Vec<_>, Vec<_>) =
            order.iter().map(|&i| (bt[i], wc[i], obs[i].clone())).fold((vec![], vec![], vec![]), |mut acc, (b, w, o)| {
                acc.0.push(b);
                acc.1.push(w);
                acc.2.push(o);
                acc
            });
        let b = refine_joint(&cam, &bt2, &obs2, &park_martin(&bt2, &wc2).unwrap());
        assert!((a.tool_from_cam.translation.vector - b.tool_from_cam.translation.vector).norm() < 1e-9);
        assert!((a.world_from_base.translation.vector - b.world_from_base.translation.vector).norm() < 1e-9);
    }
}
