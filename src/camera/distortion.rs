//! Brown–Conrady lens distortion in OpenCV's coefficient order
//! `(k1, k2, p1, p2, k3)`: forward model, analytic Jacobians, Newton inverse
//! and the radius of the first radial fold (where the model stops being
//! invertible).
//!
//! Reference: Brown 1966 "Decentering distortion of lenses"; Conrady 1919
//! "Decentred lens-systems"; OpenCV calib3d docs "Camera Calibration and 3D
//! Reconstruction" (`projectPoints`, `undistortPoints`).

use super::CameraError;
use nalgebra::{Matrix2, SMatrix, Vector2};

/// Residual tolerance of [`Distortion::undistort`], normalised units. The
/// specification requires `<= 1e-10`; we iterate to `1e-12` for margin.
pub const UNDISTORT_TOL: f64 = 1e-12;
/// Maximum Newton iterations of [`Distortion::undistort`].
pub const UNDISTORT_MAX_ITER: usize = 50;
/// Largest undistorted radius searched by [`Distortion::max_monotonic_radius`].
pub const MONOTONIC_SEARCH_RADIUS: f64 = 10.0;

/// Distortion coefficients, OpenCV order. With `r2 = x^2 + y^2`,
/// `g = 1 + k1 r2 + k2 r2^2 + k3 r2^3`,
/// `xd = g x + 2 p1 x y + p2 (r2 + 2 x^2)`,
/// `yd = g y + p1 (r2 + 2 y^2) + 2 p2 x y`.
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct Distortion {
    /// Radial coefficient of r^2 (course k1).
    pub k1: f64,
    /// Radial coefficient of r^4 (course k2).
    pub k2: f64,
    /// First tangential coefficient (course k3).
    pub p1: f64,
    /// Second tangential coefficient (course k4).
    pub p2: f64,
    /// Radial coefficient of r^6 (course k5).
    pub k3: f64,
}

impl Distortion {
    /// From `[k1, k2, p1, p2, k3]` (OpenCV order).
    pub fn from_array(a: [f64; 5]) -> Self {
        Self { k1: a[0], k2: a[1], p1: a[2], p2: a[3], k3: a[4] }
    }

    /// To `[k1, k2, p1, p2, k3]` (OpenCV order).
    pub fn to_array(&self) -> [f64; 5] {
        [self.k1, self.k2, self.p1, self.p2, self.k3]
    }

    /// Whether all coefficients are exactly zero (pure pinhole).
    pub fn is_zero(&self) -> bool {
        self.to_array().iter().all(|&c| c == 0.0)
    }

    /// Applies the distortion to normalised undistorted coordinates `xu`.
    pub fn distort(&self, xu: &Vector2<f64>) -> Vector2<f64> {
        let (x, y) = (xu.x, xu.y);
        let r2 = x * x + y * y;
        let g = 1.0 + r2 * (self.k1 + r2 * (self.k2 + r2 * self.k3));
        Vector2::new(g * x + 2.0 * self.p1 * x * y + self.p2 * (r2 + 2.0 * x * x), g * y + self.p1 * (r2 + 2.0 * y * y) + 2.0 * self.p2 * x * y)
    }

    /// Analytic Jacobian `d xd / d xu` (2x2).
    pub fn dxd_dxu(&self, xu: &Vector2<f64>) -> Matrix2<f64> {
        let (x, y) = (xu.x, xu.y);
        let r2 = x * x + y * y;
        let g = 1.0 + r2 * (self.k1 + r2 * (self.k2 + r2 * self.k3));
        // dg/dr2
        let gp = self.k1 + r2 * (2.0 * self.k2 + 3.0 * self.k3 * r2);
        let off = 2.0 * x * y * gp + 2.0 * self.p1 * x + 2.0 * self.p2 * y;
        Matrix2::new(g + 2.0 * x * x * gp + 2.0 * self.p1 * y + 6.0 * self.p2 * x, off, off, g + 2.0 * y * y * gp + 6.0 * self.p1 * y + 2.0 * self.p2 * x)
    }

    /// Analytic Jacobian `d xd / d (k1, k2, p1, p2, k3)` (columns in that order).
    pub fn dxd_dcoeffs(&self, xu: &Vector2<f64>) -> SMatrix<f64, 2, 5> {
        let (x, y) = (xu.x, xu.y);
        let r2 = x * x + y * y;
        let r4 = r2 * r2;
        let r6 = r4 * r2;
        SMatrix::<f64, 2, 5>::new(x * r2, x * r4, 2.0 * x * y, r2 + 2.0 * x * x, x * r6, y * r2, y * r4, r2 + 2.0 * y * y, 2.0 * x * y, y * r6)
    }

    /// Radial factor derivative `h(r) = d(r g(r))/dr = 1 + 3 k1 s + 5 k2 s^2 + 7 k3 s^3`, `s = r^2`.
    fn radial_slope(&self, s: f64) -> f64 {
        1.0 + s * (3.0 * self.k1 + s * (5.0 * self.k2 + s * 7.0 * self.k3))
    }

