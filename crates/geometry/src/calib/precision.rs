//! What the covariances need from the optimum: the normal equations' blocks and their
//! pseudo-inverse, with the parameters the data do not determine.
//!
//! Reference: G. H. Golub, C. F. Van Loan, *Matrix Computations*, 4th ed., section 5.5 (the
//! pseudo-inverse from the eigen-decomposition of a symmetric matrix); the diagonal scaling is
//! Jacobi's (van der Sluis 1969: it minimises the condition number to within a factor n).

use nalgebra::{DMatrix, Matrix6};

/// The blocks of the normal equations at the optimum (no damping): with the free intrinsics'
/// covariance they give the covariance of any function of intrinsics and poses by the
/// Schur complement, without forming the full inverse.
#[derive(Debug, Clone, PartialEq, Default)]
pub struct Precision {
    /// The free intrinsic indices (the covariance's rows).
    pub free: Vec<usize>,
    /// sigma^2, px^2: the residuals' variance per component the fit implies.
    pub sigma2: f64,
    /// Covariance of the free intrinsics, px^2-scaled (as [`super::refine::Refined::covariance`]).
    pub covariance: DMatrix<f64>,
    /// Per view, `W_i = J_a^T J_b` (free intrinsics x pose).
    pub w: Vec<DMatrix<f64>>,
    /// Per view, `V_i^-1 = (J_b^T J_b)^-1` (pose x pose).
    pub vinv: Vec<Matrix6<f64>>,
}

/// Relative size below which an eigenvalue of the scaled normal matrix counts as zero: the
/// parameters along its eigenvector are not determined by the data. (An exact trade, as Double
/// Sphere's at `xi = 0`, leaves 1e-14 after the Jacobian's rounding; the rational model's
/// numerator-denominator trade over a board's radii 4e-14 and 2e-11.)
const NULL_EIGENVALUE: f64 = 1e-12;

/// A parameter moves along a null direction when its share of the (unit) eigenvector exceeds this:
/// its variance along it would be at least `1e-6 / 1e-12` times its scale. Below, it is the
/// eigenvector's rounding (the rational model's trade moves `fx` by under 5e-5 of it).
const NULL_PARTICIPATION: f64 = 1e-3;

/// The pseudo-inverse of the symmetric positive semi-definite `s`, computed on `s` scaled to a
/// unit diagonal (`D^-1/2 S D^-1/2`): the intrinsics' columns differ in scale by up to 1e6 (a
/// focal length in pixels against Double Sphere's `xi`). With it, the indices (into `s`) of the
/// parameters that move along a null direction: the data do not determine them (Double Sphere at
/// `xi = 0` trades `fx`, `xi` and `alpha` exactly; a pure rotation about the axis leaves the
/// principal point free), so their standard deviation is infinite while the projection, which
/// does not move along that direction, keeps a finite covariance.
pub(super) fn pseudo_inverse(s: &DMatrix<f64>) -> (DMatrix<f64>, Vec<usize>) {
    let n = s.nrows();
    if n == 0 {
        // Nothing global is free (the poses alone): nalgebra's eigen solver refuses an empty matrix.
        return (DMatrix::zeros(0, 0), Vec::new());
    }
    let d: Vec<f64> = (0..n).map(|i| s[(i, i)].max(f64::MIN_POSITIVE).sqrt().recip()).collect();
    let scaled = DMatrix::from_fn(n, n, |i, j| s[(i, j)] * d[i] * d[j]);
    if !scaled.iter().all(|v| v.is_finite()) {
        return (DMatrix::from_element(n, n, f64::NAN), (0..n).collect());
    }
    let eig = scaled.symmetric_eigen();
    let top = eig.eigenvalues.amax();
    let mut inv = DMatrix::zeros(n, n);
    let mut undetermined = Vec::new();
    for (k, &l) in eig.eigenvalues.iter().enumerate() {
        let v = eig.eigenvectors.column(k);
        if l > NULL_EIGENVALUE * top {
            inv += v * v.transpose() / l;
        } else {
            undetermined.extend((0..n).filter(|&j| v[j].abs() > NULL_PARTICIPATION));
        }
    }
    undetermined.sort_unstable();
    undetermined.dedup();
    (DMatrix::from_fn(n, n, |i, j| inv[(i, j)] * d[i] * d[j]), undetermined)
}
