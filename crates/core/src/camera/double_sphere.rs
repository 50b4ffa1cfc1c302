//! The Double Sphere model (Usenko, Demmel and Cremers, "The Double Sphere Camera Model", 3DV
//! 2018; basalt, Kalibr `ds-none`): with `d1 = |p|`, `d2 = |(x, y, xi d1 + z)|`, the distorted
//! normalised point is `xd = (x, y) / (alpha d2 + (1 - alpha) (xi d1 + z))`, and pixels are
//! `K xd`. Unprojection is closed form (the paper's eq. 45-47).
//!
//! Rays are kept as `(xu, yu, 1)` (`z > 0`), so the renderable region is the paper's valid region
//! (`z > -w2 d1`) within [`MAX_RAY_ANGLE_RAD`] of the axis.

use nalgebra::{Matrix2, Matrix2x3, Vector2, Vector3};

use super::{CameraError, MAX_RAY_ANGLE_RAD};

/// Double Sphere parameters (besides `fx, fy, cx, cy`).
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct DoubleSphere {
    /// Distance between the two unit spheres' centres, `[-1, 1]`.
    pub xi: f64,
    /// Weight of the second sphere, `[0, 1]` (`alpha = 0, xi = 0`: the pinhole).
    pub alpha: f64,
}

impl DoubleSphere {
    /// The paper's `w2`: points with `z > -w2 |p|` are in the valid region.
    pub fn w2(&self) -> f64 {
        let w1 = if self.alpha <= 0.5 { self.alpha / (1.0 - self.alpha) } else { (1.0 - self.alpha) / self.alpha };
        (w1 + self.xi) / (2.0 * w1 * self.xi + self.xi * self.xi + 1.0).sqrt()
    }

    /// The largest `|xu|` of a valid ray `(xu, 1)`: the paper's region, at most
    /// [`MAX_RAY_ANGLE_RAD`] from the axis.
    pub fn max_radius(&self) -> f64 {
        let w2 = self.w2();
        let cap = MAX_RAY_ANGLE_RAD.tan();
        if !w2.is_finite() {
            return 0.0;
        }
        if w2 < 0.0 {
            (1.0 / (w2 * w2) - 1.0).max(0.0).sqrt().min(cap)
        } else {
            cap
        }
    }

    /// Denominator and its gradient with respect to the point, and `d2`, `e = xi d1 + z`.
    fn den(&self, p: &Vector3<f64>) -> (f64, Vector3<f64>, f64, f64, f64) {
        let d1 = p.norm();
        let e = self.xi * d1 + p.z;
        let d2 = (p.x * p.x + p.y * p.y + e * e).sqrt();
        let de = p * (self.xi / d1) + Vector3::z();
        let dd2 = (Vector3::new(p.x, p.y, 0.0) + de * e) / d2;
        let den = self.alpha * d2 + (1.0 - self.alpha) * e;
        (den, dd2 * self.alpha + de * (1.0 - self.alpha), d1, d2, e)
    }

    /// Distorted normalised point of the ray `(xu, 1)`.
    pub fn distort(&self, xu: &Vector2<f64>) -> Vector2<f64> {
        let (den, ..) = self.den(&Vector3::new(xu.x, xu.y, 1.0));
        xu / den
    }

    /// `d xd / d p` at the camera-frame point `p` (2 x 3).
    pub fn dxd_dp(&self, p: &Vector3<f64>) -> Matrix2x3<f64> {
        let (den, dden, ..) = self.den(p);
        let mut j = Matrix2x3::new(1.0 / den, 0.0, 0.0, 0.0, 1.0 / den, 0.0);
        j -= Vector2::new(p.x, p.y) * dden.transpose() / (den * den);
        j
    }

    /// `d xd / d xu` of [`Self::distort`].
    pub fn dxd_dxu(&self, xu: &Vector2<f64>) -> Matrix2<f64> {
        self.dxd_dp(&Vector3::new(xu.x, xu.y, 1.0)).fixed_view::<2, 2>(0, 0).into_owned()
    }

    /// `d xd / d (xi, alpha)` (2 x 2).
    pub fn dxd_dparams(&self, xu: &Vector2<f64>) -> Matrix2<f64> {
        let p = Vector3::new(xu.x, xu.y, 1.0);
        let (den, _, d1, d2, e) = self.den(&p);
        let dden_dxi = (self.alpha * e / d2 + 1.0 - self.alpha) * d1;
        let dden_dalpha = d2 - e;
        let m = -xu / (den * den);
        Matrix2::from_columns(&[m * dden_dxi, m * dden_dalpha])
    }

    /// The ray `(xu, 1)` of the distorted normalised point `xd`, closed form (paper eq. 45-47).
    ///
    /// # Errors
    /// [`CameraError::NonFinite`]; [`CameraError::NotInvertible`] outside the model's image
    /// (`r^2 > 1 / (2 alpha - 1)`) or for rays at or beyond 90 degrees from the axis.
    pub fn undistort(&self, xd: &Vector2<f64>) -> Result<Vector2<f64>, CameraError> {
        if !(xd.x.is_finite() && xd.y.is_finite()) {
            return Err(CameraError::NonFinite { what: "distorted normalised point" });
        }
        let (xi, a) = (self.xi, self.alpha);
        let r2 = xd.norm_squared();
        let q = 1.0 - (2.0 * a - 1.0) * r2;
        if !(q >= 0.0) {
            return Err(CameraError::NotInvertible { reason: format!("r^2 = {r2:.6} is outside the double-sphere image (1 / (2 alpha - 1))") });
        }
        let mz = (1.0 - a * a * r2) / (a * q.sqrt() + 1.0 - a);
        let s = (mz * xi + (mz * mz + (1.0 - xi * xi) * r2).sqrt()) / (mz * mz + r2);
        let z = s * mz - xi;
        let xu = xd * (s / z);
        if !(z > 0.0) || !s.is_finite() || !(xu.norm() <= self.max_radius()) {
            return Err(CameraError::NotInvertible {
                reason: format!("the ray lies outside the model's valid region or beyond 89.5 degrees from the axis (z = {z:.3e})"),
            });
        }
        Ok(xu)
    }
}
