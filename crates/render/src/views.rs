//! The shader's views (`shaders/bindings.wgsl`, binding 7): per view of [`synthcam_scene::views`], the
//! plane homography from the pixel's pinhole ray to the target plane.
//!
//! For a view with aperture point `a` and focus distance `F`, the ray of pinhole direction `d`
//! leaves `a` along `M d`, `M = F I - a e_z^T`; the target point `X = R (u, v, 0) + t` on it
//! satisfies `[r1 r2 t - a] (u, v, 1)^T ~ M d`, so `(u, v, 1) ~ [r1 r2 t - a]^-1 M d`. A pinhole
//! view (no aperture) is `[r1 r2 t]^-1`.

use nalgebra::Matrix3;

use super::RenderError;
use synthcam_scene::views::{ExposureView, ViewSet};

/// `H` of one view (rows scaled so the largest entry is 1, sign kept: W > 0 in front).
///
/// # Errors
/// [`RenderError::Degenerate`] when the target plane contains the view's centre.
pub fn homography(view: &ExposureView) -> Result<Matrix3<f64>, RenderError> {
    homography_scaled(view).map(|(h, _)| h)
}

/// [`homography`] and the factor its unscaled form was divided by (a warped board's tangent
/// planes need it: `shaders/planar.wgsl` `warp_view`).
///
/// # Errors
/// As [`homography`].
pub fn homography_scaled(view: &ExposureView) -> Result<(Matrix3<f64>, f64), RenderError> {
    let r = view.cam_from_target.rotation.to_rotation_matrix();
    let t = view.cam_from_target.translation.vector;
    let m = r.matrix();
    let n_from_t = Matrix3::from_columns(&[m.column(0).into_owned(), m.column(1).into_owned(), t - view.aperture()]);
    let t_from_n = n_from_t.try_inverse().ok_or_else(|| RenderError::Degenerate("the target plane passes through the camera centre".into()))?;
    let h = view.direction_map().map_or(t_from_n, |m| t_from_n * m);
    let scale = h.abs().max();
    if !(scale > 0.0) || !scale.is_finite() {
        return Err(RenderError::Degenerate("singular plane homography".into()));
    }
    Ok((h / scale, scale))
}

/// The views' homographies as the shader reads them: three rows (`xyz`, 0) per view.
///
/// # Errors
/// As [`homography`].
pub fn gpu_views(set: &ViewSet) -> Result<Vec<[f32; 4]>, RenderError> {
    let mut out = Vec::with_capacity(set.views.len() * 3);
    for v in &set.views {
        let h = homography(v)?;
        for row in 0..3 {
            out.push([h[(row, 0)] as f32, h[(row, 1)] as f32, h[(row, 2)] as f32, 0.0]);
        }
    }
    Ok(out)
}
