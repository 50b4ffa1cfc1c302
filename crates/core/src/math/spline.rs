//! One-dimensional piecewise-cubic interpolating splines.
//!
//! [`CubicSpline`] interpolates `y(x)` through knots `x_0 < x_1 < … < x_{n-1}`
//! with a C² piecewise cubic. Two end conditions are provided:
//!
//! * [`CubicSpline::not_a_knot`]: the third derivative is continuous across
//!   `x_1` and `x_{n-2}`. This is MATLAB's `spline(x, y, xq)` and SciPy's
//!   `CubicSpline(x, y, bc_type='not-a-knot')`, including their special cases
//!   (2 knots: the straight line; 3 knots: the interpolating parabola).
//! * [`CubicSpline::natural`]: zero second derivative at both ends (SciPy
//!   `bc_type='natural'`; 2 knots give the straight line).
//!
//! The construction follows the slope (first-derivative) formulation used by
//! SciPy: a tridiagonal system for the knot slopes, solved here by Gaussian
//! elimination with partial pivoting (the not-a-knot end rows are not
//! diagonally dominant, so plain Thomas elimination is avoided). Outside
//! `[x_0, x_{n-1}]` the end cubics are extrapolated, as MATLAB and SciPy do.

/// Errors from building a [`CubicSpline`].
#[derive(Debug, thiserror::Error)]
#[non_exhaustive]
pub enum SplineError {
    /// Fewer knots than the construction needs, or `x` and `y` differ in length
    /// (`actual` is then the shorter length).
    #[error("cubic spline needs at least {required} points with matching x/y lengths, got {actual}")]
    TooFewPoints {
        /// Minimum number of knots.
        required: usize,
        /// Number of usable knots given.
        actual: usize,
    },
    /// `x[index] <= x[index - 1]`: knots must be strictly increasing.
    #[error("spline knots must be strictly increasing (violated at index {index})")]
    NotIncreasing {
        /// First index whose knot is not greater than its predecessor.
        index: usize,
    },
    /// An input value, or a computed coefficient, is NaN or infinite.
    #[error("spline input or coefficients are not finite")]
    NonFinite,
}

/// A C² piecewise-cubic interpolant of 1-D data over strictly increasing knots.
///
/// On interval `i` (`x_i <= x < x_{i+1}`) the value is
/// `c3·h³ + c2·h² + c1·h + y_i` with `h = x − x_i`.
#[derive(Debug, Clone, PartialEq)]
pub struct CubicSpline {
    x: Vec<f64>,
    /// Per interval: [c3, c2, c1, c0] (c0 = y_i).
    coeffs: Vec<[f64; 4]>,
}

/// Which end condition closes the slope system.
#[derive(Clone, Copy, PartialEq, Eq)]
enum EndCondition {
    Natural,
    NotAKnot,
}

impl CubicSpline {
    /// Natural cubic spline (second derivative zero at both ends).
    ///
    /// Needs at least 2 knots; `x` strictly increasing; all values finite.
    pub fn natural(x: &[f64], y: &[f64]) -> Result<Self, SplineError> {
        Self::build(x, y, EndCondition::Natural)
    }

    /// Not-a-knot cubic spline, identical to MATLAB `spline` and SciPy
    /// `CubicSpline(bc_type='not-a-knot')`.
    ///
    /// Needs at least 2 knots; `x` strictly increasing; all values finite.
    /// With 2 knots it is the line through them, with 3 the parabola.
    pub fn not_a_knot(x: &[f64], y: &[f64]) -> Result<Self, SplineError> {
        Self::build(x, y, EndCondition::NotAKnot)
    }

    /// Value at `x` (end cubics are extrapolated outside the knot range;
    /// NaN in gives NaN out).
    pub fn eval(&self, x: f64) -> f64 {
        let (i, h) = self.locate(x);
        let [c3, c2, c1, c0] = self.coeffs[i];
        ((c3 * h + c2) * h + c1) * h + c0
    }

