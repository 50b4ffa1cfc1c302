//! k-fold cross-validation of a calibration, by views: is the lens model right for the data,
//! and are its parameters determined by it?
//!
//! The views are dealt into `k` folds (view `i` into fold `i mod k`: views taken in sequence
//! spread over the folds). For each fold the camera is calibrated on the other folds' views; the
//! held-out views (less the points the full calibration dropped as outliers) then get their
//! poses alone fitted under that camera (homography from the unprojected rays, then
//! Levenberg-Marquardt over the poses), and their reprojection RMS is the
//! held-out error. A model too simple for the lens leaves a held-out RMS well above the fit's
//! (the structure it cannot fit does not average out), one with parameters the data do not pin
//! down leaves fold cameras that disagree: their spread per intrinsic, and the largest difference
//! between a fold camera's and the full calibration's projection over the image area the views
//! cover (unproject by the full camera, project by the fold's; no implied rotation is fitted, so
//! this is an upper bound of mrcal's projection difference).
//!
//! References: T. Hastie, R. Tibshirani, J. Friedman, *The Elements of Statistical Learning*,
//! 2nd ed., section 7.10 (k-fold cross-validation); mrcal's cross-validation by the projection
//! difference of models fitted to disjoint data (<https://mrcal.secretsauce.net/tour-cross-validation.html>).

use nalgebra::{Point2, Rotation3};

use super::compare::pixel_diff;

use super::refine::{vector_of, View};
use super::uncertainty::ImageGrid;
use super::{calibrate, view_results, CalibError, CalibParams, CalibResult, IntrinsicStd};
use synthcam_core::camera::{CameraModel, ImageSize, N_INTRINSICS};

/// One fold of [`cross_validate`].
#[derive(Debug, Clone, PartialEq)]
pub struct Fold {
    /// Indices of the views held out.
    pub held_out: Vec<usize>,
    /// The camera calibrated on the other views.
    pub camera: CameraModel,
    /// Its reprojection RMS on the views it was fitted to, px.
    pub fit_rms_px: f64,
    /// Reprojection RMS on the held-out views (their poses fitted under `camera`), px.
    pub held_out_rms_px: f64,
    /// Largest difference between this camera's projection and the full calibration's over the
    /// image cells the views cover, px.
    pub projection_diff_max_px: f64,
}

/// Result of [`cross_validate`].
#[derive(Debug, Clone, PartialEq)]
pub struct CrossValidation {
    /// Per fold.
    pub folds: Vec<Fold>,
    /// Reprojection RMS over every held-out point, px: compare with the full fit's RMS.
    pub held_out_rms_px: f64,
    /// Sample standard deviation of each intrinsic over the fold cameras (NaN for fixed ones), in
    /// [`synthcam_core::camera::intrinsic_names`] order.
    pub intrinsics_spread: IntrinsicStd,
    /// RMS over the folds and covered cells of the projection difference, px.
    pub projection_diff_rms_px: f64,
    /// Largest projection difference of any fold, px.
    pub projection_diff_max_px: f64,
}

/// Image cells per axis over which projection differences are taken (those holding a point).
const CELLS: u32 = 24;

/// Cross-validate `full` (the calibration of all `views` with `params`) over `folds` folds.
///
/// # Errors
/// [`CalibError::BadOption`] for fewer than 2 folds or folds that leave fewer than 3 views to
/// fit; any error of [`calibrate`] on a fold; [`CalibError::Degenerate`] where a held-out view
/// has no homography or the poses' normal equations are singular.
pub fn cross_validate(views: &[View], size: ImageSize, params: &CalibParams, full: &CalibResult, folds: usize) -> Result<CrossValidation, CalibError> {
    if folds < 2 || views.len() < folds || views.len() - views.len().div_ceil(folds) < 3 {
        return Err(CalibError::BadOption { reason: format!("{folds} folds of {} views: need at least 2 folds and 3 views left to fit in each", views.len()) });
    }
    let cells = covered_cells(views, size);
    let mut out = Vec::with_capacity(folds);
    let (mut held_ss, mut held_n, mut diff_ss, mut diff_n) = (0.0, 0usize, 0.0, 0usize);
    for f in 0..folds {
        let (held_out, fit): (Vec<usize>, Vec<usize>) = (0..views.len()).partition(|i| i % folds == f);
        let pick = |ids: &[usize]| ids.iter().map(|&i| views[i].clone()).collect::<Vec<View>>();
        let r = calibrate(&pick(&fit), size, params)?;
        // The held-out views without the points the full calibration dropped as outliers.
        let held: Vec<View> = held_out.iter().map(|&i| super::outliers::without(&views[i], &full.views[i].outliers)).collect();
        let poses = super::global::poses_under(&r.camera, r.board_warp, &held, size, params.max_iterations)?;
        let (_, rms) = view_results(&r.camera, &r.board_warp, &held, &poses, &[]);
        let n: usize = held.iter().map(Vec::len).sum();
        held_ss += rms * rms * n as f64;
        held_n += n;
        let diffs: Vec<f64> = cells.iter().filter_map(|q| pixel_diff(&full.camera, &r.camera, &Rotation3::identity(), q)).collect();
        diff_ss += diffs.iter().map(|d| d * d).sum::<f64>();
        diff_n += diffs.len();
        let projection_diff_max_px = diffs.iter().copied().fold(0.0, f64::max);
        out.push(Fold { held_out, camera: r.camera, fit_rms_px: r.rms_px, held_out_rms_px: rms, projection_diff_max_px });
    }
    Ok(CrossValidation {
        intrinsics_spread: spread(&out, &full.std),
        held_out_rms_px: (held_ss / held_n.max(1) as f64).sqrt(),
        projection_diff_rms_px: (diff_ss / diff_n.max(1) as f64).sqrt(),
        projection_diff_max_px: out.iter().map(|f| f.projection_diff_max_px).fold(0.0, f64::max),
        folds: out,
    })
}

/// Centres of the [`CELLS`] x [`CELLS`] image cells holding at least one observed point.
fn covered_cells(views: &[View], size: ImageSize) -> Vec<Point2<f64>> {
    let grid = ImageGrid { size, cols: CELLS, rows: CELLS };
    let covered = grid.covered(views);
    (0..grid.len()).filter(|&k| covered[k]).map(|k| grid.centre(k)).collect()
}

/// Sample standard deviation of each intrinsic over the folds' cameras; NaN where `fixed_std` is
/// (the full calibration's standard deviations: NaN for parameters it held fixed).
fn spread(folds: &[Fold], fixed_std: &IntrinsicStd) -> IntrinsicStd {
    let vs: Vec<[f64; N_INTRINSICS]> = folds.iter().map(|f| vector_of(&f.camera)).collect();
    let n = vs.len() as f64;
    std::array::from_fn(|j| {
        if fixed_std[j].is_nan() {
            return f64::NAN;
        }
        let mean = vs.iter().map(|v| v[j]).sum::<f64>() / n;
        (vs.iter().map(|v| (v[j] - mean).powi(2)).sum::<f64>() / (n - 1.0).max(1.0)).sqrt()
    })
}

#[cfg(test)]
mod tests;
