//! How differently two calibrated cameras project: mrcal's `projection_diff` at infinity. Each
//! pixel is unprojected by the first camera and projected by the second after the rotation that
//! best aligns the two camera frames (two calibrations of one lens differ by such a rotation: the
//! frame is only defined through the boards). The rotation is the closed-form least-squares
//! alignment of the two cameras' rays at the pixels (Kabsch), not mrcal's iterative fit of the
//! pixel difference: the two agree to first order when the difference is small.
//!
//! References: D. Kogan, mrcal, "Differencing" (<https://mrcal.secretsauce.net/differencing.html>);
//! W. Kabsch, "A solution for the best rotation to relate two sets of vectors", Acta Cryst. A32,
//! 1976.

use nalgebra::{Matrix3, Point2, Point3, Rotation3};

use synthcam_core::camera::CameraModel;
use synthcam_core::math::so3::project_to_so3;

/// Result of [`projection_diff`].
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct ProjectionDiff {
    /// `b_from_a`: the rotation applied to the first camera's rays.
    pub rotation: Rotation3<f64>,
    /// RMS difference over the pixels both cameras map, px.
    pub rms_px: f64,
    /// Largest difference, px.
    pub max_px: f64,
    /// Pixels both cameras map (the others are left out).
    pub compared: usize,
}

/// `|project_b(rotation unproject_a(q)) - q|`, px; `None` where either camera cannot map the pixel.
pub fn pixel_diff(a: &CameraModel, b: &CameraModel, rotation: &Rotation3<f64>, q: &Point2<f64>) -> Option<f64> {
    let ray = a.unproject_ray(q).ok()?;
    let p = b.project(&Point3::from(rotation * ray));
    p.visible().then(|| (p.pixel_px - q).norm()).filter(|d| d.is_finite())
}

/// The projection difference of `a` and `b` at `pixels` after the best-aligning rotation.
pub fn projection_diff(a: &CameraModel, b: &CameraModel, pixels: &[Point2<f64>]) -> ProjectionDiff {
    let mut m = Matrix3::zeros();
    for q in pixels {
        if let (Ok(ra), Ok(rb)) = (a.unproject_ray(q), b.unproject_ray(q)) {
            m += rb.normalize() * ra.normalize().transpose();
        }
    }
    let rotation = project_to_so3(&m);
    let diffs: Vec<f64> = pixels.iter().filter_map(|q| pixel_diff(a, b, &rotation, q)).collect();
    let n = diffs.len();
    ProjectionDiff {
        rotation,
        rms_px: (diffs.iter().map(|d| d * d).sum::<f64>() / n.max(1) as f64).sqrt(),
        max_px: diffs.iter().copied().fold(0.0, f64::max),
        compared: n,
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use synthcam_core::camera::ImageSize;
    use synthcam_core::camera::{Distortion, Intrinsics, Lens};

    fn camera(fx: f64) -> CameraModel {
        CameraModel {
            size: ImageSize { width: 640, height: 480 },
            intrinsics: Intrinsics { fx, fy: fx, cx: 319.5, cy: 239.5, skew: 0.0 },
            lens: Lens::OpenCv(Distortion::from_array([-0.1, 0.01, 0.0, 0.0, 0.0])),
        }
    }

    #[test]
    fn a_turned_camera_differs_by_its_rotation_only() {
        // The same lens with its principal point moved by (4, -3) px is, at the centre, the same
        // camera turned by about (3/500, 4/500) rad: the fitted rotation takes all but what the
        // distortion bends differently (0.26 px here, from 5 px unaligned).
        let a = camera(500.0);
        let mut b = a;
        b.intrinsics.cx += 4.0;
        b.intrinsics.cy -= 3.0;
        let pixels: Vec<Point2<f64>> = (0..9).flat_map(|i| (0..7).map(move |j| Point2::new(200.0 + 30.0 * i as f64, 150.0 + 30.0 * j as f64))).collect();
        let d = projection_diff(&a, &b, &pixels);
        assert_eq!(d.compared, pixels.len());
        let unaligned = pixels.iter().filter_map(|q| pixel_diff(&a, &b, &Rotation3::identity(), q)).fold(0.0, f64::max);
        assert!((unaligned - 5.0).abs() < 1e-9, "{unaligned}");
        assert!(d.max_px < 0.3, "{}", d.max_px);
        let angle = d.rotation.angle();
        assert!((angle - 5.0 / 500.0).abs() < 1e-3, "{angle}");
        // A different focal length is (nearly) no rotation: the difference stays.
        let e = projection_diff(&a, &camera(505.0), &pixels);
        assert!(e.max_px > 1.0 && e.rotation.angle() < 1e-4, "{e:?}");
    }
}
