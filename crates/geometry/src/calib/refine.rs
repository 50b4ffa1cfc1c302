//! Levenberg-Marquardt refinement of intrinsics, distortion and every view's pose on the pixel
//! reprojection error, with analytic Jacobians and the sparse block structure eliminated by the
//! Schur complement (per-view 6 x 6 blocks folded into the intrinsics block), so the cost per
//! iteration grows linearly with the number of views.
//!
//! Parameters: intrinsics `[fx, fy, cx, cy, skew, lens parameters...]` (any lens model, any subset
//! free; [`synthcam_core::camera::intrinsic_names`]), then per view `[rvec (3), t (3)]` of
//! `cam_from_board` (rvec additive).
//! Reference: Triggs et al., "Bundle adjustment - a modern synthesis", 2000, section 6.1 (Schur
//! complement); Zhang 2000 section 3.2 (the maximum-likelihood refinement); Marquardt 1963.

use nalgebra::{DMatrix, DVector, Matrix3, Matrix6, Point2, Point3, SMatrix, Vector3, Vector6};

use synthcam_core::camera::{CameraModel, ImageSize, Intrinsics, LensKind, N_INTRINSICS};
use synthcam_core::math::so3::{rotation_from_rvec, skew};
pub use synthcam_core::target::{BoardExtent, Warp};

use super::precision::pseudo_inverse;
pub use super::precision::Precision;

/// One view: board points (z = 0) and their pixels.
pub type View = Vec<(Point3<f64>, Point2<f64>)>;

/// Parameters shared by every view: the intrinsics vector, then the board warp's two.
pub const N_GLOBAL: usize = N_INTRINSICS + 2;

/// Intrinsics vector: `fx, fy, cx, cy, skew`, then the lens parameters (zero-padded).
pub type IntrinsicVector = [f64; N_INTRINSICS];

/// The camera of an intrinsics vector.
pub fn camera_of(size: ImageSize, kind: LensKind, a: &IntrinsicVector) -> CameraModel {
    CameraModel { size, intrinsics: Intrinsics { fx: a[0], fy: a[1], cx: a[2], cy: a[3], skew: a[4] }, lens: kind.lens(&a[5..]) }
}

/// The intrinsics vector of a camera.
pub fn vector_of(cam: &CameraModel) -> IntrinsicVector {
    let k = &cam.intrinsics;
    let mut a = [0.0; N_INTRINSICS];
    a[..5].copy_from_slice(&[k.fx, k.fy, k.cx, k.cy, k.skew]);
    a[5..].copy_from_slice(&cam.lens.params());
    a
}

/// `cam_from_board` as the optimisation's `[rvec, t]`.
pub fn pose_vector(p: &nalgebra::Isometry3<f64>) -> Vector6<f64> {
    let r = synthcam_core::math::so3::rvec_from_rotation(&p.rotation.to_rotation_matrix());
    let t = p.translation.vector;
    Vector6::new(r.x, r.y, r.z, t.x, t.y, t.z)
}

/// The right Jacobian `Jr(w)` of SO(3).
fn right_jacobian(w: &Vector3<f64>) -> Matrix3<f64> {
    let th = w.norm();
    let wx = skew(w);
    if th < 1e-8 {
        Matrix3::identity() - 0.5 * wx + wx * wx / 6.0
    } else {
        Matrix3::identity() - (1.0 - th.cos()) / (th * th) * wx + (th - th.sin()) / (th * th * th) * wx * wx
    }
}

/// d(R(w) x)/dw = -R `[x]x` Jr(w), with Jr the right Jacobian of SO(3).
pub fn drotated_drvec(w: &Vector3<f64>, x: &Vector3<f64>) -> Matrix3<f64> {
    drotated(rotation_from_rvec(w).matrix(), &right_jacobian(w), x)
}

