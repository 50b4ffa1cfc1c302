//! Projection uncertainty: how far, at a given pixel, the calibrated camera's projection of a
//! point may be from the true camera's, from the noise of the detections alone.
//!
//! mrcal's formulation: a pixel `q` is unprojected by the calibrated camera to a point `p` at
//! range `r` (or a direction, at infinity); `p` is carried into every board's frame by that
//! view's pose, and back into the camera by the mean over the views, `p' = mean_i (R_i p_i + t_i)`
//! (at infinity `mean_i R_i v_i`): the camera frame is only defined through the boards, so the
//! poses' uncertainty enters as much as the intrinsics'. The projection `q' = project(a, p')`
//! depends on the intrinsics `a` and every pose; its 2 x 2 covariance is `G Sigma G^T` with
//! `Sigma = sigma^2 (J^T J)^-1` the covariance of every parameter of the fit, computed through the
//! Schur complement the refinement already formed: with `M = G_a^T - sum_i W_i V_i^-1 G_i^T`,
//! `Cov(q') = M^T Cov_a M + sigma^2 sum_i G_i V_i^-1 G_i^T`. The scalar reported per pixel is the
//! standard deviation in the worst direction (the square root of the larger eigenvalue), as
//! mrcal's `worstdirection-stdev`.
//!
//! Reference: D. Kogan, mrcal, "Projection uncertainty"
//! (<https://mrcal.secretsauce.net/uncertainty.html>); Triggs et al., "Bundle adjustment - a
//! modern synthesis", 2000, section 6.1 (the Schur complement).

use nalgebra::{DMatrix, Matrix2, Matrix3, Point2, Point3, SMatrix};

use super::refine::{drotated_drvec, View};
use super::CalibResult;
use synthcam_core::camera::{ImageSize, N_INTRINSICS};
use synthcam_core::math::so3::rotation_from_rvec;

/// A grid of `cols x rows` equal cells over the image; cell `k` is column `k % cols`, row
/// `k / cols` (row-major).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct ImageGrid {
    /// The image.
    pub size: ImageSize,
    /// Cells across.
    pub cols: u32,
    /// Cells down.
    pub rows: u32,
}

impl ImageGrid {
    /// The number of cells.
    pub fn len(&self) -> usize {
        (self.cols * self.rows) as usize
    }

    /// Whether the grid has no cell.
    pub fn is_empty(&self) -> bool {
        self.len() == 0
    }

    fn cell_px(&self) -> (f64, f64) {
        (f64::from(self.size.width) / f64::from(self.cols.max(1)), f64::from(self.size.height) / f64::from(self.rows.max(1)))
    }

    /// The centre of cell `k`, px (OpenCV's convention: pixel centres at integers).
    pub fn centre(&self, k: usize) -> Point2<f64> {
        let (cw, ch) = self.cell_px();
        let cols = self.cols.max(1) as usize;
        Point2::new(((k % cols) as f64 + 0.5) * cw - 0.5, ((k / cols) as f64 + 0.5) * ch - 0.5)
    }

    /// Per cell, whether any observed point of `views` falls in it.
    pub fn covered(&self, views: &[View]) -> Vec<bool> {
        let (cw, ch) = self.cell_px();
        let mut hit = vec![false; self.len()];
        for (_, q) in views.iter().flatten() {
            let (cx, cy) = ((q.x + 0.5) / cw, (q.y + 0.5) / ch);
            if (0.0..f64::from(self.cols)).contains(&cx) && (0.0..f64::from(self.rows)).contains(&cy) {
                hit[cy as usize * self.cols as usize + cx as usize] = true;
            }
        }
        hit
    }
}

/// The projection uncertainty over an image grid ([`CalibResult::uncertainty_map`]).
#[derive(Debug, Clone, PartialEq)]
pub struct UncertaintyMap {
    /// The cells.
    pub grid: ImageGrid,
    /// The range the pixels were unprojected to, board units; `None`: at infinity.
    pub range: Option<f64>,
    /// Per cell (row-major), the worst-direction standard deviation of the projection at its
    /// centre, px; NaN where the lens cannot map the pixel.
    pub sigma_px: Vec<f64>,
    /// Per cell, whether an observed point falls in it (the area the views covered).
    pub covered: Vec<bool>,
    /// The largest `sigma_px` over the covered cells.
    pub worst_inside_px: f64,
    /// The largest `sigma_px` over the other cells (NaN if every cell is covered).
    pub worst_outside_px: f64,
}