    /// First derivative at `x` (same extrapolation rule as [`Self::eval`]).
    pub fn eval_derivative(&self, x: f64) -> f64 {
        let (i, h) = self.locate(x);
        let [c3, c2, c1, _] = self.coeffs[i];
        (3.0 * c3 * h + 2.0 * c2) * h + c1
    }

    /// Second derivative at `x` (same extrapolation rule as [`Self::eval`]).
    pub fn eval_second_derivative(&self, x: f64) -> f64 {
        let (i, h) = self.locate(x);
        let [c3, c2, _, _] = self.coeffs[i];
        6.0 * c3 * h + 2.0 * c2
    }

    /// The knots `x_0 < … < x_{n-1}`.
    pub fn knots(&self) -> &[f64] {
        &self.x
    }

    /// Interval index and offset `h = x − x_i` for `x`.
    fn locate(&self, x: f64) -> (usize, f64) {
        // Number of interior knots <= x picks the interval; clamped so that
        // points outside the range use the first/last cubic.
        let n_int = self.coeffs.len();
        let interior = &self.x[1..n_int];
        let i = interior.partition_point(|&k| k <= x);
        (i, x - self.x[i])
    }

    fn build(x: &[f64], y: &[f64], end: EndCondition) -> Result<Self, SplineError> {
        let n = x.len().min(y.len());
        if n < 2 || x.len() != y.len() {
            return Err(SplineError::TooFewPoints { required: 2, actual: n });
        }
        if x.iter().chain(y.iter()).any(|v| !v.is_finite()) {
            return Err(SplineError::NonFinite);
        }
        if let Some(index) = (1..n).find(|&i| x[i] <= x[i - 1]) {
            return Err(SplineError::NotIncreasing { index });
        }

        let dx: Vec<f64> = x.windows(2).map(|w| w[1] - w[0]).collect();
        let slope: Vec<f64> = (0..n - 1).map(|i| (y[i + 1] - y[i]) / dx[i]).collect();

        let s: Vec<f64> = if n == 2 {
            // Both conditions degenerate to the straight line.
            vec![slope[0], slope[0]]
        } else {
            // Tridiagonal system: sub[i] is A[i][i-1] (sub[0] unused),
            // diag[i] = A[i][i], sup[i] = A[i][i+1] (sup[n-1] unused).
            let mut sub = vec![0.0; n];
            let mut diag = vec![0.0; n];
            let mut sup = vec![0.0; n];
            let mut rhs = vec![0.0; n];
            for i in 1..n - 1 {
                sub[i] = dx[i];
                diag[i] = 2.0 * (dx[i - 1] + dx[i]);
                sup[i] = dx[i - 1];
                rhs[i] = 3.0 * (dx[i] * slope[i - 1] + dx[i - 1] * slope[i]);
            }
            match end {
                EndCondition::Natural => {
                    diag[0] = 2.0;
                    sup[0] = 1.0;
                    rhs[0] = 3.0 * slope[0];
                    sub[n - 1] = 1.0;
                    diag[n - 1] = 2.0;
                    rhs[n - 1] = 3.0 * slope[n - 2];
                }
                EndCondition::NotAKnot if n == 3 => {
                    // Parabola through the three points (SciPy/MATLAB).
                    diag[0] = 1.0;
                    sup[0] = 1.0;
                    rhs[0] = 2.0 * slope[0];
                    sub[2] = 1.0;
                    diag[2] = 1.0;
                    rhs[2] = 2.0 * slope[1];
                }
                EndCondition::NotAKnot => {
                    let d0 = x[2] - x[0];
                    diag[0] = dx[1];
                    sup[0] = d0;
                    rhs[0] = ((dx[0] + 2.0 * d0) * dx[1] * slope[0] + dx[0] * dx[0] * slope[1]) / d0;
                    let d1 = x[n - 1] - x[n - 3];
                    let (a, b) = (dx[n - 2], dx[n - 3]);
                    sub[n - 1] = d1;
                    diag[n - 1] = b;
                    rhs[n - 1] = (a * a * slope[n - 3] + (2.0 * d1 + a) * b * slope[n - 2]) / d1;
                }
            }
            solve_tridiagonal_pivoting(&sub, &diag, &sup, &rhs)
        };

        let coeffs: Vec<[f64; 4]> = (0..n - 1)
            .map(|i| {
                let t = (s[i] + s[i + 1] - 2.0 * slope[i]) / dx[i];
                [t / dx[i], (slope[i] - s[i]) / dx[i] - t, s[i], y[i]]
            })
            .collect();
        if coeffs.iter().flatten().any(|c| !c.is_finite()) {
            return Err(SplineError::NonFinite);
        }
        Ok(Self { x: x[..n].to_vec(), coeffs })
    }
}