/// [`drotated_drvec`] from `R` and `Jr` already at hand.
fn drotated(r: &Matrix3<f64>, jr: &Matrix3<f64>, x: &Vector3<f64>) -> Matrix3<f64> {
    -(r * skew(x)) * jr
}

/// One view's pose, with what every point's Jacobian needs (computed once per view).
struct PoseTerms {
    r: Matrix3<f64>,
    jr: Matrix3<f64>,
    t: Vector3<f64>,
}

impl PoseTerms {
    fn new(pose: &Vector6<f64>) -> Self {
        let w = Vector3::new(pose[0], pose[1], pose[2]);
        Self { r: *rotation_from_rvec(&w).matrix(), jr: right_jacobian(&w), t: Vector3::new(pose[3], pose[4], pose[5]) }
    }
}

/// Residual and Jacobians of one observation: r = project(R warp(x) + t) - q; the global
/// Jacobian has its first `n_lens` lens columns and (with an extent) the warp's two filled.
fn residual(
    cam: &CameraModel,
    pose: &PoseTerms,
    n_lens: usize,
    warp: &Warp,
    x: &Point3<f64>,
    q: &Point2<f64>,
) -> (nalgebra::Vector2<f64>, SMatrix<f64, 2, N_GLOBAL>, SMatrix<f64, 2, 6>) {
    let xw = warp.apply(x);
    let p = Point3::from(pose.r * xw.coords + pose.t);
    let r = cam.project_unchecked(&p) - q;
    let dq_dp = cam.dq_dp_cam(&p);
    let mut jb = SMatrix::<f64, 2, 6>::zeros();
    jb.fixed_view_mut::<2, 3>(0, 0).copy_from(&(dq_dp * drotated(&pose.r, &pose.jr, &xw.coords)));
    jb.fixed_view_mut::<2, 3>(0, 3).copy_from(&dq_dp);
    let mut ja = SMatrix::<f64, 2, N_GLOBAL>::zeros();
    ja.fixed_view_mut::<2, N_INTRINSICS>(0, 0).copy_from(&cam.dq_dintrinsics_n(&p, n_lens));
    if let Some(e) = warp.extent {
        let (bx, by) = e.warp_basis(x);
        let dq_dz = dq_dp * pose.r.column(2);
        ja.fixed_view_mut::<2, 1>(0, N_INTRINSICS).copy_from(&(dq_dz * bx));
        ja.fixed_view_mut::<2, 1>(0, N_INTRINSICS + 1).copy_from(&(dq_dz * by));
    }
    (r, ja, jb)
}

/// State of the optimisation.
#[derive(Debug, Clone, PartialEq)]
pub struct State {
    /// Lens model of the intrinsics vector.
    pub kind: LensKind,
    /// Intrinsics vector.
    pub a: IntrinsicVector,
    /// Per-view poses.
    pub poses: Vec<Vector6<f64>>,
    /// The board's warp (its parameters are the free indices `N_INTRINSICS` and
    /// `N_INTRINSICS + 1`).
    pub warp: Warp,
}

impl State {
    /// A flat board's state.
    pub fn flat(kind: LensKind, a: IntrinsicVector, poses: Vec<Vector6<f64>>) -> Self {
        Self { kind, a, poses, warp: Warp::default() }
    }

    /// The global parameter `i` (intrinsics, then the warp's two).
    fn global_mut(&mut self, i: usize) -> &mut f64 {
        if i < N_INTRINSICS {
            &mut self.a[i]
        } else {
            &mut self.warp.k[(i - N_INTRINSICS).min(1)]
        }
    }
}

/// Normal-equation blocks at a state: the cost, the global block `U` (intrinsics; a rig's
/// intrinsics and extrinsics) and its gradient, and per view (frame) `V`, `W` (global x 6) and
/// the pose's gradient. Shared with the rig's bundle adjustment (`super::rig`).
pub(crate) struct Blocks {
    pub(crate) cost: f64,
    pub(crate) u: DMatrix<f64>,
    pub(crate) ga: DVector<f64>,
    pub(crate) v: Vec<Matrix6<f64>>,
    pub(crate) w: Vec<DMatrix<f64>>,
    pub(crate) gb: Vec<Vector6<f64>>,
}

