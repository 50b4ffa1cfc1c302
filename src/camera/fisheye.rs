//! OpenCV's fisheye model (Kannala-Brandt with four coefficients, `cv::fisheye`): with
//! `r = |xu|`, `theta = atan(r)` (the angle from the optical axis),
//! `theta_d = theta (1 + k1 theta^2 + k2 theta^4 + k3 theta^6 + k4 theta^8)` and the distorted
//! normalised point `xd = (theta_d / r) xu`.
//!
//! Reference: Kannala and Brandt, "A generic camera model and calibration method for
//! conventional, wide-angle, and fish-eye lenses", IEEE PAMI 28(8), 2006; OpenCV
//! `cv::fisheye::projectPoints` (the same formulas; Kalibr `pinhole-equi`, ROS `equidistant`).
//!
//! Rays are kept as `(xu, yu, 1)`, so the renderable region is `theta <` [`MAX_RAY_ANGLE_RAD`]
//! (89.5 degrees: a field of view below 180 degrees), and the model must be monotonic there:
//! [`Fisheye::theta_max`].

use nalgebra::{Matrix2, SMatrix, Vector2};

use super::{CameraError, MAX_RAY_ANGLE_RAD};

/// Kannala-Brandt coefficients `[k1, k2, k3, k4]` (OpenCV's fisheye `D`).
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct Fisheye {
    /// Coefficients of theta^3, theta^5, theta^7, theta^9.
    pub k: [f64; 4],
}

/// Below this radius the model is the identity to rounding (`theta_d / r = 1 + O(r^2)`).
const SMALL_R: f64 = 1e-10;

impl Fisheye {
    /// `theta_d(theta)` and its derivative.
    fn theta_d(&self, th: f64) -> (f64, f64) {
        let t2 = th * th;
        let [k1, k2, k3, k4] = self.k;
        let poly = 1.0 + t2 * (k1 + t2 * (k2 + t2 * (k3 + t2 * k4)));
        let dpoly = 1.0 + t2 * (3.0 * k1 + t2 * (5.0 * k2 + t2 * (7.0 * k3 + t2 * 9.0 * k4)));
        (th * poly, dpoly)
    }

    /// The largest angle from the axis (radians, at most [`MAX_RAY_ANGLE_RAD`]) up to which
    /// `theta_d` grows: the model's one-to-one region, bracketed on 128 steps and bisected.
    pub fn theta_max(&self) -> f64 {
        if !self.k.iter().all(|c| c.is_finite()) {
            return 0.0;
        }
        let n = 128;
        let mut lo = 0.0;
        for i in 1..=n {
            let hi = MAX_RAY_ANGLE_RAD * f64::from(i) / f64::from(n);
            if self.theta_d(hi).1 <= 0.0 {
                let (mut l, mut h) = (lo, hi);
                for _ in 0..100 {
                    let m = 0.5 * (l + h);
                    if self.theta_d(m).1 > 0.0 {
                        l = m;
                    } else {
                        h = m;
                    }
                }
                return l;
            }
            lo = hi;
        }
        MAX_RAY_ANGLE_RAD
    }

    /// Distorted normalised point of the undistorted `xu`.
    pub fn distort(&self, xu: &Vector2<f64>) -> Vector2<f64> {
        let r = xu.norm();
        if r < SMALL_R {
            return *xu;
        }
        xu * (self.theta_d(r.atan()).0 / r)
    }

    /// `d xd / d xu` (2 x 2).
    pub fn dxd_dxu(&self, xu: &Vector2<f64>) -> Matrix2<f64> {
        let r = xu.norm();
        if r < SMALL_R {
            return Matrix2::identity();
        }
        let th = r.atan();
        let (td, dtd) = self.theta_d(th);
        let s = td / r;
        // ds/dr / r = (dtd / (1 + r^2) - s) / r^2
        let ds_r = (dtd / (1.0 + r * r) - s) / (r * r);
        Matrix2::identity() * s + xu * xu.transpose() * ds_r
    }

    /// `d xd / d (k1, k2, k3, k4)` (2 x 4).
    pub fn dxd_dcoeffs(&self, xu: &Vector2<f64>) -> SMatrix<f64, 2, 4> {
        let r = xu.norm();
        if r < SMALL_R {
            return SMatrix::zeros();
        }
        let th = r.atan();
        let u = xu / r;
        let mut j = SMatrix::<f64, 2, 4>::zeros();
        for (i, p) in [3, 5, 7, 9].into_iter().enumerate() {
            j.set_column(i, &(u * th.powi(p)));
        }
        j
    }

    /// `xu` with `distort(xu) = xd`: Newton on theta (safeguarded by bisection on
    /// `[0, theta_max]`), then `xu = tan(theta) xd / |xd|`.
    ///
    /// # Errors
    /// [`CameraError::NonFinite`] for a non-finite `xd`; [`CameraError::NotInvertible`] beyond
    /// the distorted radius the model reaches within its one-to-one region (or 90 degrees).
    pub fn undistort(&self, xd: &Vector2<f64>) -> Result<Vector2<f64>, CameraError> {
        if !(xd.x.is_finite() && xd.y.is_finite()) {
            return Err(CameraError::NonFinite { what: "distorted normalised point" });
        }
        let rd = xd.norm();
        if rd < SMALL_R {
            return Ok(*xd);
        }
        let th_max = self.theta_max();
        if !(rd < self.theta_d(th_max).0) {
            return Err(CameraError::NotInvertible {
                reason: format!(
                    "distorted radius {rd:.6} is beyond the fisheye model's reach ({:.6} at {:.3} deg)",
                    self.theta_d(th_max).0,
                    th_max.to_degrees()
                ),
            });
        }
        let (mut lo, mut hi, mut th) = (0.0, th_max, rd.min(th_max * 0.999));
        for _ in 0..100 {
            let (f, df) = self.theta_d(th);
            let f = f - rd;
            if f.abs() <= 1e-15 * (1.0 + rd) {
                break;
            }
            if f > 0.0 {
                hi = th;
            } else {
                lo = th;
            }
            let next = th - f / df;
            th = if next > lo && next < hi { next } else { 0.5 * (lo + hi) };
        }
        Ok(xd * (th.tan() / rd))
    }
}