/// Solves a tridiagonal system by Gaussian elimination with partial pivoting
/// (a row swap creates one extra super-diagonal). A zero pivot (which cannot
/// occur for the spline systems with strictly increasing knots) yields
/// non-finite values that the caller rejects.
fn solve_tridiagonal_pivoting(sub: &[f64], diag: &[f64], sup: &[f64], rhs: &[f64]) -> Vec<f64> {
    let n = diag.len();
    // Upper-triangular rows: u[i] = [A(i,i), A(i,i+1), A(i,i+2)].
    let mut u = vec![[0.0f64; 3]; n];
    let mut b = vec![0.0f64; n];
    // Working row i, columns (i, i+1, i+2), and its rhs.
    let mut cur = [diag[0], sup[0], 0.0];
    let mut cur_b = rhs[0];
    for i in 0..n - 1 {
        let next = [sub[i + 1], diag[i + 1], if i + 2 < n { sup[i + 1] } else { 0.0 }];
        let next_b = rhs[i + 1];
        let (piv, piv_b, oth, oth_b) = if cur[0].abs() >= next[0].abs() { (cur, cur_b, next, next_b) } else { (next, next_b, cur, cur_b) };
        let f = oth[0] / piv[0];
        u[i] = piv;
        b[i] = piv_b;
        cur = [oth[1] - f * piv[1], oth[2] - f * piv[2], 0.0];
        cur_b = oth_b - f * piv_b;
    }
    u[n - 1] = cur;
    b[n - 1] = cur_b;

    let mut s = vec![0.0f64; n];
    for i in (0..n).rev() {
        let mut acc = b[i];
        if i + 1 < n {
            acc -= u[i][1] * s[i + 1];
        }
        if i + 2 < n {
            acc -= u[i][2] * s[i + 2];
        }
        s[i] = acc / u[i][0];
    }
    s
}

#[cfg(test)]
#[allow(clippy::expect_used)] // tests: a failed expect is a test failure
mod tests {
    use super::*;
    use approx::assert_relative_eq;

    fn cubic(x: f64) -> f64 {
        0.7 * x * x * x - 2.0 * x * x + 0.3 * x - 1.5
    }

    #[test]
    fn not_a_knot_reproduces_a_cubic_exactly() {
        // Not-a-knot splines reproduce any cubic (uneven knots on purpose).
        let x = [-1.0, -0.4, 0.3, 0.5, 1.7, 2.0, 3.1];
        let y: Vec<f64> = x.iter().map(|&v| cubic(v)).collect();
        let s = CubicSpline::not_a_knot(&x, &y).expect("valid knots");
        for k in 0..=200 {
            let t = -1.5 + 5.0 * k as f64 / 200.0; // includes extrapolation
                                                   // Round-off only: values are O(10), so 1e-11 absolute is ~1e3 ulp.
            assert_relative_eq!(s.eval(t), cubic(t), epsilon = 1e-11);
        }
    }

    #[test]
    fn natural_has_zero_second_derivative_at_ends() {
        let x = [0.0, 0.5, 1.1, 2.0, 2.2, 3.0];
        let y = [1.0, -0.3, 0.8, 2.5, 2.4, 0.1];
        let s = CubicSpline::natural(&x, &y).expect("valid knots");
        // Exact in exact arithmetic; 1e-12 absorbs round-off on O(10) values.
        assert!(s.eval_second_derivative(0.0).abs() < 1e-12);
        assert!(s.eval_second_derivative(3.0).abs() < 1e-12);
        for (xi, yi) in x.iter().zip(y) {
            assert_relative_eq!(s.eval(*xi), yi, epsilon = 1e-14);
        }
        // C² continuity at an interior knot.
        let e = 1e-9;
        assert_relative_eq!(s.eval_second_derivative(1.1 - e), s.eval_second_derivative(1.1 + e), epsilon = 1e-6);
    }

