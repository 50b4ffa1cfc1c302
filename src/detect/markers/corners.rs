//! Target corners at X-junctions next to markers: a homography of the target plane (fitted to
//! detected marker corners) predicts the corner, and [`refine_saddle`] refines it with the edge
//! directions of the target axes there (the homography's Jacobian).
//!
//! The locally uniform area around the corner (a square of half-size `margin` on the target: two
//! dark and two light quadrants, e.g. ChArUco's white margin around the markers, or an AprilGrid
//! tag's black border and gap) is where the fit window must stay: with `A` the inverse of the
//! Jacobian scaled by the margin, the largest axis-aligned image square in it has half-size
//! `h_max = min_rows 1 / (|a_r0| + |a_r1|)`; the window half-size is `floor(h_max - 1)` (room for
//! the rounded window centre and the pixel footprint), at least 2 and at most `max_half_window`;
//! a corner with `h_max` below 2.5 pixels is dropped. A refined corner is dropped when the fit
//! fails (window leaving the image, divergence), moves more than `max_corner_shift_rate * h_max`
//! or `max_corner_shift_px` from the prediction, has the wrong amplitude sign (a probe point in a
//! quadrant of known colour), too little contrast or an RMS residual above
//! `max_fit_residual_rate` of the amplitude (clutter in the window), or edge directions more than
//! 15 degrees off the prediction.
//!
//! Reference: OpenCV `modules/objdetect/src/aruco/charuco_detector.cpp`
//! (`interpolateCornersCharucoLocalHom`, `_selectAndRefineChessboardCorners`).

use nalgebra::{Matrix2, Matrix3, Point2, Vector2, Vector3};

use crate::detect::{refine_saddle, DetectError, ImageF32, SaddleFitParams};
use crate::math::homography::homography;

/// Smallest image size of the uniform area around a corner (`h_max`, see the module docs) for a
/// fit, pixels.
const MIN_MARGIN_PX: f64 = 2.5;
/// Largest sine of the angle between a fitted edge and its predicted direction.
const MAX_EDGE_SINE: f64 = 0.26;

/// Parameters of the corner refinement of the marker-based targets.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct CornerParams {
    /// Upper bound of the saddle-fit half-window, pixels (the window is also kept inside the
    /// uniform area around each corner, and a corner whose area allows less than 2 is dropped).
    pub max_half_window: usize,
    /// A refined corner may move at most this fraction of the uniform area's image size from
    /// its prediction.
    pub max_corner_shift_rate: f64,
    /// ... and at most this many pixels.
    pub max_corner_shift_px: f64,
    /// The limit in pixels for a corner predicted by its neighbours alone (its own marker not
    /// decoded: cut by the image border, blurred or hidden), whose prediction is a homography
    /// over several markers.
    pub max_predicted_shift_px: f64,
    /// Largest RMS residual of the saddle fit as a fraction of its amplitude (half the contrast);
    /// exact renders give up to about 0.2 at small windows, clutter in the window more.
    pub max_fit_residual_rate: f64,
    /// Largest RMS residual of a local homography, as a fraction of the marker side in pixels.
    pub max_homography_rms_rate: f64,
    /// Smallest contrast across the corner (twice the fitted amplitude), grey levels.
    pub min_contrast: f64,
    /// Base parameters of the saddle fit (`half_window` and `max_shift_px` are set per corner).
    pub refine: SaddleFitParams,
    /// Refine the corners in parallel (rayon) when there are at least this many.
    pub parallel_min_corners: usize,
    /// A corner whose fit residual exceeds this fraction of its amplitude *and* that moved more
    /// than `occlusion_shift_px` from its prediction is taken as partly hidden and dropped
    /// (measured on 20 occluded scenes: the one hidden corner that passed the other checks had
    /// 0.27 and 0.88 px; of 22 207 clean corners none had both above 0.2 and 0.5 px).
    pub occlusion_residual_rate: f64,
    /// See `occlusion_residual_rate`, pixels.
    pub occlusion_shift_px: f64,
}

impl Default for CornerParams {
    fn default() -> Self {
        Self {
            max_half_window: 5,
            max_corner_shift_rate: 0.5,
            max_corner_shift_px: 1.0,
            max_predicted_shift_px: 2.5,
            max_fit_residual_rate: 0.3,
            max_homography_rms_rate: 0.02,
            min_contrast: 20.0,
            refine: SaddleFitParams::default(),
            parallel_min_corners: 16,
            occlusion_residual_rate: 0.2,
            occlusion_shift_px: 0.5,
        }
    }
}

impl CornerParams {
    /// Typed check of every field.
    pub(crate) fn validate(&self) -> Result<(), DetectError> {
        let bad = |reason| Err(DetectError::BadParams { reason });
        if !((0.0..=1.0).contains(&self.max_corner_shift_rate) && (0.0..=1.0).contains(&self.max_homography_rms_rate)) {
            return bad("max_corner_shift_rate and max_homography_rms_rate must be in [0, 1]");
        }
        let finite_non_negative = |v: f64| v >= 0.0 && v.is_finite();
        let all = [
            self.max_corner_shift_px,
            self.max_predicted_shift_px,
            self.max_fit_residual_rate,
            self.min_contrast,
            self.occlusion_residual_rate,
            self.occlusion_shift_px,
        ];
        if !all.into_iter().all(finite_non_negative) {
            return bad("max_corner_shift_px, max_predicted_shift_px, max_fit_residual_rate, min_contrast, occlusion_residual_rate and occlusion_shift_px must be finite and non-negative");
        }
        if self.max_half_window < 2 || self.max_half_window > 50 {
            return bad("max_half_window must be in 2..=50");
        }
        Ok(())
    }
}

