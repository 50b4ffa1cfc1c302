//! Cameras: image size, intrinsics `K` and a lens model ([`Lens`]: OpenCV's 14-coefficient
//! model, OpenCV's fisheye / Kannala-Brandt, Double Sphere), forward projection, un-projection
//! and analytic Jacobians.
//!
//! Reference: Brown 1966 "Decentering distortion of lenses"; Conrady 1919;
//! OpenCV calib3d docs "Camera Calibration and 3D Reconstruction"; Bouguet,
//! "Camera Calibration Toolbox for Matlab" (its parameter names, mapped below).
//!
//! # Conventions
//! * Camera frame: x right, y down, z forward (optical axis).
//! * Pixels (OpenCV): the centre of the top-left pixel is (0, 0), so an image
//!   of `W x H` pixels spans `[-0.5, W - 0.5] x [-0.5, H - 0.5]`.
//! * Distortion in OpenCV order `(k1, k2, p1, p2, k3)`. With normalised
//!   undistorted coordinates `x = X/Z, y = Y/Z` and `r2 = x^2 + y^2`:
//!   `g = 1 + k1 r2 + k2 r2^2 + k3 r2^3`,
//!   `xd = g x + 2 p1 x y + p2 (r2 + 2 x^2)`,
//!   `yd = g y + p1 (r2 + 2 y^2) + 2 p2 x y`.
//! * Pixels: `u = fx xd + skew yd + cx`, `v = fy yd + cy`, i.e.
//!   `K = [[fx, skew, cx], [0, fy, cy], [0, 0, 1]]` with `skew = K[0][1]` in
//!   pixels (Zhang / Hartley–Zisserman; OpenCV itself has no skew term).
//!
//! # Mapping to Bouguet's (Camera Calibration Toolbox for Matlab) parameters
//! | Bouguet                   | here                      |
//! |---------------------------|---------------------------|
//! | `k1, k2, k5` (r^2, r^4, r^6 radial) | `k1, k2, k3`    |
//! | `k3, k4` (tangential)     | `p1, p2`                  |
//! | `alpha` (dimensionless skew, `alpha_c`) | `skew = alpha * fx` (so `K[0][1] = alpha fx`) |
//! | `u0, v0`                  | `cx, cy`                  |
//!
//! Bouguet writes `u = fx (xd + alpha yd) + u0`, which equals our
//! `u = fx xd + skew yd + cx` with `skew = alpha fx`.

pub mod distortion;
pub mod double_sphere;
pub mod fisheye;
pub mod formats;
pub mod intrinsics;
pub mod lens;
pub mod optics;
pub mod project;
pub mod sensor;

pub use distortion::Distortion;
pub use double_sphere::DoubleSphere;
pub use fisheye::{Fisheye, FISHEYE_MAX_ANGLE_RAD};
pub use intrinsics::Intrinsics;
pub use lens::{Lens, LensKind, MAX_LENS_PARAMS};
pub use project::{intrinsic_names, Projection, BASE_INTRINSIC_NAMES, N_INTRINSICS};

use nalgebra::Point2;

/// Rays of the `(xu, yu, 1)` form ([`CameraModel::unproject`]) and the Double Sphere model's
/// visible region end at this angle from the optical axis (89.5 degrees); the fisheye model
/// reaches beyond it, to [`FISHEYE_MAX_ANGLE_RAD`] ([`CameraModel::unproject_ray`]).
pub const MAX_RAY_ANGLE_RAD: f64 = 89.5 * std::f64::consts::PI / 180.0;

/// Errors of the camera model.
#[derive(Debug, thiserror::Error, Clone, PartialEq)]
#[non_exhaustive]
pub enum CameraError {
    /// A model parameter is out of range (non-finite, non-positive focal
    /// length, empty image, ...).
    #[error("invalid camera parameter `{field}`: {reason}")]
    InvalidParameter {
        /// Name of the offending field, e.g. `"intrinsics.fx"`.
        field: &'static str,
        /// Human-readable explanation including the offending value.
        reason: String,
    },
    /// The distortion model cannot be inverted at the requested point.
    #[error("distortion model is not invertible here: {reason}")]
    NotInvertible {
        /// Why the inversion failed (no convergence, fold, ...).
        reason: String,
    },
    /// The point lies on or behind the camera plane (z <= 0).
    #[error("point is on or behind the camera plane (z <= 0)")]
    BehindCamera,
    /// An input value was NaN or infinite.
    #[error("non-finite input: {what}")]
    NonFinite {
        /// Which input was non-finite.
        what: &'static str,
    },
}

/// Image size in pixels.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct ImageSize {
    /// Width in pixels (number of columns).
    pub width: u32,
    /// Height in pixels (number of rows).
    pub height: u32,
}

impl ImageSize {
    /// Whether the pixel position `q` lies inside the image, using OpenCV's
    /// convention: the image covers `[-0.5, W - 0.5] x [-0.5, H - 0.5]`
    /// (borders included). NaN coordinates are outside.
    pub fn contains_px(&self, q: &Point2<f64>) -> bool {
        let w = f64::from(self.width);
        let h = f64::from(self.height);
        q.x >= -0.5 && q.x <= w - 0.5 && q.y >= -0.5 && q.y <= h - 0.5
    }
}

