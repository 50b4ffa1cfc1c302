//! Fitzgibbon's one-parameter division lens model about a centre, for the detectors that fit a
//! camera without knowing it (the S-path's radial check, the chessboard's whole-grid prediction):
//! undistorted = c + d / (1 + lambda |d|^2), d the offset from the centre c.
//!
//! Reference: A. W. Fitzgibbon, "Simultaneous linear estimation of multiple view geometry and
//! lens distortion", CVPR 2001.

use nalgebra::Point2;

/// The division model about `centre`: undistorted = centre + d / (1 + lambda |d|^2).
#[derive(Debug, Clone, Copy, PartialEq)]
pub(crate) struct Division {
    pub(crate) centre: Point2<f64>,
    pub(crate) lambda: f64,
}

impl Division {
    /// The undistorted pixel of `p`.
    pub(crate) fn undistort(&self, p: &Point2<f64>) -> Point2<f64> {
        let d = p - self.centre;
        self.centre + d / (1.0 + self.lambda * d.norm_squared())
    }

    /// The image point whose undistorted point is `u` (the inverse of [`Division::undistort`]):
    /// the smaller root r of `lambda r_u r^2 - r + r_u = 0`; `None` where there is none
    /// (pincushion beyond its reach) or the point would have to lie beyond the model's horizon
    /// (`1 + lambda r^2 <= 0`).
    pub(crate) fn distort(&self, u: &Point2<f64>) -> Option<Point2<f64>> {
        let (centre, lambda) = (self.centre, self.lambda);
        let d = u - centre;
        let ru = d.norm();
        if ru < 1e-12 || lambda.abs() < 1e-18 {
            return Some(*u);
        }
        let disc = 1.0 - 4.0 * lambda * ru * ru;
        if !(disc >= 0.0) {
            return None;
        }
        // r = (1 - sqrt(disc)) / (2 lambda ru), written without the cancellation at small lambda
        let r = 2.0 * ru / (1.0 + disc.sqrt());
        (1.0 + lambda * r * r > 0.0).then(|| centre + d * (r / ru))
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn distort_inverts_undistort() {
        let centre = Point2::new(640.0, 512.0);
        for lambda in [-1.5e-6, -4e-7, 0.0, 3e-7] {
            let model = Division { centre, lambda };
            for p in [Point2::new(10.0, 20.0), Point2::new(900.0, 700.0), Point2::new(640.5, 512.0)] {
                let back = model.distort(&model.undistort(&p)).expect("inside the model's reach");
                assert!((back - p).norm() < 1e-9, "lambda {lambda}, {p}: {back}");
            }
        }
    }
}