/// The homography (target plane to image) of the point pairs `src -> dst` (corners of `dst.len()
/// / 4` markers); `None` when it fails or its RMS residual exceeds `max_homography_rms_rate` of
/// the mean marker side.
pub(crate) fn local_homography(src: &[Point2<f64>], dst: &[Point2<f64>], params: &CornerParams) -> Option<Matrix3<f64>> {
    let h = homography(src, dst)?;
    let markers = dst.len() / 4;
    if markers == 0 {
        return None;
    }
    let side = dst.chunks_exact(4).map(|q| (0..4).map(|k| (q[(k + 1) % 4] - q[k]).norm()).sum::<f64>() / 4.0).sum::<f64>() / markers as f64;
    let rms = (src.iter().zip(dst).map(|(s, d)| (apply(&h, *s) - d).norm_squared()).sum::<f64>() / src.len() as f64).sqrt();
    (rms <= params.max_homography_rms_rate * side).then_some(h)
}

/// A corner to refine: target point `c` (metres) under homography `h`, uniform area of half-size
/// `margin_m` around it, and `probe_m`, an offset from `c` into a quadrant whose colour is
/// `probe_light` (light or dark).
#[derive(Debug, Clone, Copy)]
pub(crate) struct Junction {
    /// Target plane to image.
    pub h: Matrix3<f64>,
    /// The corner on the target plane, metres.
    pub c: Point2<f64>,
    /// Half-size of the uniform area around it, metres.
    pub margin_m: f64,
    /// Offset into a quadrant of known colour, metres.
    pub probe_m: Vector2<f64>,
    /// Whether that quadrant is light.
    pub probe_light: bool,
    /// The fit's start and the centre of its shift limit, pixels (default: `h` applied to `c`;
    /// a decoded marker's own sub-pixel corner where it has one, which stays close under lens
    /// distortion where a homography over several markers does not).
    pub seed_px: Option<Point2<f64>>,
    /// Predicted by neighbouring markers alone (the shift limit is `max_predicted_shift_px`).
    pub predicted: bool,
}

/// The refined corner (see the module docs); `None` when it is not measurable.
pub(crate) fn refine_junction(img: &ImageF32, j: &Junction, params: &CornerParams) -> Option<Point2<f64>> {
    let (p, jac) = (j.seed_px.unwrap_or_else(|| apply(&j.h, j.c)), jacobian(&j.h, j.c));
    let a = (jac * j.margin_m).try_inverse()?;
    let h_max = (0..2).map(|r| 1.0 / (a[(r, 0)].abs() + a[(r, 1)].abs())).fold(f64::INFINITY, f64::min);
    if !(h_max >= MIN_MARGIN_PX) {
        return None;
    }
    // Near the image border the window shrinks to stay inside (the fit needs at least 2).
    let border = p.x.min(p.y).min(img.width as f64 - 1.0 - p.x).min(img.height as f64 - 1.0 - p.y).floor() - 1.0;
    let hw = ((h_max - 1.0).min(border).floor().max(2.0) as usize).min(params.max_half_window);
    let fp = SaddleFitParams {
        half_window: hw,
        fast_half_window: params.refine.fast_half_window.min(hw),
        max_shift_px: (params.max_corner_shift_rate * h_max).min(if j.predicted { params.max_predicted_shift_px } else { params.max_corner_shift_px }),
        ..params.refine
    };
    let (dx, dy) = (jac.column(0).into_owned(), jac.column(1).into_owned());
    let fit = refine_saddle(img, p, dx, dy, &fp).ok()?;
    let towards = jac * j.probe_m;
    let side_of = |t: f64| Vector2::new(-t.sin(), t.cos()).dot(&towards).signum();
    let sign_ok = (fit.amplitude * side_of(fit.angles[0]) * side_of(fit.angles[1]) > 0.0) == j.probe_light;
    let edge_ok = |t: f64, d: &Vector2<f64>| Vector2::new(t.cos(), t.sin()).perp(&d.normalize()).abs() <= MAX_EDGE_SINE;
    let fit_ok = 2.0 * fit.amplitude.abs() >= params.min_contrast && fit.rms_residual <= params.max_fit_residual_rate * fit.amplitude.abs();
    let ok = sign_ok && fit_ok && edge_ok(fit.angles[0], &dx) && edge_ok(fit.angles[1], &dy);
    // A fit both poor and pulled far from its prediction: something else in the window (an
    // object hiding part of the corner, issue 19) drags it; a clean corner has one or the other.
    let occluded = fit.rms_residual > params.occlusion_residual_rate * fit.amplitude.abs() && (fit.point - p).norm() > params.occlusion_shift_px;
    let ok = ok && !occluded;
    ok.then_some(fit.point)
}

/// `h` applied to a point.
pub(crate) fn apply(h: &Matrix3<f64>, p: Point2<f64>) -> Point2<f64> {
    let v = h * Vector3::new(p.x, p.y, 1.0);
    Point2::new(v.x / v.z, v.y / v.z)
}

/// Jacobian of the map of `h` at `p` (columns: image derivatives along target x and y).
fn jacobian(h: &Matrix3<f64>, p: Point2<f64>) -> Matrix2<f64> {
    let v = h * Vector3::new(p.x, p.y, 1.0);
    let (u, w) = (Vector2::new(v.x, v.y), v.z);
    let col = |k: usize| (Vector2::new(h[(0, k)], h[(1, k)]) - u * (h[(2, k)] / w)) / w;
    Matrix2::from_columns(&[col(0), col(1)])
}