/// A complete camera: image size, intrinsics and lens model.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct CameraModel {
    /// Image size in pixels.
    pub size: ImageSize,
    /// Pinhole intrinsics (focal lengths, principal point, skew).
    pub intrinsics: Intrinsics,
    /// The lens: normalised ray `(xu, 1)` to distorted normalised point.
    pub lens: Lens,
}

fn check_finite(field: &'static str, v: f64) -> Result<(), CameraError> {
    if v.is_finite() {
        Ok(())
    } else {
        Err(CameraError::InvalidParameter { field, reason: format!("must be finite, got {v}") })
    }
}

impl CameraModel {
    /// Checks that all parameters are finite, `fx, fy > 0` and the image is
    /// non-empty. The error names the offending field.
    pub fn validate(&self) -> Result<(), CameraError> {
        if self.size.width == 0 {
            return Err(CameraError::InvalidParameter { field: "size.width", reason: "must be > 0".into() });
        }
        if self.size.height == 0 {
            return Err(CameraError::InvalidParameter { field: "size.height", reason: "must be > 0".into() });
        }
        let k = &self.intrinsics;
        check_finite("intrinsics.fx", k.fx)?;
        check_finite("intrinsics.fy", k.fy)?;
        check_finite("intrinsics.cx", k.cx)?;
        check_finite("intrinsics.cy", k.cy)?;
        check_finite("intrinsics.skew", k.skew)?;
        self.lens.validate()?;
        if k.fx <= 0.0 {
            return Err(CameraError::InvalidParameter { field: "intrinsics.fx", reason: format!("must be > 0, got {}", k.fx) });
        }
        if k.fy <= 0.0 {
            return Err(CameraError::InvalidParameter { field: "intrinsics.fy", reason: format!("must be > 0, got {}", k.fy) });
        }
        self.check_lens_reach()
    }

    /// A lens that is one-to-one only within a pixel of the principal point cannot image
    /// anything: an error naming the lens field.
    fn check_lens_reach(&self) -> Result<(), CameraError> {
        let Some(r) = self.lens.max_radius() else { return Ok(()) };
        let reach_px = self.lens.distort(&nalgebra::Vector2::new(r, 0.0)).norm() * self.intrinsics.fx.min(self.intrinsics.fy);
        if !(reach_px >= 1.0) {
            let field = if self.lens.kind() == LensKind::DoubleSphere { "xi" } else { "dist" };
            return Err(CameraError::InvalidParameter {
                field,
                reason: format!("the lens is one-to-one only within {reach_px:.3e} px of the principal point"),
            });
        }
        Ok(())
    }

    /// A preset: an SXGA machine-vision camera, 1280 x 1024 pixels, `fx = fy = 1500`, the
    /// principal point at (640, 512), no distortion, no skew (the default camera of
    /// `synthcam_scene::Scene::builder`).
    pub fn sxga_1500px() -> Self {
        Self {
            size: ImageSize { width: 1280, height: 1024 },
            intrinsics: Intrinsics { fx: 1500.0, fy: 1500.0, cx: 640.0, cy: 512.0, skew: 0.0 },
            lens: Lens::default(),
        }
    }

    /// A pinhole camera of `width x height` pixels, focal length `f_px`, the principal point at
    /// the image centre ((W - 1) / 2, (H - 1) / 2 in OpenCV's convention), no distortion.
    ///
    /// ```
    /// let cam = synthcam_core::camera::CameraModel::pinhole(1920, 1200, 1100.0).with_distortion([-0.2, 0.0, 0.0, 0.0, 0.0]);
    /// assert_eq!(cam.intrinsics.cx, 959.5);
    /// assert!(cam.validate().is_ok());
    /// ```
    pub fn pinhole(width: u32, height: u32, f_px: f64) -> Self {
        Self {
            size: ImageSize { width, height },
            intrinsics: Intrinsics { fx: f_px, fy: f_px, cx: (f64::from(width) - 1.0) / 2.0, cy: (f64::from(height) - 1.0) / 2.0, skew: 0.0 },
            lens: Lens::default(),
        }
    }

    /// The same camera with Brown-Conrady coefficients in OpenCV's order (k1, k2, p1, p2, k3).
    pub fn with_distortion(self, dist: [f64; 5]) -> Self {
        Self { lens: Lens::OpenCv(Distortion::from_array(dist)), ..self }
    }

    /// The same camera with another lens.
    ///
    /// ```
    /// use synthcam_core::camera::{CameraModel, Fisheye, Lens};
    /// let cam = CameraModel::pinhole(1280, 1024, 400.0).with_lens(Lens::Fisheye(Fisheye { k: [0.05, -0.01, 0.0, 0.0] }));
    /// let q = cam.project(&nalgebra::Point3::new(1.0, 0.0, 1.0)); // 45 degrees off-axis
    /// assert!(q.visible() && (q.pixel_px.x - 639.5 - 400.0 * 0.806633).abs() < 1e-3);
    /// ```
    pub fn with_lens(self, lens: Lens) -> Self {
        Self { lens, ..self }
    }

