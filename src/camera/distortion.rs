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
mod tests {
    use super::*;
    use crate::math::numdiff::central_diff;
    use nalgebra::{DMatrix, DVector};
    use proptest::prelude::*;

    fn strong() -> Distortion {
        Distortion::from_array([-0.25, 0.12, 1e-3, -5e-4, 0.01])
    }

    /// Max abs difference, scaled by 1 + |numeric| entries.
    fn rel_err(a: &DMatrix<f64>, n: &DMatrix<f64>) -> f64 {
        (a - n).amax() / (1.0 + n.amax())
    }

    const PTS: [[f64; 2]; 6] = [[0.0, 0.0], [0.3, -0.2], [-0.5, 0.4], [0.7, 0.6], [-0.05, -0.9], [1.0, 0.0]];

    #[test]
    fn array_round_trip_and_zero() {
        let d = strong();
        assert_eq!(Distortion::from_array(d.to_array()), d);
        assert!(Distortion::default().is_zero());
        assert!(!d.is_zero());
        let p = Vector2::new(0.3, -0.4);
        assert_eq!(Distortion::default().distort(&p), p);
    }

    #[test]
    fn distort_hand_value() {
        // x = 0.1, y = -0.05, r2 = 0.0125; k1=-0.2, k2=0.05, p1=1e-3, p2=-2e-3, k3=0.01.
        // g = 1 - 0.0025 + 0.05*1.5625e-4 + 0.01*1.953125e-6 = 0.99750783203125
        // xd = 0.0997507832... + 2e-3*(-0.005) - 2e-3*0.0325 = 0.099675783203125
        // yd = -0.04987539160... + 1e-3*0.0175 + 2*(-2e-3)*(-0.005) = -0.0498378916015625
        let d = Distortion::from_array([-0.2, 0.05, 1e-3, -2e-3, 0.01]);
        let xd = d.distort(&Vector2::new(0.1, -0.05));
        assert!((xd.x - 0.099675783203125).abs() < 1e-15);
        assert!((xd.y - (-0.0498378916015625)).abs() < 1e-15);
    }

    #[test]
    fn dxd_dxu_matches_central_diff() {
        // h = 1e-6: truncation O(h^2 * |f'''|) ~ 1e-12 * O(10), rounding
        // ~ eps/h ~ 1e-10. Tolerance 1e-7 relative is 3 orders above that and
        // far below any wrong term (the smallest, p2 x ~ 5e-4 * 0.3, is 1.5e-4).
        for d in [strong(), Distortion::from_array([0.1, -0.02, -2e-3, 3e-3, -0.004])] {
            for p in PTS {
                let xu = Vector2::new(p[0], p[1]);
                let a = d.dxd_dxu(&xu);
                let n = central_diff(
                    |v| {
                        let r = d.distort(&Vector2::new(v[0], v[1]));
                        DVector::from_vec(vec![r.x, r.y])
                    },
                    &DVector::from_vec(vec![p[0], p[1]]),
                    1e-6,
                );
                let a = DMatrix::from_iterator(2, 2, a.iter().copied());
                assert!(rel_err(&a, &n) < 1e-7, "at {p:?}: {a} vs {n}");
            }
        }
    }

    #[test]
    fn dxd_dcoeffs_matches_central_diff() {
        // Linear in the coefficients: central difference exact up to
        // rounding ~1e-10; 1e-8 catches any wrong column (entries >= 1e-3
        // at these points except at the origin where everything is zero).
        let d = strong();
        for p in PTS {
            let xu = Vector2::new(p[0], p[1]);
            let a = d.dxd_dcoeffs(&xu);
            let n = central_diff(
                |c| {
                    let dd = Distortion::from_array([c[0], c[1], c[2], c[3], c[4]]);
                    let r = dd.distort(&xu);
                    DVector::from_vec(vec![r.x, r.y])
                },
                &DVector::from_row_slice(&d.to_array()),
                1e-6,
            );
            let a = DMatrix::from_iterator(2, 5, a.iter().copied());
            assert!(rel_err(&a, &n) < 1e-8, "at {p:?}: {a} vs {n}");
        }
    }

