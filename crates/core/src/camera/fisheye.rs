//! OpenCV's fisheye model (Kannala-Brandt with four coefficients, `cv::fisheye`): with
//! `r = |xu|`, `theta = atan(r)` (the angle from the optical axis),
//! `theta_d = theta (1 + k1 theta^2 + k2 theta^4 + k3 theta^6 + k4 theta^8)` and the distorted
//! normalised point `xd = (theta_d / r) xu`.
//!
//! Reference: Kannala and Brandt, "A generic camera model and calibration method for
//! conventional, wide-angle, and fish-eye lenses", IEEE PAMI 28(8), 2006; OpenCV
//! `cv::fisheye::projectPoints` (the same formulas; Kalibr `pinhole-equi`, ROS `equidistant`).
//!
//! The angle from the axis is `theta = atan2(|(x, y)|, z)` of the camera-frame point, so points
//! at and beyond 90 degrees (z <= 0) project too: fields of view beyond 180 degrees render, up to
//! [`FISHEYE_MAX_ANGLE_RAD`] from the axis and within the model's one-to-one region
//! ([`Fisheye::theta_max`]). For `z > 0` this is OpenCV's `theta = atan(|xu|)`; OpenCV's
//! `cv::fisheye` divides by z first and so cannot map points at or behind 90 degrees (its files
//! hold the same four coefficients). The `(xu, yu, 1)` forms ([`Fisheye::distort`],
//! [`Fisheye::undistort`]) cover `theta <` [`MAX_RAY_ANGLE_RAD`]; the ray forms
//! ([`Fisheye::distort_ray`], [`Fisheye::undistort_ray`]) the whole reach.

use nalgebra::{Matrix2, Matrix2x3, SMatrix, Vector2, Vector3};

use super::{CameraError, MAX_RAY_ANGLE_RAD};