    /// The OpenCV distortion of this camera (zero for other lens models).
    pub fn distortion(&self) -> Distortion {
        self.lens.opencv().copied().unwrap_or_default()
    }

    /// The same view on a sensor with `factor` times the pixels along each axis (the image of
    /// every ray scaled about the image's corner): focal lengths and skew times `factor`, the
    /// principal point `factor (c + 0.5) - 0.5` (OpenCV's pixel centres), the lens unchanged.
    ///
    /// # Errors
    /// [`CameraError::NonFinite`] for a factor that is not finite and positive, or sizes that
    /// would not be whole pixels or exceed `u32`.
    pub fn scaled(&self, factor: f64) -> Result<Self, CameraError> {
        let side = |n: u32| {
            let v = f64::from(n) * factor;
            (factor.is_finite() && factor > 0.0 && v.fract() == 0.0 && v >= 1.0 && v <= f64::from(u32::MAX)).then_some(v as u32)
        };
        let (Some(width), Some(height)) = (side(self.size.width), side(self.size.height)) else {
            return Err(CameraError::NonFinite { what: "scale factor (positive, giving whole pixels)" });
        };
        let k = &self.intrinsics;
        let intrinsics =
            Intrinsics { fx: k.fx * factor, fy: k.fy * factor, cx: factor * (k.cx + 0.5) - 0.5, cy: factor * (k.cy + 0.5) - 0.5, skew: k.skew * factor };
        Ok(Self { size: ImageSize { width, height }, intrinsics, lens: self.lens })
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn contains_px_uses_half_pixel_border() {
        let s = ImageSize { width: 4, height: 3 };
        assert!(s.contains_px(&Point2::new(-0.5, -0.5)));
        assert!(s.contains_px(&Point2::new(3.5, 2.5)));
        assert!(!s.contains_px(&Point2::new(-0.5001, 1.0)));
        assert!(!s.contains_px(&Point2::new(3.5001, 1.0)));
        assert!(!s.contains_px(&Point2::new(1.0, 2.5001)));
        assert!(!s.contains_px(&Point2::new(f64::NAN, 1.0)));
    }

    /// A scaled camera puts every ray at `factor (q + 0.5) - 0.5` of the original pixel `q`.
    #[test]
    fn scaling_maps_pixel_corners_onto_pixel_corners() {
        use nalgebra::Point3;
        let cam = CameraModel::sxga_1500px().with_distortion([-0.25, 0.1, 0.001, -0.002, 0.0]);
        let big = cam.scaled(3.0).unwrap();
        assert_eq!((big.size.width, big.size.height), (3840, 3072));
        for p in [Point3::new(0.1, -0.05, 0.6), Point3::new(-0.3, 0.2, 0.9), Point3::new(0.0, 0.0, 1.0)] {
            let (q, r) = (cam.project(&p).pixel_px, big.project(&p).pixel_px);
            assert!((r.x - (3.0 * (q.x + 0.5) - 0.5)).abs() < 1e-9 && (r.y - (3.0 * (q.y + 0.5) - 0.5)).abs() < 1e-9, "{q} -> {r}");
        }
        // the image's corners stay its corners
        assert_eq!(big.intrinsics.cx, 3.0 * (cam.intrinsics.cx + 0.5) - 0.5);
        assert!(cam.scaled(0.0).is_err() && cam.scaled(f64::NAN).is_err() && cam.scaled(1.0001).is_err());
        assert_eq!(cam.scaled(0.5).unwrap().size.width, 640);
    }

    #[test]
    fn sxga_1500px_is_valid() {
        let c = CameraModel::sxga_1500px();
        assert_eq!(c.validate(), Ok(()));
        assert_eq!(c.size.width, 1280);
        assert_eq!(c.size.height, 1024);
        assert!(c.lens.is_identity());
    }

    #[test]
    fn validate_names_the_field() {
        let mut c = CameraModel::sxga_1500px();
        c.intrinsics.fy = -1.0;
        assert!(matches!(c.validate(), Err(CameraError::InvalidParameter { field: "intrinsics.fy", .. })));
        let mut c = CameraModel::sxga_1500px();
        c.lens = Lens::OpenCv(Distortion { p2: f64::NAN, ..Distortion::default() });
        assert!(matches!(c.validate(), Err(CameraError::InvalidParameter { field: "p2", .. })));
        c.lens = Lens::DoubleSphere(DoubleSphere { xi: 0.5, alpha: 1.5 });
        assert!(matches!(c.validate(), Err(CameraError::InvalidParameter { field: "alpha", .. })));
        let mut c = CameraModel::sxga_1500px();
        c.size.height = 0;
        assert!(matches!(c.validate(), Err(CameraError::InvalidParameter { field: "size.height", .. })));
        let msg = CameraError::InvalidParameter { field: "intrinsics.fx", reason: "must be > 0, got 0".into() }.to_string();
        assert!(msg.contains("intrinsics.fx") && msg.contains("must be > 0"));
    }
}
