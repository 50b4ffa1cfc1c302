//! The rig's Levenberg-Marquardt: residuals and Jacobians, the normal equations with the frames'
//! poses eliminated by the Schur complement, the damped step.

use nalgebra::{DMatrix, DVector, Matrix3, Matrix6, Point2, Point3, SMatrix, Vector2, Vector3, Vector6};

use super::super::refine::{camera_of, drotated_drvec, reduced, Blocks};
use super::super::{CalibError, CalibParams};
use super::RigCamera;
use synthcam_core::camera::N_INTRINSICS;
use synthcam_core::math::so3::rotation_from_rvec;

/// One observation: camera, frame, board point, pixel.
pub(super) struct Obs {
    pub(super) cam: usize,
    pub(super) frame: usize,
    pub(super) x: Point3<f64>,
    pub(super) q: Point2<f64>,
}

/// The optimisation's state.
#[derive(Clone)]
pub(super) struct RigState {
    pub(super) a: Vec<[f64; N_INTRINSICS]>,
    /// `camN_from_cam0` for cameras 1.. as `[rvec, t]`.
    pub(super) ext: Vec<Vector6<f64>>,
    /// `cam0_from_board` per frame.
    pub(super) frames: Vec<Vector6<f64>>,
}

/// Where each camera's free intrinsics and extrinsics sit in the global block.
pub(super) struct Layout {
    /// Per camera, its free intrinsic indices and their first column.
    pub(super) free: Vec<(Vec<usize>, usize)>,
    /// First column of camera `c`'s extrinsics (`c >= 1`), after all intrinsics.
    pub(super) ext0: usize,
    pub(super) size: usize,
}

impl Layout {
    pub(super) fn new(cams: &[RigCamera]) -> Self {
        let mut free = Vec::new();
        let mut col = 0;
        for c in cams {
            let f = super::super::free_parameters(&CalibParams { board_warp: None, ..c.params });
            free.push((f.clone(), col));
            col += f.len();
        }
        Self { free, ext0: col, size: col + 6 * (cams.len() - 1) }
    }
}

/// A residual, its global Jacobian's non-zero columns (column, 2-vector) and its frame's 2 x 6.
pub(super) type Linearised = (Vector2<f64>, Vec<(usize, Vector2<f64>)>, SMatrix<f64, 2, 6>);

/// One observation's residual and its Jacobians.
pub(super) fn residual(cams: &[RigCamera], lay: &Layout, st: &RigState, o: &Obs) -> Linearised {
    let cam = camera_of(cams[o.cam].size, cams[o.cam].params.model.kind(), &st.a[o.cam]);
    let f = &st.frames[o.frame];
    let wf = Vector3::new(f[0], f[1], f[2]);
    let p0 = rotation_from_rvec(&wf) * o.x.coords + Vector3::new(f[3], f[4], f[5]);
    let (p, re, we) = match o.cam {
        0 => (p0, Matrix3::identity(), None),
        c => {
            let e = &st.ext[c - 1];
            let we = Vector3::new(e[0], e[1], e[2]);
            let re = *rotation_from_rvec(&we).matrix();
            (re * p0 + Vector3::new(e[3], e[4], e[5]), re, Some(we))
        }
    };
    let p = Point3::from(p);
    let r = cam.project_unchecked(&p) - o.q;
    let dq_dp = cam.dq_dp_cam(&p);
    let mut jf = SMatrix::<f64, 2, 6>::zeros();
    jf.fixed_view_mut::<2, 3>(0, 0).copy_from(&(dq_dp * re * drotated_drvec(&wf, &o.x.coords)));
    jf.fixed_view_mut::<2, 3>(0, 3).copy_from(&(dq_dp * re));
    let ja = cam.dq_dintrinsics(&p);
    let (free, col0) = &lay.free[o.cam];
    let mut jg: Vec<(usize, Vector2<f64>)> = free.iter().enumerate().map(|(j, &f)| (col0 + j, ja.column(f).into_owned())).collect();
    if let Some(we) = we {
        let base = lay.ext0 + 6 * (o.cam - 1);
        let dr = dq_dp * drotated_drvec(&we, &p0);
        for i in 0..3 {
            jg.push((base + i, dr.column(i).into_owned()));
            jg.push((base + 3 + i, dq_dp.column(i).into_owned()));
        }
    }
    (r, jg, jf)
}

