//! Target corners at X-junctions next to markers: a homography of the target plane (fitted to
//! detected marker corners) predicts the corner, and [`refine_saddle`] refines it with the edge
//! directions of the target axes there (the homography's Jacobian).
//!
//! The locally uniform area around the corner ([`Area`]) is where the fit window must stay: two
//! dark and two light quadrants, either a square of half-size `margin` on the target (an
//! AprilGrid tag's black border and gap) or the four squares around the corner less, in the two
//! light ones, the markers inset by `margin` (ChArUco: the window may reach along the white
//! margins and into the dark squares, which matters on tilted or rolled boards, where the image
//! of the margin square is thin or turned). `h_max` is the half-size of the largest axis-aligned
//! image square centred on the prediction whose target footprint (through the inverse Jacobian)
//! stays in the area: in closed form `min_rows margin / (|a_r0| + |a_r1|)` (`a` the rows of the
//! inverse Jacobian) for the half-planes bounding a square, by bisection for the quarter-planes
//! of the inset markers. The window half-size is `floor(h_max - 1)` (room for the rounded window
//! centre and the pixel footprint), at least 2 and at most `max_half_window`; a square-area
//! corner with `h_max` below 2.5 pixels is dropped. An inset-marker window that still reaches
//! into a marker (the smallest window on a margin under about 3 pixels) has the pixels whose
//! footprint meets the marker set to the light level (the median of the pixels around that lie
//! wholly in a light quadrant outside the markers): what the saddle shows there, so the model
//! fits the rest unbiased; a corner where such a pixel also crosses the quadrant's edge (a margin
//! under a pixel) is dropped.
//!
//! A refined corner is dropped when the fit fails (window leaving the image, divergence), moves
//! more than `max_corner_shift_rate * h_max` or `max_corner_shift_px` from the prediction, has
//! the wrong amplitude sign (a probe point in a quadrant of known colour), too little contrast or
//! an RMS residual above `max_fit_residual_rate` of the amplitude (clutter in the window), or
//! edge directions more than 15 degrees off the prediction. The residual limit holds for windows
//! of 7 x 7 pixels and more; the model's misfit at the few pixels both edges cross (sharp edges,
//! where the fitted blur reaches its floor) is a fixed sum of squares, so its RMS over a 5 x 5
//! window is 7/5 larger and the limit there is scaled by 7/5.
//!
//! The local homographies are Hartley-normalised DLTs with `h33 = 1`, solved on the 8 x 8
//! normal equations (the same fit as the SVD's to rounding on marker corners, several times
//! cheaper at 8-16 point pairs).
//!
//! Reference: OpenCV `modules/objdetect/src/aruco/charuco_detector.cpp`
//! (`interpolateCornersCharucoLocalHom`, `_selectAndRefineChessboardCorners`).

use nalgebra::{Matrix2, Matrix3, Point2, SMatrix, SVector, Vector2, Vector3};

pub(crate) use super::window::Area;
use super::window::{marker_patch, reach_px, Patched};
use super::Samples;
use crate::{refine_saddle, DetectError, SaddleFitParams};

/// Smallest image size of the uniform area around a corner (`h_max`, see the module docs) for a
/// fit, pixels.
const MIN_MARGIN_PX: f64 = 2.5;
/// Window side (pixels) at and above which the residual limit is `max_fit_residual_rate`; a
/// narrower window's limit is scaled by this over its side (see [`refine_junction`]).
const RESIDUAL_REF_WINDOW: usize = 7;
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

/// Similarity moving `pts` to zero mean and mean distance sqrt(2) (Hartley's normalisation).
fn normaliser(pts: &[Point2<f64>]) -> Matrix3<f64> {
    let n = pts.len().max(1) as f64;
    let c = pts.iter().fold(Vector2::zeros(), |a, p| a + p.coords) / n;
    let d = pts.iter().map(|p| (p.coords - c).norm()).sum::<f64>() / n;
    let s = if d > 0.0 { std::f64::consts::SQRT_2 / d } else { 1.0 };
    Matrix3::new(s, 0.0, -s * c.x, 0.0, s, -s * c.y, 0.0, 0.0, 1.0)
}

