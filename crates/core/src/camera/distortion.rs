//! OpenCV's lens distortion (`cv::projectPoints`): Brown-Conrady radial and tangential terms,
//! the rational radial model, thin prism and the tilted sensor, 14 coefficients in OpenCV's
//! order `(k1, k2, p1, p2, k3, k4, k5, k6, s1, s2, s3, s4, tau_x, tau_y)`: forward model,
//! analytic Jacobians, Newton inverse and the radius of the first radial fold (where the model
//! stops being invertible).
//!
//! Reference: Brown 1966 "Decentering distortion of lenses"; Conrady 1919
//! "Decentred lens-systems"; OpenCV calib3d docs "Camera Calibration and 3D
//! Reconstruction" (`projectPoints`, `undistortPoints`; rational model: Claus and Fitzgibbon
//! 2005; thin prism: Weng et al. 1992).

mod fold;
pub mod tilt;

use super::CameraError;
use nalgebra::{Matrix2, SMatrix, Vector2};

/// Residual tolerance of [`Distortion::undistort`], normalised units. The
/// specification requires `<= 1e-10`; we iterate to `1e-12` for margin.
pub const UNDISTORT_TOL: f64 = 1e-12;
/// Maximum Newton iterations of [`Distortion::undistort`].
pub const UNDISTORT_MAX_ITER: usize = 50;
/// Largest undistorted radius searched by [`Distortion::max_monotonic_radius`].
pub const MONOTONIC_SEARCH_RADIUS: f64 = 10.0;

/// Distortion coefficients, OpenCV order `[k1, k2, p1, p2, k3, k4, k5, k6, s1, s2, s3, s4, tau_x,
/// tau_y]` (`cv::projectPoints`). With `r2 = x^2 + y^2`,
/// `g = (1 + k1 r2 + k2 r2^2 + k3 r2^3) / (1 + k4 r2 + k5 r2^2 + k6 r2^3)`,
/// `x0 = g x + 2 p1 x y + p2 (r2 + 2 x^2) + s1 r2 + s2 r2^2`,
/// `y0 = g y + p1 (r2 + 2 y^2) + 2 p2 x y + s3 r2 + s4 r2^2`, then the tilted sensor
/// `(xd, yd) = proj(T(tau_x, tau_y) (x0, y0, 1))` (see [`tilt`]). The 4-, 5-, 8- and 12-value
/// forms are this vector truncated (the missing values are 0).
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct Distortion {
    /// Radial coefficient of r^2 (Bouguet k1).
    pub k1: f64,
    /// Radial coefficient of r^4 (Bouguet k2).
    pub k2: f64,
    /// First tangential coefficient (Bouguet k3).
    pub p1: f64,
    /// Second tangential coefficient (Bouguet k4).
    pub p2: f64,
    /// Radial coefficient of r^6 (Bouguet k5).
    pub k3: f64,
    /// Rational model: denominator coefficient of r^2.
    pub k4: f64,
    /// Rational model: denominator coefficient of r^4.
    pub k5: f64,
    /// Rational model: denominator coefficient of r^6.
    pub k6: f64,
    /// Thin prism: x coefficient of r^2.
    pub s1: f64,
    /// Thin prism: x coefficient of r^4.
    pub s2: f64,
    /// Thin prism: y coefficient of r^2.
    pub s3: f64,
    /// Thin prism: y coefficient of r^4.
    pub s4: f64,
    /// Tilted sensor: rotation about x, radians.
    pub tau_x: f64,
    /// Tilted sensor: rotation about y, radians.
    pub tau_y: f64,
}

/// Lengths of OpenCV's distortion vector.
pub const OPENCV_LENGTHS: [usize; 5] = [4, 5, 8, 12, 14];

/// Intermediate values of the forward model at one point.
struct Terms {
    x: f64,
    y: f64,
    r2: f64,
    den: f64,
    g: f64,
    /// dg / d(r2).
    dg: f64,
}

