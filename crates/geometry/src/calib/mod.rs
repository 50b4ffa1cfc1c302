//! Intrinsic camera calibration from views of a planar target: Zhang's closed form (OpenCV
//! models) or a focal-length search (fisheye, Double Sphere; [`init_wide`]), then
//! Levenberg-Marquardt over intrinsics, the lens parameters and every view's pose.
//!
//! Reference: Z. Zhang, "A flexible new technique for camera calibration", IEEE PAMI 22(11), 2000;
//! OpenCV `calibrateCamera` (same model and objective: its results are the outside reference in
//! the tests).

pub mod cross;
pub mod init_wide;
pub mod model;
pub mod refine;
pub mod views;
pub mod zhang;

pub use cross::{cross_validate, CrossValidation, Fold};
pub use model::{CalibModel, CALIB_MODELS};

use nalgebra::{Point2, Point3, Vector2, Vector3, Vector6};

pub use refine::View;
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
}

impl Default for CalibParams {
    fn default() -> Self {
        Self { estimate_skew: false, model: CalibModel::OpenCv5, fix_distortion: [false; MAX_LENS_PARAMS], max_iterations: 200 }
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
    /// Residuals (projected - observed), px.
    pub residuals_px: Vec<Vector2<f64>>,
}

/// Standard deviations of the intrinsics (NaN for fixed ones), in
/// [`synthcam_core::camera::intrinsic_names`] order: fx, fy, cx, cy, skew, then the lens parameters.
pub type IntrinsicStd = [f64; N_INTRINSICS];

/// Result of [`calibrate`].
#[derive(Debug, Clone, PartialEq)]
pub struct CalibResult {
    /// The calibrated camera.
    pub camera: CameraModel,
    /// RMS reprojection error over all points, px (as OpenCV's `calibrateCamera` returns).
    pub rms_px: f64,
    /// Per view.
    pub views: Vec<ViewResult>,
    /// Standard deviations from sigma^2 (J^T J)^-1 with sigma^2 = SSE / (n - k).
    pub std: IntrinsicStd,
    /// Iterations of the refinement.
    pub iterations: usize,
    /// Whether the refinement met its convergence test.
    pub converged: bool,
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

/// Zhang's closed form: intrinsics and every view's pose (OpenCV models).
fn initial_zhang(views: &[View], params: &CalibParams) -> Result<(refine::IntrinsicVector, Vec<Vector6<f64>>), CalibError> {
    let hs = views
        .iter()
        .enumerate()
        .map(|(i, v)| {
            let (src, dst): (Vec<Point2<f64>>, Vec<Point2<f64>>) = v.iter().map(|(x, q)| (x.xy(), *q)).unzip();
            synthcam_core::math::homography::homography(&src, &dst).ok_or_else(|| CalibError::Degenerate { reason: format!("no homography for view {i}") })
        })
        .collect::<Result<Vec<_>, _>>()?;
    let k0 = zhang::intrinsics_from_homographies(&hs, !params.estimate_skew)?;
    let poses: Vec<Vector6<f64>> = hs.iter().map(|h| refine::pose_vector(&zhang::pose_from_homography(h, &k0))).collect();
    let mut a0 = [0.0; N_INTRINSICS];
    a0[..5].copy_from_slice(&[k0.fx, k0.fy, k0.cx, k0.cy, k0.skew]);
    Ok((a0, poses))
}

/// Each view's residuals under `camera` at its pose (rvec, t), and the RMS over all points, px.
fn view_results(camera: &CameraModel, views: &[View], poses: &[Vector6<f64>]) -> (Vec<ViewResult>, f64) {
    let (mut total, mut count) = (0.0, 0usize);
    let results = views
        .iter()
        .zip(poses)
        .map(|(v, pose)| {
            let w = Vector3::new(pose[0], pose[1], pose[2]);
            let t = Vector3::new(pose[3], pose[4], pose[5]);
            let rot = synthcam_core::math::so3::rotation_from_rvec(&w);
            let res: Vec<Vector2<f64>> = v.iter().map(|(x, q)| camera.project_unchecked(&Point3::from(rot * x.coords + t)) - q).collect();
            let ss: f64 = res.iter().map(|e| e.norm_squared()).sum();
            total += ss;
            count += res.len();
            ViewResult { rvec: w, tvec: t, rms_px: (ss / res.len() as f64).sqrt(), max_px: res.iter().map(|e| e.norm()).fold(0.0, f64::max), residuals_px: res }
        })
        .collect();
    (results, (total / count.max(1) as f64).sqrt())
}

/// Calibrate from views of a planar target, with the lens model of `params.model`.
///
/// # Errors
/// Fewer than 3 views or 4 points per view, NaN, collinear or parallel views, or (fisheye,
/// Double Sphere) no focal length under which every view has a pose.
pub fn calibrate(views: &[View], size: ImageSize, params: &CalibParams) -> Result<CalibResult, CalibError> {
    validate(views)?;
    let kind = params.model.kind();
    let (a0, poses) = match kind {
        synthcam_core::camera::LensKind::OpenCv => initial_zhang(views, params)?,
        _ => init_wide::initial(size, kind, views)
            .ok_or_else(|| CalibError::Degenerate { reason: format!("no {} focal length fits every view", params.model) })?,
    };
    let mut free: Vec<usize> = vec![0, 1, 2, 3];
    if params.estimate_skew {
        free.push(4);
    }
    free.extend((0..params.model.n_lens_params()).filter(|i| !params.fix_distortion[*i]).map(|i| 5 + i));
    let init = refine::State { kind, a: a0, poses };
    let r = refine::refine(size, init, views, &free, params.max_iterations)
        .ok_or_else(|| CalibError::Degenerate { reason: "the normal equations are singular".into() })?;
    let camera = refine::camera_of(size, kind, &r.state.a);
    let mut std = [f64::NAN; N_INTRINSICS];
    for (j, &f) in free.iter().enumerate() {
        std[f] = r.covariance[(j, j)].sqrt();
    }
    let (view_results, rms_px) = view_results(&camera, views, &r.state.poses);
    Ok(CalibResult { camera, rms_px, views: view_results, std, iterations: r.iterations, converged: r.converged })
}

#[cfg(test)]
mod tests;
