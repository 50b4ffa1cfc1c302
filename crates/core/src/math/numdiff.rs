//! Central finite-difference Jacobians, the reference every analytic Jacobian
//! in the crate is tested against.
//!
//! Reference: Nocedal & Wright, "Numerical Optimization" (2006), sec. 8.1
//! (central difference, truncation error O(h^2)).

use nalgebra::{DMatrix, DVector};

/// Central finite-difference Jacobian of `f` at `x` with step `h`.
///
/// Returns an `m x n` matrix (rows = outputs, columns = inputs) whose column
/// `j` is `(f(x + h e_j) - f(x - h e_j)) / (2 h)`. `f` is evaluated once at `x`
/// to learn `m`. Truncation error is O(h^2 |f'''|) and rounding error is about
/// `eps |f| / h`, so `h ~ 1e-6 * scale(x)` is a good default for f64.
/// If `f` returns vectors of inconsistent length the extra/missing entries are
/// ignored/treated as zero rather than panicking.
pub fn central_diff<F: Fn(&DVector<f64>) -> DVector<f64>>(f: F, x: &DVector<f64>, h: f64) -> DMatrix<f64> {
    let m = f(x).len();
    let n = x.len();
    let mut jac = DMatrix::<f64>::zeros(m, n);
    for j in 0..n {
        let mut xp = x.clone();
        let mut xm = x.clone();
        xp[j] += h;
        xm[j] -= h;
        let fp = f(&xp);
        let fm = f(&xm);
        for i in 0..m {
            let a = fp.get(i).copied().unwrap_or(0.0);
            let b = fm.get(i).copied().unwrap_or(0.0);
            jac[(i, j)] = (a - b) / (2.0 * h);
        }
    }
    jac
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn linear_map_is_exact() {
        // f(x) = A x: the central difference is exact up to rounding (~1e-10
        // for h = 1e-6 and entries O(1)), so 1e-8 would catch any indexing error.
        let a = DMatrix::from_row_slice(2, 3, &[1.0, -2.0, 3.0, 0.5, 4.0, -1.0]);
        let a2 = a.clone();
        let x = DVector::from_vec(vec![0.3, -0.7, 1.1]);
        let j = central_diff(move |v| &a2 * v, &x, 1e-6);
        assert_eq!(j.shape(), (2, 3));
        assert!((j - a).amax() < 1e-8);
    }

    #[test]
    fn nonlinear_matches_closed_form() {
        // f(x, y) = (x^2 y, sin x); O(h^2) truncation with h = 1e-5 is ~1e-10.
        let x = DVector::from_vec(vec![0.7, -1.3]);
        let j = central_diff(|v| DVector::from_vec(vec![v[0] * v[0] * v[1], v[0].sin()]), &x, 1e-5);
        let expect = DMatrix::from_row_slice(2, 2, &[2.0 * 0.7 * -1.3, 0.7 * 0.7, 0.7f64.cos(), 0.0]);
        assert!((j - expect).amax() < 1e-8);
    }
}