impl Distortion {
    /// From `[k1, k2, p1, p2, k3]` (OpenCV order; the other coefficients 0).
    pub fn from_array(a: [f64; 5]) -> Self {
        Self { k1: a[0], k2: a[1], p1: a[2], p2: a[3], k3: a[4], ..Self::default() }
    }

    /// From an OpenCV distortion vector of 4, 5, 8, 12 or 14 values.
    ///
    /// # Errors
    /// [`CameraError::InvalidParameter`] (`dist`) for any other length.
    pub fn from_opencv(v: &[f64]) -> Result<Self, CameraError> {
        if !OPENCV_LENGTHS.contains(&v.len()) {
            return Err(CameraError::InvalidParameter {
                field: "dist",
                reason: format!("OpenCV's distortion vector has 4, 5, 8, 12 or 14 values, got {}", v.len()),
            });
        }
        let mut a = [0.0; 14];
        a[..v.len()].copy_from_slice(v);
        Ok(Self::from_coefficients(a))
    }

    /// From all 14 coefficients in OpenCV order.
    pub fn from_coefficients(a: [f64; 14]) -> Self {
        let [k1, k2, p1, p2, k3, k4, k5, k6, s1, s2, s3, s4, tau_x, tau_y] = a;
        Self { k1, k2, p1, p2, k3, k4, k5, k6, s1, s2, s3, s4, tau_x, tau_y }
    }

    /// All 14 coefficients in OpenCV order.
    pub fn coefficients(&self) -> [f64; 14] {
        [self.k1, self.k2, self.p1, self.p2, self.k3, self.k4, self.k5, self.k6, self.s1, self.s2, self.s3, self.s4, self.tau_x, self.tau_y]
    }

    /// `[k1, k2, p1, p2, k3]` (OpenCV order; the 5-value form).
    pub fn to_array(&self) -> [f64; 5] {
        [self.k1, self.k2, self.p1, self.p2, self.k3]
    }

    /// The shortest OpenCV vector length (4, 5, 8, 12, 14) that holds every non-zero coefficient.
    pub fn opencv_len(&self) -> usize {
        let c = self.coefficients();
        let last = c.iter().rposition(|&v| v != 0.0).map_or(0, |i| i + 1);
        OPENCV_LENGTHS.into_iter().find(|&n| n >= last).unwrap_or(14)
    }

    /// Whether all coefficients are exactly zero (pure pinhole).
    pub fn is_zero(&self) -> bool {
        self.coefficients().iter().all(|&c| c == 0.0)
    }

    /// Whether the sensor is tilted (`tau_x` or `tau_y` non-zero).
    pub fn has_tilt(&self) -> bool {
        self.tau_x != 0.0 || self.tau_y != 0.0
    }

    fn terms(&self, xu: &Vector2<f64>) -> Terms {
        let (x, y) = (xu.x, xu.y);
        let r2 = x * x + y * y;
        let num = 1.0 + r2 * (self.k1 + r2 * (self.k2 + r2 * self.k3));
        let den = 1.0 + r2 * (self.k4 + r2 * (self.k5 + r2 * self.k6));
        let dnum = self.k1 + r2 * (2.0 * self.k2 + 3.0 * self.k3 * r2);
        let dden = self.k4 + r2 * (2.0 * self.k5 + 3.0 * self.k6 * r2);
        let g = num / den;
        Terms { x, y, r2, den, g, dg: (dnum - g * dden) / den }
    }

    /// The untilted distorted point `(x0, y0)`.
    fn untilted(&self, t: &Terms) -> Vector2<f64> {
        let (x, y, r2) = (t.x, t.y, t.r2);
        Vector2::new(
            t.g * x + 2.0 * self.p1 * x * y + self.p2 * (r2 + 2.0 * x * x) + r2 * (self.s1 + self.s2 * r2),
            t.g * y + self.p1 * (r2 + 2.0 * y * y) + 2.0 * self.p2 * x * y + r2 * (self.s3 + self.s4 * r2),
        )
    }

