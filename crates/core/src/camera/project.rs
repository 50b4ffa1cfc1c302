//! Forward projection of camera-frame points to pixels, un-projection of
//! pixels to rays, and the analytic Jacobians of the projection with respect
//! to the point and to the intrinsics (`fx, fy, cx, cy, skew`, then the lens parameters).
//!
//! Reference: OpenCV calib3d docs "Camera Calibration and 3D Reconstruction"
//! (`projectPoints` model and its Jacobian layout); Brown 1966; Zhang 2000.

use super::{CameraError, CameraModel, Fisheye, Lens, LensKind, MAX_LENS_PARAMS};
use nalgebra::{Matrix2, Matrix2x3, Point2, Point3, SMatrix, Vector2, Vector3};

/// The first five columns of [`CameraModel::dq_dintrinsics`]; the lens parameters follow.
pub const BASE_INTRINSIC_NAMES: [&str; 5] = ["fx", "fy", "cx", "cy", "skew"];

/// Columns of [`CameraModel::dq_dintrinsics`]: 5 + the most lens parameters of any model.
pub const N_INTRINSICS: usize = 5 + MAX_LENS_PARAMS;

/// Names of the intrinsics of a camera with this lens model, in [`CameraModel::dq_dintrinsics`]
/// column order (`fx, fy, cx, cy, skew`, then [`LensKind::param_names`]).
pub fn intrinsic_names(kind: LensKind) -> Vec<&'static str> {
    BASE_INTRINSIC_NAMES.iter().chain(kind.param_names()).copied().collect()
}

/// Result of [`CameraModel::project`].
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Projection {
    /// Pixel position. For `z < 0` this is the projection of the mirrored
    /// point `(x, y, |z|)` (finite but physically meaningless); for `z == 0`
    /// or non-finite input it is `(NaN, NaN)`. A fisheye maps every direction by its angle
    /// from the axis instead (z <= 0 too; NaN only on the axis behind the camera).
    pub pixel_px: Point2<f64>,
    /// Whether the point is on the side of the camera its lens sees: strictly in front
    /// (`z > 0`), or, for a fisheye, within its reach ([`crate::camera::Fisheye::theta_max`],
    /// which may pass 90 degrees).
    pub in_front: bool,
    /// Whether `pixel_px` lies in the image (`[-0.5, W-0.5] x [-0.5, H-0.5]`)
    /// and the point is not beyond the first radial fold of the distortion
    /// model (where pixels wrap back spuriously into the image).
    pub in_image: bool,
}

impl Projection {
    /// `in_front && in_image`.
    pub fn visible(&self) -> bool {
        self.in_front && self.in_image
    }
}

impl CameraModel {
    /// Whether every point of `points` (in frame x) projects visibly, at least `margin_px` inside
    /// the image border (0: the image rectangle of [`Projection::in_image`]).
    pub fn sees_all(&self, cam_from_x: &nalgebra::Isometry3<f64>, points: &[Point3<f64>], margin_px: f64) -> bool {
        let (w, h) = (f64::from(self.size.width), f64::from(self.size.height));
        points.iter().all(|p| {
            let q = self.project(&(cam_from_x * p));
            q.visible()
                && q.pixel_px.x >= margin_px - 0.5
                && q.pixel_px.x <= w - 0.5 - margin_px
                && q.pixel_px.y >= margin_px - 0.5
                && q.pixel_px.y <= h - 0.5 - margin_px
        })
    }

    /// Projects a camera-frame point, reporting whether it is in front of the
    /// camera and inside the image. Never panics; see [`Projection`] for what
    /// `pixel_px` holds for points on or behind the camera plane.
    pub fn project(&self, p_cam: &Point3<f64>) -> Projection {
        if let Lens::Fisheye(f) = &self.lens {
            return self.project_fisheye(f, p_cam);
        }
        let z = p_cam.z;
        let in_front = z > 0.0;
        if !(z != 0.0 && z.is_finite() && p_cam.x.is_finite() && p_cam.y.is_finite()) {
            return Projection { pixel_px: Point2::new(f64::NAN, f64::NAN), in_front: in_front && p_cam.x.is_finite() && p_cam.y.is_finite(), in_image: false };
        }
        let xu = Vector2::new(p_cam.x / z.abs(), p_cam.y / z.abs());
        let pixel_px = self.intrinsics.normalized_to_pixel(&self.lens.distort(&xu));
        let beyond_fold = match self.lens.max_radius() {
            Some(rf) => xu.norm() > rf,
            None => false,
        };
        Projection { pixel_px, in_front, in_image: !beyond_fold && self.size.contains_px(&pixel_px) }
    }

    /// [`Self::project`] through a fisheye: theta from atan2, so directions at and beyond 90
    /// degrees map as well, up to the model's reach.
    fn project_fisheye(&self, f: &Fisheye, p_cam: &Point3<f64>) -> Projection {
        if !(p_cam.coords.iter().all(|v| v.is_finite()) && p_cam.coords.norm() > 0.0) {
            return Projection { pixel_px: Point2::new(f64::NAN, f64::NAN), in_front: false, in_image: false };
        }
        let th = p_cam.coords.xy().norm().atan2(p_cam.z);
        let within = th <= f.theta_max();
        let pixel_px = self.intrinsics.normalized_to_pixel(&f.distort_ray(&p_cam.coords));
        Projection { pixel_px, in_front: p_cam.z > 0.0 || within, in_image: within && self.size.contains_px(&pixel_px) }
    }

