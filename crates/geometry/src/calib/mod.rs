//! Intrinsic camera calibration from views of a planar target: Zhang's closed form (OpenCV
//! models) or a focal-length search (fisheye, Double Sphere; [`init_wide`]), then
//! Levenberg-Marquardt over intrinsics, the lens parameters and every view's pose.
//!
//! Reference: Z. Zhang, "A flexible new technique for camera calibration", IEEE PAMI 22(11), 2000;
//! OpenCV `calibrateCamera` (same model and objective: its results are the outside reference in
//! the tests).

pub mod compare;
pub mod cross;
pub mod global;
pub mod init_wide;
pub mod model;
pub mod outliers;
pub mod precision;
pub mod rectify;
pub mod refine;
pub mod rig;
pub mod uncertainty;
pub mod views;
pub mod zhang;

pub use compare::{projection_diff, ProjectionDiff};
pub use cross::{cross_validate, CrossValidation, Fold};
pub use global::Search;
pub use model::{CalibModel, CALIB_MODELS};
pub use outliers::Rejection;
pub use rectify::{essential_fundamental, stereo_rectify, StereoRectification};
pub use rig::{calibrate_rig, rectified_row_errors, RigCamera, RigCameraResult, RigResult};
pub use uncertainty::UncertaintyMap;

use nalgebra::{Point3, Vector2, Vector3, Vector6};

pub use refine::{BoardExtent, View, Warp};
use synthcam_core::camera::{CameraModel, ImageSize, MAX_LENS_PARAMS, N_INTRINSICS};
pub use views::{views_from_detections, BoardViews, SkippedDetection};

/// Errors of the calibration.
#[derive(Debug, thiserror::Error, Clone, PartialEq)]
#[non_exhaustive]
pub enum CalibError {
    /// Not enough views.
    #[error("calibration needs at least {required} views, got {actual}")]
    TooFewViews {
        /// Needed.
        required: usize,
        /// Given.
        actual: usize,
    },
    /// A view has too few points.
    #[error("view {view} has {actual} points, at least {required} needed")]
    TooFewPoints {
        /// View index.
        view: usize,
        /// Needed.
        required: usize,
        /// Given.
        actual: usize,
    },
    /// A point is NaN or infinite.
    #[error("view {view}, point {index}: non-finite coordinate")]
    NonFinite {
        /// View index.
        view: usize,
        /// Point index.
        index: usize,
    },
    /// An option out of its range.
    #[error("bad option: {reason}")]
    BadOption {
        /// Why.
        reason: String,
    },
    /// A detection whose points do not fit the board.
    #[error("detection {index}: {reason}")]
    BadDetection {
        /// Index into the detections.
        index: usize,
        /// Why.
        reason: String,
    },
    /// The data cannot determine the parameters.
    #[error("degenerate data: {reason}")]
    Degenerate {
        /// Why.
        reason: String,
    },
}

/// Options of [`calibrate`].
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct CalibParams {
    /// Estimate the skew `K[0][1]` (OpenCV never does).
    pub estimate_skew: bool,
    /// The lens model to estimate.
    pub model: CalibModel,
    /// Fix lens parameters (in [`synthcam_core::camera::LensKind::param_names`] order) at their
    /// initial value (0; Double Sphere: `xi = 0`, `alpha = 0.5`).
    pub fix_distortion: [bool; MAX_LENS_PARAMS],
    /// Levenberg-Marquardt iteration limit.
    pub max_iterations: usize,
    /// Drop points whose residual is more than this many robust standard deviations of the
    /// residuals, then fit again ([`outliers`]); `None` keeps every point (as OpenCV does).
    pub outlier_threshold: Option<f64>,
    /// Estimate the board's warp (mrcal's two-parameter sag, [`Warp`]) over this extent of the
    /// board (usually its points' extent, [`BoardExtent::of`]); `None`: the board is flat.
    pub board_warp: Option<BoardExtent>,
    /// A camera to start from besides the model's own starts ([`global`]; as OpenCV's
    /// `CALIB_USE_INTRINSIC_GUESS`, except that the other starts still run and the lowest
    /// optimum wins). Ignored unless its lens model is the one estimated.
    pub initial: Option<CameraModel>,
}

/// [`CalibParams::outlier_threshold`]'s default: 5 robust standard deviations (a residual of
/// Gaussian noise exceeds it with probability `exp(-12.5)`, 4e-6, per point).
pub const DEFAULT_OUTLIER_THRESHOLD: f64 = 5.0;

