//! The gates of the S-path's optimal assignment ([`super::assign`]): the image of each path point's
//! tolerance disc under a fitted camera, an ellipse, and a dot's image distance to it.
//!
//! Reference: Hartley and Zisserman, *Multiple View Geometry*, 2nd ed., 4.8 (first-order
//! propagation through a projection: the ellipse as the Jacobian's image of the disc).

use nalgebra::{Matrix2, Matrix2x3, Matrix3x2, Point2, Point3, Vector2, Vector3};

use super::dlt::Dlt;
use super::grow::facing;
use synthcam_core::target::SPath;

/// The image of a path point's tolerance disc: centre and Jacobian (pixels per metre along two
/// orthonormal tangent directions of the sphere there).
#[derive(Debug, Clone, Copy)]
pub(super) struct Gate {
    pub(super) q: Point2<f64>,
    jac: Matrix2<f64>,
    inv: Matrix2<f64>,
    /// Pixels per metre along the outward normal.
    pub(super) up: Vector2<f64>,
    /// `|jac|` (Frobenius): the ellipse of radius `r` lies within `r |jac|` of its centre.
    reach_per_m: f64,
}

impl Gate {
    /// The gate of point `x` with outward normal `normal`, `None` behind the camera or where
    /// the disc projects edge-on.
    fn at(dlt: &Dlt, x: &Point3<f64>, normal: &Vector3<f64>) -> Option<Self> {
        let y = dlt.p * x.to_homogeneous();
        if y[2] <= 0.0 {
            return None;
        }
        let q = Point2::new(y[0] / y[2], y[1] / y[2]);
        let m = dlt.p.fixed_view::<3, 3>(0, 0);
        let d = Matrix2x3::from_rows(&[(m.row(0) - q.x * m.row(2)) / y[2], (m.row(1) - q.y * m.row(2)) / y[2]]);
        let a = normal.cross(&Vector3::z()).try_normalize(1e-6).unwrap_or_else(|| normal.cross(&Vector3::x()).normalize());
        let jac = d * Matrix3x2::from_columns(&[a, normal.cross(&a)]);
        Some(Self { q, jac, inv: jac.try_inverse()?, up: d * normal, reach_per_m: jac.norm() })
    }

    /// Whether `u` may lie within `reach` px of the ellipse of [`Gate::distance`]: false only
    /// where it cannot (its distance to the centre exceeds `reach` plus the ellipse's extent, a
    /// bound), so a test before the distance changes no result.
    pub(super) fn may_reach(&self, u: &Point2<f64>, r: f64, h: f64, reach: f64) -> bool {
        (u - (self.q + self.up * h)).norm() <= reach + r * self.reach_per_m + 1e-9 * (1.0 + reach)
    }

    /// Image distance from `u` to the ellipse of radius `r` metres (0 inside) around the point
    /// `h` metres off the sphere along its normal, pixels, and the tangent offset over `r`.
    pub(super) fn distance(&self, u: &Point2<f64>, r: f64, h: f64) -> (f64, f64) {
        let q = self.q + self.up * h;
        let t = self.inv * (u - q);
        let n = t.norm();
        if n <= r {
            (0.0, n / r)
        } else {
            ((u - q - self.jac * (t * (r / n))).norm(), n / r)
        }
    }
}

/// The gates of every path point the camera sees (facing it: dots on the far side of the sphere
/// are hidden; every point where the camera centre is at infinity).
pub(super) fn gates(dlt: &Dlt, path: &SPath) -> Vec<Option<Gate>> {
    let centre = dlt.centre();
    (0..path.len()).map(|i| facing(path, i, centre).then(|| Gate::at(dlt, &path.points_m[i], &path.normal_at(i))).flatten()).collect()
}