/// Running sums of one view's (or all views') normal-equation terms over the free intrinsics
/// (written out as loops over the `k` free columns, lower triangle of `J_a^T J_a` only: a 2 x 19
/// Jacobian's full products cost eight times more in the 5-coefficient case).
struct Sums {
    k: usize,
    u: [[f64; N_GLOBAL]; N_GLOBAL],
    ga: [f64; N_GLOBAL],
}

impl Sums {
    fn new(k: usize) -> Self {
        Self { k, u: [[0.0; N_GLOBAL]; N_GLOBAL], ga: [0.0; N_GLOBAL] }
    }

    fn add(&mut self, ja: &[[f64; N_GLOBAL]; 2], r: &nalgebra::Vector2<f64>) {
        for i in 0..self.k {
            let (a0, a1) = (ja[0][i], ja[1][i]);
            for ((u, b0), b1) in self.u[i][..=i].iter_mut().zip(&ja[0]).zip(&ja[1]) {
                *u += a0 * b0 + a1 * b1;
            }
            self.ga[i] += a0 * r.x + a1 * r.y;
        }
    }

    fn u(&self) -> DMatrix<f64> {
        DMatrix::from_fn(self.k, self.k, |i, j| if j <= i { self.u[i][j] } else { self.u[j][i] })
    }
}

fn blocks(size: ImageSize, st: &State, views: &[View], free: &[usize]) -> Blocks {
    let cam = camera_of(size, st.kind, &st.a);
    let k = free.len();
    let mut sums = Sums::new(k);
    let mut b = Blocks { cost: 0.0, u: DMatrix::zeros(k, k), ga: DVector::zeros(k), v: Vec::new(), w: Vec::new(), gb: Vec::new() };
    let n_lens = free.iter().filter(|&&f| f < N_INTRINSICS).map(|&f| f.saturating_sub(4)).max().unwrap_or(0);
    let mut ja = [[0.0; N_GLOBAL]; 2];
    for (view, pose) in views.iter().zip(&st.poses) {
        let pose = PoseTerms::new(pose);
        let (mut v, mut w, mut gb) = (Matrix6::zeros(), DMatrix::<f64>::zeros(k, 6), Vector6::zeros());
        for (x, q) in view {
            let (r, ja_full, jb) = residual(&cam, &pose, n_lens, &st.warp, x, q);
            for (j, &f) in free.iter().enumerate() {
                ja[0][j] = ja_full[(0, f)];
                ja[1][j] = ja_full[(1, f)];
            }
            b.cost += r.norm_squared();
            sums.add(&ja, &r);
            for i in 0..k {
                for c in 0..6 {
                    w[(i, c)] += ja[0][i] * jb[(0, c)] + ja[1][i] * jb[(1, c)];
                }
            }
            v += jb.transpose() * jb;
            gb += jb.transpose() * r;
        }
        b.v.push(v);
        b.w.push(w);
        b.gb.push(gb);
    }
    b.u = sums.u();
    b.ga = DVector::from_fn(k, |i, _| sums.ga[i]);
    b
}

/// Outcome of [`refine`].
#[derive(Debug, Clone, PartialEq)]
pub struct Refined {
    /// Final state.
    pub state: State,
    /// Sum of squared residuals, px^2.
    pub cost: f64,
    /// Iterations run.
    pub iterations: usize,
    /// Stopped on a convergence test (not the iteration limit).
    pub converged: bool,
    /// Covariance of the free intrinsics, px^2-scaled: sigma^2 (Schur complement)^+ (the
    /// pseudo-inverse: see `undetermined`), with sigma^2 = cost / (observations - free parameters).
    pub covariance: DMatrix<f64>,
    /// The global parameters (indices as in `free`'s values) the data do not determine: they move
    /// along a null direction of the normal equations, and their standard deviation is infinite.
    pub undetermined: Vec<usize>,
    /// The normal equations' blocks at the optimum, for the covariance of anything that depends
    /// on the poses too ([`super::uncertainty`]).
    pub precision: Precision,
}

