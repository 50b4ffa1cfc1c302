//! OpenCV's tilted-sensor model (`tau_x`, `tau_y`; Scheimpflug cameras): the distorted point
//! `(x0, y0)` is mapped through `T = P_z(R) R`, `R = R_y(tau_y) R_x(tau_x)`, and dehomogenised.
//!
//! Reference: OpenCV `calib3d/src/distortion_model.hpp`, `computeTiltProjectionMatrix` (the matrix
//! and its derivatives written out here from the same definition; Louhichi et al. 2007,
//! "Self-calibration of Scheimpflug cameras").

use nalgebra::{Matrix2, Matrix2x3, Matrix3, Vector2, Vector3};

fn rot_x(t: f64) -> (Matrix3<f64>, Matrix3<f64>) {
    let (s, c) = t.sin_cos();
    (Matrix3::new(1.0, 0.0, 0.0, 0.0, c, s, 0.0, -s, c), Matrix3::new(0.0, 0.0, 0.0, 0.0, -s, c, 0.0, -c, -s))
}

fn rot_y(t: f64) -> (Matrix3<f64>, Matrix3<f64>) {
    let (s, c) = t.sin_cos();
    (Matrix3::new(c, 0.0, -s, 0.0, 1.0, 0.0, s, 0.0, c), Matrix3::new(-s, 0.0, -c, 0.0, 0.0, 0.0, c, 0.0, -s))
}

fn proj_z(r: &Matrix3<f64>) -> Matrix3<f64> {
    Matrix3::new(r[(2, 2)], 0.0, -r[(0, 2)], 0.0, r[(2, 2)], -r[(1, 2)], 0.0, 0.0, 0.0)
}

/// `T(tau_x, tau_y)` as OpenCV computes it.
pub fn matrix(tau_x: f64, tau_y: f64) -> Matrix3<f64> {
    let r = rot_y(tau_y).0 * rot_x(tau_x).0;
    let mut p = proj_z(&r);
    p[(2, 2)] = 1.0;
    p * r
}

/// `dT/dtau_x`, `dT/dtau_y`.
fn d_matrix(tau_x: f64, tau_y: f64) -> (Matrix3<f64>, Matrix3<f64>) {
    let ((rx, drx), (ry, dry)) = (rot_x(tau_x), rot_y(tau_y));
    let r = ry * rx;
    let mut p = proj_z(&r);
    p[(2, 2)] = 1.0;
    let d = |dr: Matrix3<f64>| proj_z(&dr) * r + p * dr;
    (d(ry * drx), d(dry * rx))
}

/// `proj(T (p0, 1))`.
pub fn apply(t: &Matrix3<f64>, p0: &Vector2<f64>) -> Vector2<f64> {
    let v = t * Vector3::new(p0.x, p0.y, 1.0);
    Vector2::new(v.x / v.z, v.y / v.z)
}

fn d_proj(v: &Vector3<f64>) -> Matrix2x3<f64> {
    let iz = 1.0 / v.z;
    Matrix2x3::new(iz, 0.0, -v.x * iz * iz, 0.0, iz, -v.y * iz * iz)
}

/// `d apply / d p0` (2 x 2).
pub fn d_apply(t: &Matrix3<f64>, p0: &Vector2<f64>) -> Matrix2<f64> {
    let v = t * Vector3::new(p0.x, p0.y, 1.0);
    d_proj(&v) * t.fixed_view::<3, 2>(0, 0)
}

/// `d apply / d tau_x`, `d apply / d tau_y` at `p0`.
pub fn d_apply_dtau(tau_x: f64, tau_y: f64, p0: &Vector2<f64>) -> (Vector2<f64>, Vector2<f64>) {
    let h = Vector3::new(p0.x, p0.y, 1.0);
    let dp = d_proj(&(matrix(tau_x, tau_y) * h));
    let (dx, dy) = d_matrix(tau_x, tau_y);
    (dp * (dx * h), dp * (dy * h))
}