/// Homography `H` with `dst ~ H src` from 4 or more point pairs: Hartley-normalised DLT with
/// `h33 = 1` in the normalised frame (the source centroid maps to a finite point, as it does for
/// markers in view), solved by Cholesky on the 8 x 8 normal equations, which is several times
/// cheaper than the SVD of [`synthcam_core::math::homography::homography`] at the 8-16 pairs of a local
/// fit; `None` when degenerate.
pub(crate) fn homography(src: &[Point2<f64>], dst: &[Point2<f64>]) -> Option<Matrix3<f64>> {
    if src.len() < 4 || src.len() != dst.len() {
        return None;
    }
    let (ts, td) = (normaliser(src), normaliser(dst));
    let mut ata = SMatrix::<f64, 8, 8>::zeros();
    let mut atb = SVector::<f64, 8>::zeros();
    for (s, d) in src.iter().zip(dst) {
        let (s, d) = (ts * s.to_homogeneous(), td * d.to_homogeneous());
        let (x, y, u, v) = (s.x, s.y, d.x, d.y);
        // u = (h0 x + h1 y + h2) / (h6 x + h7 y + 1), v likewise with h3..h5
        let r0 = SVector::<f64, 8>::from_column_slice(&[x, y, 1.0, 0.0, 0.0, 0.0, -u * x, -u * y]);
        let r1 = SVector::<f64, 8>::from_column_slice(&[0.0, 0.0, 0.0, x, y, 1.0, -v * x, -v * y]);
        ata += r0 * r0.transpose() + r1 * r1.transpose();
        atb += r0 * u + r1 * v;
    }
    let h = ata.cholesky()?.solve(&atb);
    let hn = Matrix3::new(h[0], h[1], h[2], h[3], h[4], h[5], h[6], h[7], 1.0);
    let hm = td.try_inverse()? * hn * ts;
    let scale = hm[(2, 2)];
    (scale.abs() > 1e-300 && hm.iter().all(|v| v.is_finite())).then(|| hm / scale)
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
    /// Half-size of the uniform area around it, metres (see [`Area`]).
    pub margin_m: f64,
    /// Shape of the uniform area.
    pub area: Area,
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
pub(crate) fn refine_junction<I: Samples + ?Sized>(img: &I, j: &Junction, params: &CornerParams) -> Option<Point2<f64>> {
    let (p, jac) = (j.seed_px.unwrap_or_else(|| apply(&j.h, j.c)), jacobian(&j.h, j.c));
    let inv = jac.try_inverse()?;
    let h_max = reach_px(&inv, j.margin_m, j.area);
    // an inset-marker window may reach into the markers (their pixels are patched below)
    if !(h_max >= MIN_MARGIN_PX || matches!(j.area, Area::Inset { .. }) && h_max > 0.0) {
        return None;
    }
    // Near the image border the window shrinks to stay inside (the fit needs at least 2).
    let border = p.x.min(p.y).min(img.width() as f64 - 1.0 - p.x).min(img.height() as f64 - 1.0 - p.y).floor() - 1.0;
    let hw = ((h_max - 1.0).min(border).floor().max(2.0) as usize).min(params.max_half_window);
    let fp = SaddleFitParams {
        half_window: hw,
        fast_half_window: params.refine.fast_half_window.min(hw),
        max_shift_px: (params.max_corner_shift_rate * h_max).min(if j.predicted { params.max_predicted_shift_px } else { params.max_corner_shift_px }),
        ..params.refine
    };
    let (dx, dy) = (jac.column(0).into_owned(), jac.column(1).into_owned());
    // a window reaching into an inset marker sees it as the light square it sits in
    // (only where the window with its room, hw + 1, passes h_max)
    let patch = match j.area {
        Area::Inset { light, .. } if hw as f64 + 1.0 > h_max => marker_patch(img, p, hw, &inv, j.margin_m, light)?,
        _ => Vec::new(),
    };
    let fit = if patch.is_empty() { refine_saddle(img, p, dx, dy, &fp) } else { refine_saddle(&Patched { img, patch }, p, dx, dy, &fp) }.ok()?;
    let towards = jac * j.probe_m;
    let side_of = |t: f64| Vector2::new(-t.sin(), t.cos()).dot(&towards).signum();
    let sign_ok = (fit.amplitude * side_of(fit.angles[0]) * side_of(fit.angles[1]) > 0.0) == j.probe_light;
    let edge_ok = |t: f64, d: &Vector2<f64>| Vector2::new(t.cos(), t.sin()).perp(&d.normalize()).abs() <= MAX_EDGE_SINE;
    // the model's misfit at the pixels both edges cross is a fixed sum of squares: its RMS over
    // windows narrower than RESIDUAL_REF_WINDOW grows as 1 / side
    let residual_limit = params.max_fit_residual_rate * (RESIDUAL_REF_WINDOW as f64 / (2 * hw + 1) as f64).max(1.0);
    let fit_ok = 2.0 * fit.amplitude.abs() >= params.min_contrast && fit.rms_residual <= residual_limit * fit.amplitude.abs();
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
#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn homography_matches_the_svd_dlt() {
        let truth = Matrix3::new(900.0, 40.0, 320.0, -30.0, 850.0, 240.0, 0.3, -0.2, 1.0);
        let src: Vec<Point2<f64>> = (0..12).map(|k| Point2::new(0.03 * f64::from(k % 4), 0.02 * f64::from(k / 4))).collect();
        let dst: Vec<Point2<f64>> = src.iter().map(|p| apply(&truth, *p)).collect();
        let h = homography(&src, &dst).unwrap();
        let svd = synthcam_core::math::homography::homography(&src, &dst).unwrap();
        for p in &src {
            assert!((apply(&h, *p) - apply(&truth, *p)).norm() < 1e-9);
            assert!((apply(&h, *p) - apply(&svd, *p)).norm() < 1e-9);
        }
        // four points: exact; too few points or a mismatch: none
        let (s4, d4) = ([src[0], src[3], src[11], src[8]], [dst[0], dst[3], dst[11], dst[8]]);
        assert!(homography(&s4, &d4).is_some_and(|h| (apply(&h, src[5]) - dst[5]).norm() < 1e-9));
        assert!(homography(&src[..3], &dst[..3]).is_none());
        assert!(homography(&src, &dst[..11]).is_none());
    }
}