    /// Projects without any check: `K * distort(x/z, y/z)` ([`super::Lens::distort_point`]).
    /// Division by `z` as is (z <= 0 gives meaningless or non-finite output); a fisheye takes
    /// the angle from the axis by atan2 ([`Fisheye::distort_ray`]), valid at z <= 0 too.
    pub fn project_unchecked(&self, p_cam: &Point3<f64>) -> Point2<f64> {
        self.intrinsics.normalized_to_pixel(&self.lens.distort_point(&p_cam.coords))
    }

    /// Back-projects a pixel to the ray `(xu, yu, 1)` in the camera frame
    /// (not normalised), via [`super::Lens::undistort`]. Rays at or beyond 90 degrees from the
    /// axis have no such form and are errors.
    ///
    /// # Errors
    /// [`CameraError::NonFinite`] for a non-finite pixel or degenerate
    /// intrinsics; [`CameraError::NotInvertible`] where the distortion cannot
    /// be inverted.
    pub fn unproject(&self, q_px: &Point2<f64>) -> Result<Vector3<f64>, CameraError> {
        if !(q_px.x.is_finite() && q_px.y.is_finite()) {
            return Err(CameraError::NonFinite { what: "pixel" });
        }
        let xd = self.intrinsics.pixel_to_normalized(q_px);
        if !(xd.x.is_finite() && xd.y.is_finite()) {
            return Err(CameraError::NonFinite { what: "normalised pixel (check fx, fy)" });
        }
        let xu = self.lens.undistort(&xd)?;
        Ok(Vector3::new(xu.x, xu.y, 1.0))
    }

    /// Back-projects a pixel to a ray direction in the camera frame at any angle the lens
    /// reaches: a fisheye's unit ray ([`Fisheye::undistort_ray`], beyond 90 degrees too), the
    /// other models' `(xu, yu, 1)` ([`Self::unproject`]). What ray casting needs.
    ///
    /// # Errors
    /// As [`Self::unproject`].
    pub fn unproject_ray(&self, q_px: &Point2<f64>) -> Result<Vector3<f64>, CameraError> {
        let Lens::Fisheye(f) = &self.lens else { return self.unproject(q_px) };
        if !(q_px.x.is_finite() && q_px.y.is_finite()) {
            return Err(CameraError::NonFinite { what: "pixel" });
        }
        let xd = self.intrinsics.pixel_to_normalized(q_px);
        if !(xd.x.is_finite() && xd.y.is_finite()) {
            return Err(CameraError::NonFinite { what: "normalised pixel (check fx, fy)" });
        }
        f.undistort_ray(&xd)
    }

    /// `d q / d xd`: the linear part of `K`.
    fn dq_dxd(&self) -> Matrix2<f64> {
        let k = &self.intrinsics;
        Matrix2::new(k.fx, k.skew, 0.0, k.fy)
    }

    /// Analytic Jacobian of [`Self::project_unchecked`] with respect to the
    /// camera-frame point (2x3). Non-finite where `z == 0`.
    pub fn dq_dp_cam(&self, p_cam: &Point3<f64>) -> Matrix2x3<f64> {
        if let (Lens::Fisheye(f), false) = (&self.lens, p_cam.z > 0.0) {
            return self.dq_dxd() * f.dxd_dp(&p_cam.coords);
        }
        let (x, y, z) = (p_cam.x, p_cam.y, p_cam.z);
        let iz = 1.0 / z;
        let xu = Vector2::new(x * iz, y * iz);
        let dxu_dp = Matrix2x3::new(iz, 0.0, -x * iz * iz, 0.0, iz, -y * iz * iz);
        self.dq_dxd() * self.lens.dxd_dxu(&xu) * dxu_dp
    }

    /// Analytic Jacobian of [`Self::project_unchecked`] with respect to the
    /// intrinsics, columns in [`intrinsic_names`] order: `fx, fy, cx, cy, skew`, then the lens
    /// parameters (zero columns past the model's count).
    pub fn dq_dintrinsics(&self, p_cam: &Point3<f64>) -> SMatrix<f64, 2, N_INTRINSICS> {
        self.dq_dintrinsics_n(p_cam, MAX_LENS_PARAMS)
    }

    /// [`Self::dq_dintrinsics`] with only the first `n_lens` lens columns computed (the others
    /// zero): what an estimate that fixes the trailing parameters needs.
    pub fn dq_dintrinsics_n(&self, p_cam: &Point3<f64>, n_lens: usize) -> SMatrix<f64, 2, N_INTRINSICS> {
        let xd = self.lens.distort_point(&p_cam.coords);
        let mut j = SMatrix::<f64, 2, N_INTRINSICS>::zeros();
        j[(0, 0)] = xd.x; // fx
        j[(1, 1)] = xd.y; // fy
        j[(0, 2)] = 1.0; // cx
        j[(1, 3)] = 1.0; // cy
        j[(0, 4)] = xd.y; // skew
        let dc = self.dq_dxd() * self.lens.dxd_dparams_point(&p_cam.coords, n_lens);
        j.fixed_view_mut::<2, MAX_LENS_PARAMS>(0, 5).copy_from(&dc);
        j
    }
}

#[cfg(test)]
mod tests;
