//! Joint refinement of `tool_from_cam` and `world_from_base` on the pixel reprojection error of
//! every view (after a closed-form start): Levenberg-Marquardt over two 6-vectors of right-
//! multiplied increments (rotation vector, translation), Jacobian by central differences
//! (12 parameters; the reprojection Jacobians themselves are tested in `camera` and `pnp`).
//! Reference: Strobl & Hirzinger, "Optimal hand-eye calibration", IROS 2006 (reprojection form).

use nalgebra::{DMatrix, DVector, Isometry3, Point2, Point3, Translation3, UnitQuaternion, Vector3};

use super::HandEyeResult;
use crate::camera::CameraModel;

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