impl Default for CalibParams {
    fn default() -> Self {
        Self {
            estimate_skew: false,
            model: CalibModel::OpenCv5,
            fix_distortion: [false; MAX_LENS_PARAMS],
            max_iterations: 200,
            outlier_threshold: Some(DEFAULT_OUTLIER_THRESHOLD),
            board_warp: None,
            initial: None,
        }
    }
}

/// Result for one view.
#[derive(Debug, Clone, PartialEq)]
pub struct ViewResult {
    /// `cam_from_board` rotation vector, radians.
    pub rvec: Vector3<f64>,
    /// `cam_from_board` translation, board units.
    pub tvec: Vector3<f64>,
    /// RMS reprojection error, px.
    pub rms_px: f64,
    /// Largest reprojection error, px.
    pub max_px: f64,
    /// Residuals (projected - observed) of every point of the view, outliers included, px.
    pub residuals_px: Vec<Vector2<f64>>,
    /// Indices (into the view's points) of the points dropped as outliers; `rms_px` and
    /// `max_px` are over the others.
    pub outliers: Vec<usize>,
}

/// Standard deviations of the intrinsics (NaN for fixed ones), in
/// [`synthcam_core::camera::intrinsic_names`] order: fx, fy, cx, cy, skew, then the lens parameters.
pub type IntrinsicStd = [f64; N_INTRINSICS];

/// Result of [`calibrate`].
#[derive(Debug, Clone, PartialEq)]
pub struct CalibResult {
    /// The calibrated camera.
    pub camera: CameraModel,
    /// RMS reprojection error over all points not dropped as outliers, px (as OpenCV's
    /// `calibrateCamera` returns).
    pub rms_px: f64,
    /// Per view.
    pub views: Vec<ViewResult>,
    /// Standard deviations from sigma^2 (J^T J)^-1 with sigma^2 = SSE / (n - k); infinite for a
    /// parameter the data do not determine ([`CalibResult::undetermined`]), NaN for fixed ones.
    pub std: IntrinsicStd,
    /// Iterations of the refinement.
    pub iterations: usize,
    /// Whether the refinement met its convergence test.
    pub converged: bool,
    /// Parameters the data do not determine (indices into the intrinsics vector,
    /// [`synthcam_core::camera::intrinsic_names`], then the warp's `N_INTRINSICS`,
    /// `N_INTRINSICS + 1`): a null direction of the normal equations moves them (e.g. Double
    /// Sphere's `fx`, `xi`, `alpha` at `xi = 0`). Empty for a well-posed calibration.
    pub undetermined: Vec<usize>,
    /// The board's warp as estimated (`k` zero and no extent unless asked for).
    pub board_warp: Warp,
    /// Standard deviations of the warp's `kx`, `ky` (NaN unless estimated), board units.
    pub board_warp_std: [f64; 2],
    /// The starts and restarts behind the optimum ([`global`]).
    pub search: Search,
    /// The outlier rejection ([`outliers`]).
    pub rejection: Rejection,
    /// What the projection uncertainty needs ([`uncertainty`]).
    precision: refine::Precision,
}

fn validate(views: &[View]) -> Result<(), CalibError> {
    if views.len() < 3 {
        return Err(CalibError::TooFewViews { required: 3, actual: views.len() });
    }
    for (vi, v) in views.iter().enumerate() {
        if v.len() < 4 {
            return Err(CalibError::TooFewPoints { view: vi, required: 4, actual: v.len() });
        }
        for (i, (x, q)) in v.iter().enumerate() {
            if !(x.coords.iter().all(|c| c.is_finite()) && q.coords.iter().all(|c| c.is_finite())) {
                return Err(CalibError::NonFinite { view: vi, index: i });
            }
        }
        // Spread of the board points: both principal axes must be non-degenerate.
        let n = v.len() as f64;
        let m = v.iter().fold(Vector2::zeros(), |a, (x, _)| a + x.xy().coords) / n;
        let mut c = nalgebra::Matrix2::zeros();
        for (x, _) in v {
            let d = x.xy().coords - m;
            c += d * d.transpose();
        }
        let e = c.symmetric_eigenvalues();
        if !(e.min() > 1e-12 * e.max().max(1e-300)) {
            return Err(CalibError::Degenerate { reason: format!("the points of view {vi} are collinear") });
        }
        if v.iter().any(|(x, _)| x.z != 0.0) {
            return Err(CalibError::Degenerate { reason: format!("view {vi}: board points must lie on z = 0") });
        }
    }
    Ok(())
}