    #[test]
    fn max_monotonic_radius_values() {
        // k1 only: d(r - 0.25 r^3)/dr = 1 - 0.75 r^2 = 0 at r = sqrt(4/3).
        let d = Distortion::from_array([-0.25, 0.0, 0.0, 0.0, 0.0]);
        let r = d.max_monotonic_radius().unwrap_or(f64::NAN);
        assert!((r - (4.0f64 / 3.0).sqrt()).abs() < 1e-12);
        // k1=-0.25, k2=0.12: 1 - 0.75 s + 0.6 s^2 has no real root -> None.
        assert_eq!(Distortion::from_array([-0.25, 0.12, 0.0, 0.0, 0.0]).max_monotonic_radius(), None);
        assert_eq!(Distortion::default().max_monotonic_radius(), None);
        // Pincushion with negative k3: must find a root and slope must vanish there.
        let d = Distortion::from_array([0.5, 0.0, 0.0, 0.0, -0.3]);
        let r = d.max_monotonic_radius().unwrap_or(f64::NAN);
        assert!(r > 1.0 && r < 1.1, "{r}");
        assert!(d.radial_slope(r * r).abs() < 1e-12);
        // Positive k1 with a late fold from negative k2:
        // 1 + 0.3 s - 0.05 s^2 = 0 -> s = (0.3 + sqrt(0.09+0.2))/0.1 = 8.385...
        let d = Distortion::from_array([0.1, -0.01, 0.0, 0.0, 0.0]);
        let s: f64 = (0.3 + 0.29f64.sqrt()) / 0.1;
        let r = d.max_monotonic_radius().unwrap_or(f64::NAN);
        assert!((r - s.sqrt()).abs() < 1e-12, "{r} vs {}", s.sqrt());
    }

    #[test]
    fn undistort_round_trip_points() {
        let d = strong();
        for p in PTS {
            let xu = Vector2::new(p[0], p[1]);
            let back = d.undistort(&d.distort(&xu));
            assert!(matches!(back, Ok(b) if (b - xu).amax() < 1e-10), "{p:?}: {back:?}");
        }
    }

    #[test]
    fn folded_model_is_not_invertible() {
        // k1 = -0.6: r - 0.6 r^3 peaks at r = sqrt(1/1.8) = 0.745 with
        // distorted radius 0.497; xd at radius 0.6 has no preimage.
        let d = Distortion::from_array([-0.6, 0.0, 0.0, 0.0, 0.0]);
        let r = d.undistort(&Vector2::new(0.6, 0.0));
        assert!(matches!(r, Err(CameraError::NotInvertible { .. })), "{r:?}");
        let r = d.undistort(&Vector2::new(3.0, -4.0));
        assert!(matches!(r, Err(CameraError::NotInvertible { .. })), "{r:?}");
        // A point beyond the fold (r = 1.0 -> 0.4) undistorts to the first
        // branch, never to a folded solution.
        let xd = d.distort(&Vector2::new(1.0, 0.0));
        let rf = d.max_monotonic_radius().unwrap_or(0.0);
        let xu = d.undistort(&xd);
        assert!(matches!(xu, Ok(v) if v.norm() < rf && (d.distort(&v) - xd).norm() < 1e-10), "{xu:?}");
    }

    #[test]
    fn restart_recovers_first_branch() {
        // Pincushion then fold (fold ~1.04, peak distorted radius ~1.21).
        // Newton from xd = 1.1 starts beyond the fold and runs to the outer
        // root; the restart must return the inner root instead.
        let d = Distortion::from_array([0.5, 0.0, 0.0, 0.0, -0.3]);
        let rf = d.max_monotonic_radius().unwrap_or(0.0);
        let xd = Vector2::new(1.1, 0.0);
        let xu = d.undistort(&xd);
        assert!(matches!(xu, Ok(v) if v.norm() < rf && (d.distort(&v) - xd).norm() < 1e-10), "{xu:?}");
    }

    #[test]
    fn non_finite_input_is_error() {
        let d = strong();
        for v in [Vector2::new(f64::NAN, 0.0), Vector2::new(0.0, f64::INFINITY)] {
            assert!(matches!(d.undistort(&v), Err(CameraError::NonFinite { .. })));
        }
        // NaN coefficients: error, no panic / infinite loop.
        let bad = Distortion::from_array([f64::NAN, 0.0, 0.0, 0.0, 0.0]);
        assert!(bad.undistort(&Vector2::new(0.1, 0.1)).is_err());
    }

    proptest! {
        #[test]
        fn prop_round_trip(x in -1.0f64..1.0, y in -1.0f64..1.0) {
            // Strong model is monotonic (no fold) on this square; the
            // Jacobian's smallest singular value is > 0.5 there, so a
            // residual of 1e-12 means an error of at most ~2e-12.
            let d = strong();
            let xu = Vector2::new(x, y);
            let back = d.undistort(&d.distort(&xu));
            prop_assert!(back.is_ok());
            if let Ok(b) = back {
                prop_assert!((b - xu).amax() <= 1e-10);
            }
        }
    }
}