/// The fisheye model's largest angle from the optical axis (175 degrees: a field of view up to
/// 350 degrees; next to 180 the direction of the image radius is undefined).
pub const FISHEYE_MAX_ANGLE_RAD: f64 = 175.0 * std::f64::consts::PI / 180.0;

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

    /// The largest angle from the axis (radians, at most [`FISHEYE_MAX_ANGLE_RAD`]) up to which
    /// `theta_d` grows: the model's one-to-one region, bracketed on 256 steps and bisected.
    pub fn theta_max(&self) -> f64 {
        if !self.k.iter().all(|c| c.is_finite()) {
            return 0.0;
        }
        let n = 256;
        let mut lo = 0.0;
        for i in 1..=n {
            let hi = FISHEYE_MAX_ANGLE_RAD * f64::from(i) / f64::from(n);
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
        FISHEYE_MAX_ANGLE_RAD
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
        Self::coeff_columns(&(xu / r), r.atan())
    }

    /// Distorted normalised point of the camera-frame point (direction) `p`, theta from atan2:
    /// [`Self::distort`] of `p.xy / p.z` where `z > 0`, and the same formula on the angle where
    /// `z <= 0` (NaN on the axis behind the camera).
    pub fn distort_ray(&self, p: &Vector3<f64>) -> Vector2<f64> {
        if p.z > 0.0 {
            return self.distort(&(p.xy() / p.z));
        }
        let r = p.xy().norm();
        p.xy() * (self.theta_d(r.atan2(p.z)).0 / r)
    }

    /// `d xd / d p` (2 x 3) of [`Self::distort_ray`]. With `r = |(x, y)|`, `rho = |p|`:
    /// `d theta / d(x, y) = z (x, y) / (r rho^2)`, `d theta / d z = -r / rho^2`, and
    /// `xd = s (x, y)` with `s = theta_d / r`.
    pub fn dxd_dp(&self, p: &Vector3<f64>) -> Matrix2x3<f64> {
        if p.z > 0.0 {
            let iz = 1.0 / p.z;
            let dxu_dp = Matrix2x3::new(iz, 0.0, -p.x * iz * iz, 0.0, iz, -p.y * iz * iz);
            return self.dxd_dxu(&(p.xy() / p.z)) * dxu_dp;
        }
        let xy = p.xy();
        let r = xy.norm();
        let rho2 = p.norm_squared();
        let (td, dtd) = self.theta_d(r.atan2(p.z));
        let s = td / r;
        let dth = Vector3::new(p.z * xy.x / (r * rho2), p.z * xy.y / (r * rho2), -r / rho2);
        let ds = dth * (dtd / r) - Vector3::new(xy.x, xy.y, 0.0) * (td / (r * r * r));
        let mut j = xy * ds.transpose();
        j[(0, 0)] += s;
        j[(1, 1)] += s;
        j
    }

    /// `d xd / d (k1, k2, k3, k4)` (2 x 4) at the camera-frame point `p` (any direction).
    pub fn dxd_dcoeffs_ray(&self, p: &Vector3<f64>) -> SMatrix<f64, 2, 4> {
        if p.z > 0.0 {
            return self.dxd_dcoeffs(&(p.xy() / p.z));
        }
        let r = p.xy().norm();
        Self::coeff_columns(&(p.xy() / r), r.atan2(p.z))
    }

    /// The columns `u theta^(3, 5, 7, 9)` of `d xd / d k` (`u` the unit image direction).
    fn coeff_columns(u: &Vector2<f64>, th: f64) -> SMatrix<f64, 2, 4> {
        let mut j = SMatrix::<f64, 2, 4>::zeros();
        for (i, p) in [3, 5, 7, 9].into_iter().enumerate() {
            j.set_column(i, &(u * th.powi(p)));
        }
        j
    }

    /// The angle from the axis of the distorted radius `rd > 0`: Newton on theta, safeguarded by
    /// bisection on `[0, theta_max]`.
    fn theta_of(&self, rd: f64) -> Result<f64, CameraError> {
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
        Ok(th)
    }

    /// `xu` with `distort(xu) = xd`: theta by Newton (safeguarded by bisection), then
    /// `xu = tan(theta) xd / |xd|`.
    ///
    /// # Errors
    /// [`CameraError::NonFinite`] for a non-finite `xd`; [`CameraError::NotInvertible`] beyond
    /// the distorted radius the model reaches within its one-to-one region, or where the ray is
    /// [`MAX_RAY_ANGLE_RAD`] or more from the axis (no `(xu, yu, 1)` form:
    /// [`Self::undistort_ray`] has it).
    pub fn undistort(&self, xd: &Vector2<f64>) -> Result<Vector2<f64>, CameraError> {
        if !(xd.x.is_finite() && xd.y.is_finite()) {
            return Err(CameraError::NonFinite { what: "distorted normalised point" });
        }
        let rd = xd.norm();
        if rd < SMALL_R {
            return Ok(*xd);
        }
        let th = self.theta_of(rd)?;
        if !(th < MAX_RAY_ANGLE_RAD) {
            return Err(CameraError::NotInvertible {
                reason: format!("the ray is {:.3} deg from the axis: no (xu, yu, 1) form (use the unit ray)", th.to_degrees()),
            });
        }
        Ok(xd * (th.tan() / rd))
    }

    /// The unit ray `(sin(theta) xd / |xd|, cos(theta))` with `distort_ray(ray) = xd`, at any
    /// angle the model reaches (beyond 90 degrees too).
    ///
    /// # Errors
    /// [`CameraError::NonFinite`] for a non-finite `xd`; [`CameraError::NotInvertible`] beyond
    /// the distorted radius the model reaches within its one-to-one region.
    pub fn undistort_ray(&self, xd: &Vector2<f64>) -> Result<Vector3<f64>, CameraError> {
        if !(xd.x.is_finite() && xd.y.is_finite()) {
            return Err(CameraError::NonFinite { what: "distorted normalised point" });
        }
        let rd = xd.norm();
        if rd < SMALL_R {
            return Ok(Vector3::new(xd.x, xd.y, 1.0).normalize());
        }
        let th = self.theta_of(rd)?;
        let u = xd / rd;
        Ok(Vector3::new(u.x * th.sin(), u.y * th.sin(), th.cos()))
    }
}