/// The normal equations (the single camera's blocks, the frames as its views).
type Normal = Blocks;

fn normal(cams: &[RigCamera], lay: &Layout, st: &RigState, obs: &[Obs]) -> Normal {
    let n = st.frames.len();
    let mut b = Normal {
        cost: 0.0,
        u: DMatrix::zeros(lay.size, lay.size),
        ga: DVector::zeros(lay.size),
        v: vec![Matrix6::zeros(); n],
        w: vec![DMatrix::zeros(lay.size, 6); n],
        gb: vec![Vector6::zeros(); n],
    };
    for o in obs {
        let (r, jg, jf) = residual(cams, lay, st, o);
        b.cost += r.norm_squared();
        for (i, ji) in &jg {
            b.ga[*i] += ji.dot(&r);
            for (j, jj) in &jg {
                b.u[(*i, *j)] += ji.dot(jj);
            }
            let row = ji.transpose() * jf;
            for c in 0..6 {
                b.w[o.frame][(*i, c)] += row[c];
            }
        }
        b.v[o.frame] += jf.transpose() * jf;
        b.gb[o.frame] += jf.transpose() * r;
    }
    b
}

/// A step: the global block's, every frame's, and the reduced matrix's inverse.
type Step = (DVector<f64>, Vec<Vector6<f64>>, DMatrix<f64>);

/// The damped Schur system's solution ([`reduced`], the single camera's elimination): global
/// step and per-frame steps, with the inverse of the reduced matrix (undamped when `lambda` is 0:
/// the global block's covariance up to sigma^2).
fn solve(b: &Normal, lambda: f64) -> Option<Step> {
    let (s, rhs, vinv) = reduced(b, lambda)?;
    let sinv = s.try_inverse()?;
    let da = &sinv * rhs;
    let df = b.w.iter().zip(&b.gb).zip(&vinv).map(|((w, gf), vi)| -(vi * (gf + Vector6::from_iterator((w.transpose() * &da).iter().copied())))).collect();
    Some((da, df, sinv))
}

fn step(lay: &Layout, st: &RigState, da: &DVector<f64>, df: &[Vector6<f64>]) -> RigState {
    let mut t = st.clone();
    for (c, (free, col0)) in lay.free.iter().enumerate() {
        for (j, &f) in free.iter().enumerate() {
            t.a[c][f] += da[col0 + j];
        }
    }
    for (c, e) in t.ext.iter_mut().enumerate() {
        for i in 0..6 {
            e[i] += da[lay.ext0 + 6 * c + i];
        }
    }
    for (f, d) in t.frames.iter_mut().zip(df) {
        *f += d;
    }
    t
}

/// Levenberg-Marquardt (Nielsen's damping, as [`super::super::refine::refine`]): the state, the global
/// block's covariance (sigma^2 scaled) and the iterations.
pub(super) fn lm(
    cams: &[RigCamera],
    lay: &Layout,
    mut st: RigState,
    obs: &[Obs],
    max_iterations: usize,
) -> Result<(RigState, DMatrix<f64>, usize), CalibError> {
    let singular = || CalibError::Degenerate { reason: "the rig's normal equations are singular".into() };
    let mut b = normal(cams, lay, &st, obs);
    let (mut lambda, mut nu, mut it) = (1e-3, 2.0, 0);
    while it < max_iterations {
        it += 1;
        let Some((da, df, _)) = solve(&b, lambda) else {
            lambda *= 10.0;
            continue;
        };
        let trial = step(lay, &st, &da, &df);
        let nb = normal(cams, lay, &trial, obs);
        if nb.cost.is_finite() && nb.cost <= b.cost {
            let done = b.cost - nb.cost <= 1e-12 * b.cost.max(1e-300);
            (st, b, lambda, nu) = (trial, nb, (lambda / 3.0).max(1e-15), 2.0);
            if done {
                break;
            }
        } else {
            lambda *= nu;
            nu *= 2.0;
            if lambda > 1e12 {
                break;
            }
        }
    }
    let (_, _, sinv) = solve(&b, 0.0).ok_or_else(singular)?;
    let dof = (2 * obs.len()).saturating_sub(lay.size + 6 * st.frames.len()).max(1);
    Ok((st, sinv * (b.cost / dof as f64), it))
}