    /// Applies the distortion to normalised undistorted coordinates `xu`.
    pub fn distort(&self, xu: &Vector2<f64>) -> Vector2<f64> {
        let p0 = self.untilted(&self.terms(xu));
        if self.has_tilt() {
            tilt::apply(&tilt::matrix(self.tau_x, self.tau_y), &p0)
        } else {
            p0
        }
    }

    /// `d(x0, y0) / d xu` of the untilted part.
    fn d_untilted(&self, t: &Terms) -> Matrix2<f64> {
        let (x, y, r2) = (t.x, t.y, t.r2);
        let sx = self.s1 + 2.0 * self.s2 * r2;
        let sy = self.s3 + 2.0 * self.s4 * r2;
        let off = 2.0 * x * y * t.dg;
        Matrix2::new(
            t.g + 2.0 * x * x * t.dg + 2.0 * self.p1 * y + 6.0 * self.p2 * x + 2.0 * x * sx,
            off + 2.0 * self.p1 * x + 2.0 * self.p2 * y + 2.0 * y * sx,
            off + 2.0 * self.p1 * x + 2.0 * self.p2 * y + 2.0 * x * sy,
            t.g + 2.0 * y * y * t.dg + 6.0 * self.p1 * y + 2.0 * self.p2 * x + 2.0 * y * sy,
        )
    }

    /// Analytic Jacobian `d xd / d xu` (2x2).
    pub fn dxd_dxu(&self, xu: &Vector2<f64>) -> Matrix2<f64> {
        let t = self.terms(xu);
        let d0 = self.d_untilted(&t);
        if self.has_tilt() {
            tilt::d_apply(&tilt::matrix(self.tau_x, self.tau_y), &self.untilted(&t)) * d0
        } else {
            d0
        }
    }

    /// Analytic Jacobian `d xd / d (k1, k2, p1, p2, k3, k4, k5, k6, s1, s2, s3, s4, tau_x, tau_y)`
    /// (columns in that order).
    pub fn dxd_dcoeffs(&self, xu: &Vector2<f64>) -> SMatrix<f64, 2, 14> {
        self.dxd_dcoeffs_n(xu, true)
    }

    /// [`Self::dxd_dcoeffs`], the two tilt columns left zero unless `with_tilt`.
    pub fn dxd_dcoeffs_n(&self, xu: &Vector2<f64>, with_tilt: bool) -> SMatrix<f64, 2, 14> {
        let t = self.terms(xu);
        let (x, y, r2) = (t.x, t.y, t.r2);
        let (r4, r6) = (r2 * r2, r2 * r2 * r2);
        let (a, b) = (1.0 / t.den, -t.g / t.den);
        let mut j = SMatrix::<f64, 2, 14>::zeros();
        let cols: [[f64; 2]; 12] = [
            [x * r2 * a, y * r2 * a],
            [x * r4 * a, y * r4 * a],
            [2.0 * x * y, r2 + 2.0 * y * y],
            [r2 + 2.0 * x * x, 2.0 * x * y],
            [x * r6 * a, y * r6 * a],
            [x * r2 * b, y * r2 * b],
            [x * r4 * b, y * r4 * b],
            [x * r6 * b, y * r6 * b],
            [r2, 0.0],
            [r4, 0.0],
            [0.0, r2],
            [0.0, r4],
        ];
        for (c, v) in cols.iter().enumerate() {
            j[(0, c)] = v[0];
            j[(1, c)] = v[1];
        }
        let p0 = self.untilted(&t);
        if self.has_tilt() {
            let dm = tilt::d_apply(&tilt::matrix(self.tau_x, self.tau_y), &p0);
            let head = dm * j.fixed_view::<2, 12>(0, 0);
            j.fixed_view_mut::<2, 12>(0, 0).copy_from(&head);
        }
        if with_tilt {
            // The tilt's columns are not zero at tau = 0.
            let (dtx, dty) = tilt::d_apply_dtau(self.tau_x, self.tau_y, &p0);
            j.set_column(12, &dtx);
            j.set_column(13, &dty);
        }
        j
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