    /// Smallest undistorted radius `r > 0` where the radial map `r -> r g(r)`
    /// stops increasing (`d(r g)/dr = 0`), or `None` if it is increasing for
    /// all `r <= MONOTONIC_SEARCH_RADIUS` (10).
    ///
    /// `d(r g)/dr` is a cubic in `s = r^2` with value 1 at `s = 0`. It is
    /// monotonic between its critical points (roots of a quadratic, solved in
    /// closed form), so checking the sign at those points and bisecting the
    /// first bracket finds the first root exactly (to ~1e-15 in `s`).
    /// Non-finite coefficients give `Some(0.0)` (nothing is invertible).
    pub fn max_monotonic_radius(&self) -> Option<f64> {
        if !self.to_array().iter().all(|c| c.is_finite()) {
            return Some(0.0);
        }
        let s_max = MONOTONIC_SEARCH_RADIUS * MONOTONIC_SEARCH_RADIUS;
        // p'(s) = a + 2 b s + 3 c s^2 with p(s) = 1 + a s + b s^2 + c s^3.
        let (a, b, c) = (3.0 * self.k1, 5.0 * self.k2, 7.0 * self.k3);
        let mut knots: Vec<f64> = Vec::with_capacity(4);
        if c != 0.0 {
            let disc = 4.0 * b * b - 12.0 * a * c;
            if disc >= 0.0 {
                let sq = disc.sqrt();
                knots.push((-2.0 * b + sq) / (6.0 * c));
                knots.push((-2.0 * b - sq) / (6.0 * c));
            }
        } else if b != 0.0 {
            knots.push(-a / (2.0 * b));
        }
        knots.retain(|&s| s > 0.0 && s < s_max);
        knots.sort_by(f64::total_cmp);
        knots.push(s_max);
        let mut lo = 0.0;
        for &hi in &knots {
            if self.radial_slope(hi) <= 0.0 {
                // p(lo) > 0 >= p(hi), p monotonic on [lo, hi]: bisect.
                let (mut l, mut h) = (lo, hi);
                for _ in 0..200 {
                    let m = 0.5 * (l + h);
                    if m <= l || m >= h {
                        break;
                    }
                    if self.radial_slope(m) > 0.0 {
                        l = m;
                    } else {
                        h = m;
                    }
                }
                return Some(h.sqrt());
            }
            lo = hi;
        }
        None
    }

    /// Inverts [`Self::distort`]: finds `xu` with `distort(xu) = xd`.
    ///
    /// Newton's method with the analytic Jacobian, starting at `xu = xd`, with
    /// step halving whenever the residual would grow; converged when
    /// `|distort(xu) - xd| <= 1e-12` (at most 50 iterations). If the result is
    /// unusable (beyond the first radial fold or `det(dxd_dxu) <= 0`), Newton is
    /// restarted once from `xd` scaled to half the fold radius, which lands on
    /// the first (physical) branch when one exists.
    ///
    /// # Errors
    /// * [`CameraError::NonFinite`] if `xd` is NaN/infinite.
    /// * [`CameraError::NotInvertible`] if Newton does not converge (e.g. `xd`
    ///   lies beyond the largest distorted radius the model reaches), or the only
    ///   solution found lies on a folded part of the model.
    pub fn undistort(&self, xd: &Vector2<f64>) -> Result<Vector2<f64>, CameraError> {
        if !(xd.x.is_finite() && xd.y.is_finite()) {
            return Err(CameraError::NonFinite { what: "distorted normalised point" });
        }
        if self.is_zero() {
            return Ok(*xd);
        }
        let fold = self.max_monotonic_radius();
        let first = self.newton(xd, *xd).and_then(|xu| self.check_branch(&xu, fold));
        match (first, fold) {
            (Ok(xu), _) => Ok(xu),
            (Err(e), Some(rf)) if rf > 0.0 => {
                let n = xd.norm();
                if n > 0.5 * rf {
                    let start = xd * (0.5 * rf / n);
                    self.newton(xd, start).and_then(|xu| self.check_branch(&xu, fold))
                } else {
                    Err(e)
                }
            }
            (Err(e), _) => Err(e),
        }
    }

    fn check_branch(&self, xu: &Vector2<f64>, fold: Option<f64>) -> Result<Vector2<f64>, CameraError> {
        if let Some(rf) = fold {
            let r = xu.norm();
            if r > rf {
                return Err(CameraError::NotInvertible { reason: format!("solution radius {r:.6} lies beyond the first radial fold at {rf:.6}") });
            }
        }
        let det = self.dxd_dxu(xu).determinant();
        if det.is_nan() || det <= 0.0 {
            return Err(CameraError::NotInvertible { reason: format!("distortion Jacobian determinant {det:.3e} <= 0 at the solution (folded model)") });
        }
        Ok(*xu)
    }

    fn newton(&self, xd: &Vector2<f64>, start: Vector2<f64>) -> Result<Vector2<f64>, CameraError> {
        let mut xu = start;
        let mut res = self.distort(&xu) - xd;
        let mut rn = res.norm();
        for _ in 0..UNDISTORT_MAX_ITER {
            if rn <= UNDISTORT_TOL {
                return Ok(xu);
            }
            let j = self.dxd_dxu(&xu);
            let Some(jinv) = j.try_inverse() else {
                return Err(CameraError::NotInvertible { reason: "singular distortion Jacobian during Newton iteration".into() });
            };
            let step = -(jinv * res);
            let mut t = 1.0;
            let mut accepted = false;
            for _ in 0..30 {
                let cand = xu + step * t;
                let cres = self.distort(&cand) - xd;
                let cn = cres.norm();
                if cn.is_finite() && cn < rn {
                    xu = cand;
                    res = cres;
                    rn = cn;
                    accepted = true;
                    break;
                }
                t *= 0.5;
            }
            if !accepted {
                break;
            }
        }
        if rn <= UNDISTORT_TOL {
            return Ok(xu);
        }
        Err(CameraError::NotInvertible {
            reason: format!("Newton did not converge (residual {rn:.3e} > {UNDISTORT_TOL:e} after at most {UNDISTORT_MAX_ITER} iterations)"),
        })
    }
}

#[cfg(test)]
mod tests;