/// Every point's residual (projected - observed) under `camera` at the view's pose (rvec, t), the
/// board warped by `warp`.
fn residuals(camera: &CameraModel, warp: &Warp, view: &View, pose: &Vector6<f64>) -> Vec<Vector2<f64>> {
    let rot = synthcam_core::math::so3::rotation_from_rvec(&Vector3::new(pose[0], pose[1], pose[2]));
    let t = Vector3::new(pose[3], pose[4], pose[5]);
    view.iter().map(|(x, q)| camera.project_unchecked(&Point3::from(rot * warp.apply(x).coords + t)) - q).collect()
}

/// Each view's residuals under `camera` at its pose, and the RMS over all points but the
/// `outliers` (per view; empty: none), px.
fn view_results(camera: &CameraModel, warp: &Warp, views: &[View], poses: &[Vector6<f64>], outliers: &[Vec<usize>]) -> (Vec<ViewResult>, f64) {
    let (mut total, mut count) = (0.0, 0usize);
    let results = views
        .iter()
        .zip(poses)
        .enumerate()
        .map(|(i, (v, pose))| {
            let res = residuals(camera, warp, v, pose);
            let dropped = outliers.get(i).cloned().unwrap_or_default();
            let kept: Vec<f64> = res.iter().enumerate().filter(|(j, _)| !dropped.contains(j)).map(|(_, e)| e.norm()).collect();
            let ss: f64 = kept.iter().map(|e| e * e).sum();
            total += ss;
            count += kept.len();
            ViewResult {
                rvec: Vector3::new(pose[0], pose[1], pose[2]),
                tvec: Vector3::new(pose[3], pose[4], pose[5]),
                rms_px: (ss / kept.len().max(1) as f64).sqrt(),
                max_px: kept.iter().copied().fold(0.0, f64::max),
                residuals_px: res,
                outliers: dropped,
            }
        })
        .collect();
    (results, (total / count.max(1) as f64).sqrt())
}

/// The free intrinsic indices of `params`.
fn free_parameters(params: &CalibParams) -> Vec<usize> {
    let mut free: Vec<usize> = vec![0, 1, 2, 3];
    if params.estimate_skew {
        free.push(4);
    }
    free.extend((0..params.model.n_lens_params()).filter(|i| !params.fix_distortion[*i]).map(|i| 5 + i));
    if params.board_warp.is_some() {
        free.extend([N_INTRINSICS, N_INTRINSICS + 1]);
    }
    free
}

/// Calibrate from views of a planar target, with the lens model of `params.model`: the best of
/// several starts checked by perturbed restarts ([`global`]), outliers dropped ([`outliers`]).
///
/// # Errors
/// Fewer than 3 views or 4 points per view, NaN, collinear or parallel views, an outlier
/// threshold that is not a positive number, or (fisheye, Double Sphere) no focal length under
/// which every view has a pose.
pub fn calibrate(views: &[View], size: ImageSize, params: &CalibParams) -> Result<CalibResult, CalibError> {
    validate(views)?;
    if let Some(k) = params.outlier_threshold.filter(|k| !(k.is_finite() && *k > 0.0)) {
        return Err(CalibError::BadOption { reason: format!("the outlier threshold must be a positive number of standard deviations, got {k}") });
    }
    let free = free_parameters(params);
    let (fit, search) = global::fit(views, size, params, &free)?;
    let (r, dropped, rejection) = outliers::reject(fit, views, size, params, &free)?;
    let camera = refine::camera_of(size, r.state.kind, &r.state.a);
    let (mut std, mut board_warp_std) = ([f64::NAN; N_INTRINSICS], [f64::NAN; 2]);
    for (j, &f) in free.iter().enumerate() {
        let s = if r.undetermined.contains(&f) { f64::INFINITY } else { r.covariance[(j, j)].sqrt() };
        match f.checked_sub(N_INTRINSICS) {
            Some(w) => board_warp_std[w.min(1)] = s,
            None => std[f] = s,
        }
    }
    let (view_results, rms_px) = view_results(&camera, &r.state.warp, views, &r.state.poses, &dropped);
    Ok(CalibResult {
        camera,
        rms_px,
        views: view_results,
        std,
        iterations: r.iterations,
        converged: r.converged,
        undetermined: r.undetermined.clone(),
        board_warp: r.state.warp,
        board_warp_std,
        search,
        rejection,
        precision: r.precision,
    })
}

#[cfg(test)]
mod rig_tests;
#[cfg(test)]
mod robust_tests;
#[cfg(test)]
mod testdata;
#[cfg(test)]
mod tests;