    #[test]
    fn matches_scipy_reference_values() {
        // Reference computed outside this crate with SciPy 1.17.1
        // (python3 -m venv /tmp/spvenv && /tmp/spvenv/bin/pip install scipy):
        //   from scipy.interpolate import CubicSpline
        //   x=[0,1,2.5,3,4.5]; y=[1,3,2,5,0]
        //   CubicSpline(x,y,bc_type='not-a-knot')([0.3,1.7,2.8,4.0,5.0])
        //   CubicSpline(x,y,bc_type='natural')([0.3,1.7,2.8,4.0,5.0])
        //   CubicSpline([0,1,3],[1,2,0])([2.0,4.0])   # 3-knot parabola
        // Printed with repr(); compared to 1e-12 (solver round-off only).
        let x = [0.0, 1.0, 2.5, 3.0, 4.5];
        let y = [1.0, 3.0, 2.0, 5.0, 0.0];
        let q = [0.3, 1.7, 2.8, 4.0, 5.0];
        let nak = CubicSpline::not_a_knot(&x, &y).expect("valid knots");
        let nat = CubicSpline::natural(&x, &y).expect("valid knots");
        for (i, &t) in q.iter().enumerate() {
            assert_relative_eq!(nak.eval(t), SCIPY_NAK[i], epsilon = 1e-12);
            assert_relative_eq!(nat.eval(t), SCIPY_NAT[i], epsilon = 1e-12);
        }
        let p = CubicSpline::not_a_knot(&[0.0, 1.0, 3.0], &[1.0, 2.0, 0.0]).expect("valid");
        assert_relative_eq!(p.eval(2.0), SCIPY_PARABOLA[0], epsilon = 1e-12);
        assert_relative_eq!(p.eval(4.0), SCIPY_PARABOLA[1], epsilon = 1e-12);
    }

    const SCIPY_NAK: [f64; 5] = [2.6150130841121495, 1.5007003115264799, 3.6536971962616818, 7.134579439252335, -16.78193146417445];
    const SCIPY_NAT: [f64; 5] = [1.9483440860215056, 1.5957626443647954, 3.845763440860214, 3.4285145360414173, -3.428514536041419];
    const SCIPY_PARABOLA: [f64; 2] = [1.6666666666666667, -3.000000000000001];

    #[test]
    fn two_points_give_a_line() {
        let s = CubicSpline::not_a_knot(&[1.0, 3.0], &[2.0, 6.0]).expect("valid");
        assert_relative_eq!(s.eval(2.0), 4.0, epsilon = 1e-15);
        let s = CubicSpline::natural(&[1.0, 3.0], &[2.0, 6.0]).expect("valid");
        assert_relative_eq!(s.eval(0.0), 0.0, epsilon = 1e-15);
    }

    #[test]
    fn rejects_bad_input() {
        assert!(matches!(CubicSpline::natural(&[1.0], &[1.0]), Err(SplineError::TooFewPoints { required: 2, actual: 1 })));
        assert!(matches!(CubicSpline::natural(&[1.0, 2.0, 3.0], &[1.0, 2.0]), Err(SplineError::TooFewPoints { .. })));
        assert!(matches!(CubicSpline::not_a_knot(&[0.0, 1.0, 1.0, 2.0], &[0.0; 4]), Err(SplineError::NotIncreasing { index: 2 })));
        assert!(matches!(CubicSpline::not_a_knot(&[0.0, 1.0, 2.0], &[0.0, f64::NAN, 1.0]), Err(SplineError::NonFinite)));
        assert!(matches!(CubicSpline::not_a_knot(&[0.0, 1.0, 2.0, 1e308 * 10.0], &[0.0; 4]), Err(SplineError::NonFinite)));
    }
}