/// Reduced system: the Schur complement S, its right-hand side, and the inverted view blocks.
pub(crate) type Reduced = (DMatrix<f64>, DVector<f64>, Vec<Matrix6<f64>>);

/// Schur-complement reduced system for the intrinsics (a rig's global block) at damping
/// `lambda`; `None` when a view's block is singular.
pub(crate) fn reduced(b: &Blocks, lambda: f64) -> Option<Reduced> {
    let k = b.u.nrows();
    let mut s = b.u.clone();
    for i in 0..k {
        s[(i, i)] += lambda * b.u[(i, i)].max(1e-12);
    }
    let mut rhs = -b.ga.clone();
    let mut vinv = Vec::with_capacity(b.v.len());
    for ((v, w), gb) in b.v.iter().zip(&b.w).zip(&b.gb) {
        let mut vd = *v;
        for i in 0..6 {
            vd[(i, i)] += lambda * v[(i, i)].max(1e-12);
        }
        let vi = vd.try_inverse()?;
        let wv = w * DMatrix::from_column_slice(6, 6, vi.as_slice());
        s -= &wv * w.transpose();
        rhs += &wv * DVector::from_column_slice(gb.as_slice());
        vinv.push(vi);
    }
    Some((s, rhs, vinv))
}

/// A trial step from `st`: the new state, the squared step length and the decrease of the cost
/// the linear model predicts (`-(2 g.h + h^T J^T J h)`, the cost being the plain sum of squares).
fn trial_step(b: &Blocks, st: &State, free: &[usize], da: &DVector<f64>, vinv: &[Matrix6<f64>]) -> (State, f64, f64) {
    let mut trial = st.clone();
    for (j, &f) in free.iter().enumerate() {
        *trial.global_mut(f) += da[j];
    }
    let mut step2 = da.norm_squared();
    let mut gh = b.ga.dot(da);
    let mut hjh = (da.transpose() * &b.u * da)[(0, 0)];
    for (i, pose) in trial.poses.iter_mut().enumerate() {
        let wda = Vector6::from_iterator((b.w[i].transpose() * da).iter().copied());
        let db = -(vinv[i] * (b.gb[i] + wda));
        step2 += db.norm_squared();
        gh += b.gb[i].dot(&db);
        hjh += 2.0 * wda.dot(&db) + (db.transpose() * b.v[i] * db)[(0, 0)];
        *pose += db;
    }
    (trial, step2, -(2.0 * gh + hjh))
}