impl UncertaintyMap {
    /// The one-line answer: the worst sigma inside and outside the covered area.
    pub fn summary(&self) -> String {
        let at = self.range.map_or_else(|| "at infinity".to_string(), |r| format!("at range {r}"));
        format!(
            "projection uncertainty ({at}): worst {:.4} px inside the area the views cover ({} of {} cells), {:.4} px outside it",
            self.worst_inside_px,
            self.covered.iter().filter(|c| **c).count(),
            self.grid.len(),
            self.worst_outside_px
        )
    }
}

/// Largest value of an iterator of finite numbers; NaN when there is none.
fn max_finite(values: impl Iterator<Item = f64>) -> f64 {
    values.filter(|v| v.is_finite()).fold(f64::NAN, f64::max)
}

impl CalibResult {
    /// Covariance (px^2) of the projection of the point seen at `q_px`, at `range` (board units)
    /// or at infinity (`None`), from the noise of the fit (module documentation). `None` where
    /// the lens cannot unproject the pixel.
    pub fn projection_covariance(&self, q_px: &Point2<f64>, range: Option<f64>) -> Option<Matrix2<f64>> {
        let pr = &self.precision;
        if pr.w.len() != self.views.len() || range.is_some_and(|r| !(r.is_finite() && r > 0.0)) {
            return None;
        }
        let v = self.camera.unproject_ray(q_px).ok()?.normalize();
        let p_cam = range.map_or(v, |r| v * r);
        let dq_dp = self.camera.dq_dp_cam(&Point3::from(p_cam));
        let n = self.views.len() as f64;
        let ga_full = self.camera.dq_dintrinsics(&Point3::from(p_cam));
        let k = pr.free.len();
        // The warp moves the board's points, not the projection of a point in a board's frame.
        let mut m = DMatrix::from_fn(k, 2, |i, c| if pr.free[i] < N_INTRINSICS { ga_full[(c, pr.free[i])] } else { 0.0 });
        let mut poses_part = Matrix2::zeros();
        for ((view, w), vinv) in self.views.iter().zip(&pr.w).zip(&pr.vinv) {
            let rot_t = rotation_from_rvec(&view.rvec).inverse();
            let (p_frame, dp_dt) = match range {
                Some(_) => (rot_t * (p_cam - view.tvec), Matrix3::identity() / n),
                None => (rot_t * p_cam, Matrix3::zeros()),
            };
            let mut dp_dpose = SMatrix::<f64, 3, 6>::zeros();
            dp_dpose.fixed_view_mut::<3, 3>(0, 0).copy_from(&(drotated_drvec(&view.rvec, &p_frame) / n));
            dp_dpose.fixed_view_mut::<3, 3>(0, 3).copy_from(&dp_dt);
            let gi = dq_dp * dp_dpose;
            let vg = vinv * gi.transpose();
            m -= w * DMatrix::from_column_slice(6, 2, vg.as_slice());
            poses_part += gi * vg;
        }
        let cov_a = DMatrix::from_column_slice(2, 2, (m.transpose() * &pr.covariance * &m).as_slice());
        let cov = Matrix2::from_column_slice(cov_a.as_slice()) + poses_part * pr.sigma2;
        cov.iter().all(|c| c.is_finite()).then_some(cov)
    }

    /// The worst-direction standard deviation of the projection at `q_px`, px
    /// ([`Self::projection_covariance`]'s larger eigenvalue, square-rooted).
    pub fn projection_sigma_px(&self, q_px: &Point2<f64>, range: Option<f64>) -> Option<f64> {
        let c = self.projection_covariance(q_px, range)?;
        Some(c.symmetric_eigenvalues().max().max(0.0).sqrt())
    }

    /// [`Self::projection_sigma_px`] at every cell centre of a `cols x rows` grid, with the cells
    /// the observed points of `views` cover and the worst value inside and outside them.
    pub fn uncertainty_map(&self, views: &[View], cols: u32, rows: u32, range: Option<f64>) -> UncertaintyMap {
        let grid = ImageGrid { size: self.camera.size, cols, rows };
        let covered = grid.covered(views);
        let sigma_px: Vec<f64> = (0..grid.len()).map(|k| self.projection_sigma_px(&grid.centre(k), range).unwrap_or(f64::NAN)).collect();
        let worst_inside_px = max_finite(sigma_px.iter().zip(&covered).filter(|(_, c)| **c).map(|(s, _)| *s));
        let worst_outside_px = max_finite(sigma_px.iter().zip(&covered).filter(|(_, c)| !**c).map(|(s, _)| *s));
        UncertaintyMap { grid, range, sigma_px, covered, worst_inside_px, worst_outside_px }
    }
}
