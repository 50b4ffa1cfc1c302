//! Pinhole intrinsics `K = [[fx, skew, cx], [0, fy, cy], [0, 0, 1]]` and the
//! affine map between normalised (distorted) image coordinates and pixels.
//!
//! Reference: Zhang 2000 "A flexible new technique for camera calibration"
//! (skew as `K[0][1]`); OpenCV calib3d docs "Camera Calibration and 3D
//! Reconstruction" (pixel convention, no skew there).

use nalgebra::{Matrix3, Point2, Vector2};

/// Pinhole intrinsics in pixels. `skew` is `K[0][1]` in pixels (Bouguet's
/// `alpha` times `fx`).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Intrinsics {
    /// Focal length along x, pixels.
    pub fx: f64,
    /// Focal length along y, pixels.
    pub fy: f64,
    /// Principal point x, pixels (OpenCV convention: pixel centres at integers).
    pub cx: f64,
    /// Principal point y, pixels.
    pub cy: f64,
    /// Skew `K[0][1]`, pixels.
    pub skew: f64,
}

impl Intrinsics {
    /// The 3x3 calibration matrix `K`.
    pub fn matrix(&self) -> Matrix3<f64> {
        Matrix3::new(self.fx, self.skew, self.cx, 0.0, self.fy, self.cy, 0.0, 0.0, 1.0)
    }

    /// Reads `fx = K[0][0]`, `skew = K[0][1]`, `cx = K[0][2]`, `fy = K[1][1]`,
    /// `cy = K[1][2]`. The matrix is assumed to be normalised (`K[2][2] = 1`,
    /// zero below the diagonal); those entries are ignored.
    pub fn from_matrix(k: &Matrix3<f64>) -> Self {
        Self { fx: k[(0, 0)], fy: k[(1, 1)], cx: k[(0, 2)], cy: k[(1, 2)], skew: k[(0, 1)] }
    }

    /// Normalised distorted coordinates to pixels:
    /// `u = fx xd + skew yd + cx`, `v = fy yd + cy`.
    pub fn normalized_to_pixel(&self, xd: &Vector2<f64>) -> Point2<f64> {
        Point2::new(self.fx * xd.x + self.skew * xd.y + self.cx, self.fy * xd.y + self.cy)
    }

    /// Pixels to normalised distorted coordinates (inverse of
    /// [`Self::normalized_to_pixel`]). Requires `fx, fy != 0` (see
    /// `CameraModel::validate`); otherwise the result is non-finite.
    pub fn pixel_to_normalized(&self, q_px: &Point2<f64>) -> Vector2<f64> {
        let yd = (q_px.y - self.cy) / self.fy;
        let xd = (q_px.x - self.cx - self.skew * yd) / self.fx;
        Vector2::new(xd, yd)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn k() -> Intrinsics {
        Intrinsics { fx: 1000.0, fy: 980.0, cx: 639.5, cy: 511.5, skew: 0.5 }
    }

    #[test]
    fn matrix_round_trip() {
        let i = k();
        assert_eq!(Intrinsics::from_matrix(&i.matrix()), i);
        assert_eq!(i.matrix()[(0, 1)], 0.5);
    }

    #[test]
    fn pixel_map_matches_matrix_and_inverts() {
        let i = k();
        let xd = Vector2::new(0.31, -0.22);
        let q = i.normalized_to_pixel(&xd);
        let h = i.matrix() * xd.push(1.0);
        // Same arithmetic in a different order: rounding only (~1e-13 px).
        assert!((q.x - h.x).abs() < 1e-10 && (q.y - h.y).abs() < 1e-10);
        // Hand value: u = 1000*0.31 + 0.5*(-0.22) + 639.5 = 949.39,
        // v = 980*(-0.22) + 511.5 = 295.9.
        assert!((q.x - 949.39).abs() < 1e-9 && (q.y - 295.9).abs() < 1e-9);
        let back = i.pixel_to_normalized(&q);
        assert!((back - xd).amax() < 1e-14);
    }
}