/// Run Levenberg-Marquardt from `init`; `free` lists the free intrinsic indices. Damping
/// `lambda diag(J^T J)` (Marquardt), updated by the gain ratio as Nielsen proposes (Madsen,
/// Nielsen and Tingleff, "Methods for non-linear least squares problems", 2004, section 3.2).
pub fn refine(size: ImageSize, init: State, views: &[View], free: &[usize], max_iterations: usize) -> Option<Refined> {
    let mut st = init;
    let mut b = blocks(size, &st, views, free);
    let (mut lambda, mut nu) = (1e-3, 2.0);
    let mut converged = false;
    let mut it = 0;
    while it < max_iterations {
        it += 1;
        let (s, rhs, vinv) = reduced(&b, lambda)?;
        let Some(da) = s.clone().cholesky().map(|c| c.solve(&rhs)).or_else(|| s.lu().solve(&rhs)) else {
            lambda *= 10.0;
            continue;
        };
        let (trial, step2, predicted) = trial_step(&b, &st, free, &da, &vinv);
        let nb = blocks(size, &trial, views, free);
        if nb.cost.is_finite() && nb.cost <= b.cost {
            let decrease = b.cost - nb.cost;
            let rho = if predicted > 0.0 { decrease / predicted } else { 1.0 };
            st = trial;
            b = nb;
            lambda = (lambda * (1.0f64 / 3.0).max(1.0 - (2.0 * rho - 1.0).powi(3))).max(1e-15);
            nu = 2.0;
            if decrease <= 1e-12 * b.cost.max(1e-300) || step2.sqrt() < 1e-12 {
                converged = true;
                break;
            }
        } else {
            lambda *= nu;
            nu *= 2.0;
            if lambda > 1e12 {
                converged = true;
                break;
            }
        }
    }
    let (s, _, vinv) = reduced(&b, 0.0)?;
    let n_obs: usize = views.iter().map(|v| 2 * v.len()).sum();
    let dof = n_obs.saturating_sub(free.len() + 6 * views.len()).max(1);
    let sigma2 = b.cost / dof as f64;
    let (inverse, undetermined) = pseudo_inverse(&s);
    let covariance = inverse * sigma2;
    let precision = Precision { free: free.to_vec(), sigma2, covariance: covariance.clone(), w: b.w, vinv };
    let undetermined = undetermined.into_iter().map(|j| free[j]).collect();
    Some(Refined { state: st, cost: b.cost, iterations: it, converged, covariance, undetermined, precision })
}

#[cfg(test)]
mod tests {
    use super::*;
    use synthcam_core::math::numdiff::central_diff;

    #[test]
    fn rotation_jacobian_matches_finite_differences() {
        for w in [Vector3::new(0.3, -0.2, 0.5), Vector3::new(1e-10, 0.0, 0.0), Vector3::new(2.5, 1.0, -0.4)] {
            let x = Vector3::new(0.2, -0.7, 1.3);
            let f = |v: &DVector<f64>| DVector::from_column_slice((rotation_from_rvec(&Vector3::new(v[0], v[1], v[2])) * x).as_slice());
            let num = central_diff(f, &DVector::from_column_slice(w.as_slice()), 1e-6);
            let ana = drotated_drvec(&w, &x);
            // Central differences with h = 1e-6 are good to ~1e-9 here.
            assert!((num - DMatrix::from_column_slice(3, 3, ana.as_slice())).abs().max() < 1e-8, "w = {w}");
        }
    }

    #[test]
    fn warp_jacobian_matches_finite_differences() {
        let cam = CameraModel::pinhole(640, 480, 500.0).with_distortion([-0.2, 0.05, 0.0, 0.0, 0.0]);
        let pose_v = Vector6::new(0.3, -0.2, 0.1, -0.05, 0.02, 0.5);
        let pose = PoseTerms::new(&pose_v);
        let extent = BoardExtent { x: (0.0, 0.2), y: (0.0, 0.15) };
        let x = Point3::new(0.13, 0.04, 0.0);
        let q = Point2::new(300.0, 200.0);
        let at = |k: &DVector<f64>| {
            let warp = Warp { k: [k[0], k[1]], extent: Some(extent) };
            DVector::from_column_slice(residual(&cam, &pose, 5, &warp, &x, &q).0.as_slice())
        };
        let k0 = DVector::from_column_slice(&[0.002, -0.001]);
        let num = central_diff(at, &k0, 1e-7);
        let (_, ja, _) = residual(&cam, &pose, 5, &Warp { k: [0.002, -0.001], extent: Some(extent) }, &x, &q);
        let ana = ja.fixed_view::<2, 2>(0, N_INTRINSICS).into_owned();
        // The residual is linear-ish in k at this scale: central differences are good to 1e-6 px/m.
        assert!((num - DMatrix::from_column_slice(2, 2, ana.as_slice())).abs().max() < 1e-4 * ana.abs().max(), "{ana}");
    }
}
