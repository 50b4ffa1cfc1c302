//! ChArUco board detection: the ArUco markers of a [`Charuco`] board, then its chessboard
//! corners by local-homography interpolation and an unbiased saddle-model fit.
//!
//! 1. Marker candidates (`threshold`, `components`, `quads`): an adaptive mean threshold at one
//!    or more window sizes marks the pixels darker than their surroundings; the 8-connected
//!    components of those pixels (a marker's black border and the black bits touching it form
//!    one, cut off from the dark chessboard squares by the white margin) give their convex
//!    hulls, and a hull that a convex quadrilateral fits within a small tolerance is a
//!    candidate. Large images are searched at half resolution.
//! 2. Sub-pixel quad (`edges`): on the full-resolution image each side is located by the
//!    mid-level crossings of intensity profiles across it; a line fit per side, adjacent lines
//!    intersected.
//! 3. Decoding (`decode`): the perspective map of the unit square onto the quad samples the
//!    `(n + 2)^2` cells; Otsu's threshold on the cell means; the border must be black; the
//!    `n x n` bits match the board's codes in the four rotations within the dictionary's
//!    correction capacity; corner 0 becomes the marker's top-left. Only the board's ids are
//!    kept, one candidate per id; markers that disagree with every detected neighbour are
//!    dropped (`consistency`).
//! 4. ChArUco corners (`corners`): OpenCV's local-homography interpolation: each inner corner
//!    with at least one detected marker in an adjacent square is predicted by the homography
//!    fitted to that marker's corners and those of the nearest other detected marker(s) (the two
//!    adjacent markers when both are found, else the adjacent one and the nearest marker within
//!    two squares), and refined with [`refine_saddle`](super::refine_saddle) in a window that
//!    stays inside the white margin around the corner.
//!
//! References: S. Garrido-Jurado, R. Munoz-Salinas, F. J. Madrid-Cuevas, M. J. Marin-Jimenez,
//! "Automatic generation and detection of highly reliable fiducial markers under occlusion",
//! Pattern Recognition 47(6), 2014; OpenCV `modules/objdetect/src/aruco/aruco_detector.cpp`
//! (`detectMarkers`) and `charuco_detector.cpp` (`interpolateCornersCharucoLocalHom`);
//! N. Otsu, "A threshold selection method from gray-level histograms", IEEE SMC 9(1), 1979;
//! A. M. Andrew, "Another efficient algorithm for convex hulls in two dimensions", IPL 9(5),
//! 1979.

use std::borrow::Cow;

use nalgebra::Point2;
use rayon::prelude::*;

use super::par::worth_parallel;
use super::{DetectError, ImageF32, SaddleFitParams};
use crate::target::Charuco;

mod components;
mod consistency;
mod corners;
mod decode;
mod edges;
mod quads;
mod threshold;

/// Candidates are decoded in parallel (rayon) when there are at least this many.
const PARALLEL_MIN_QUADS: usize = 8;

/// Parameters of [`find_charuco`]. Grey-level thresholds are on the 0-255 scale of 8-bit images.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct CharucoParams {
    /// Side lengths of the adaptive-threshold windows, pixels of the search image (0 = unused);
    /// each non-zero size adds one candidate search (OpenCV's `adaptiveThreshWinSize*`).
    pub threshold_windows_px: [usize; 3],
    /// A pixel is dark when it lies this far below its window's mean, grey levels (OpenCV's
    /// `adaptiveThreshConstant`).
    pub threshold_offset: f32,
    /// Images with at least this many pixels are searched for candidates at half resolution
    /// (decoding and all fits stay at full resolution); markers then need sides of about 16
    /// full-resolution pixels (5x5 dictionary, 1280 x 1024: all 44 found at 20 px, 43 at 16 px,
    /// 25 at 14 px). `usize::MAX` never downsamples.
    pub downsample_min_pixels: usize,
    /// Smallest marker perimeter, full-resolution pixels.
    pub min_marker_perimeter_px: f64,
    /// Largest marker perimeter as a multiple of the image's larger side.
    pub max_marker_perimeter_rate: f64,
    /// Largest distance of the candidate's outline from its quadrilateral, as a fraction of the
    /// perimeter (OpenCV's `polygonalApproxAccuracyRate`).
    pub polygon_accuracy_rate: f64,
    /// Smallest contrast between a marker's white and black cells, grey levels.
    pub min_contrast: f64,
    /// Largest share of the marker's border cells that may read white.
    pub max_border_error_rate: f64,
    /// Share of the dictionary's correction capacity used (OpenCV's `errorCorrectionRate`).
    pub error_correction_rate: f64,
    /// Upper bound of the saddle-fit half-window, pixels (the window is also kept inside the
    /// white margin around each corner, and a corner whose margin allows less than 2 is dropped).
    pub max_half_window: usize,
    /// A refined corner may move at most this fraction of the margin's image size from its
    /// local-homography prediction.
    pub max_corner_shift_rate: f64,
    /// ... and at most this many pixels.
    pub max_corner_shift_px: f64,
    /// Largest RMS residual of the saddle fit as a fraction of its amplitude (half the contrast);
    /// exact renders give up to about 0.2 at small windows, clutter in the window more.
    pub max_fit_residual_rate: f64,
    /// Largest RMS residual of a local homography, as a fraction of the marker side in pixels.
    pub max_homography_rms_rate: f64,
    /// Base parameters of the saddle fit (`half_window` and `max_shift_px` are set per corner).
    pub refine: SaddleFitParams,
    /// Refine the corners in parallel (rayon) when there are at least this many.
    pub parallel_min_corners: usize,
}

impl Default for CharucoParams {
    fn default() -> Self {
        Self {
            threshold_windows_px: [9, 27, 0],
            threshold_offset: 7.0,
            downsample_min_pixels: 300_000,
            min_marker_perimeter_px: 40.0,
            max_marker_perimeter_rate: 4.0,
            polygon_accuracy_rate: 0.03,
            min_contrast: 20.0,
            max_border_error_rate: 0.1,
            error_correction_rate: 0.6,
            max_half_window: 6,
            max_corner_shift_rate: 0.5,
            max_corner_shift_px: 1.0,
            max_fit_residual_rate: 0.3,
            max_homography_rms_rate: 0.02,
            refine: SaddleFitParams::default(),
            parallel_min_corners: 16,
        }
    }
}

impl CharucoParams {
    /// Typed check of every field.
    fn validate(&self) -> Result<(), DetectError> {
        let bad = |reason| Err(DetectError::BadParams { reason });
        if self.threshold_windows_px.iter().all(|&w| w == 0) || self.threshold_windows_px.iter().any(|&w| w > 10_000) {
            return bad("threshold_windows_px needs a non-zero size, each at most 10000");
        }
        if !(self.threshold_offset.is_finite()) {
            return bad("threshold_offset must be finite");
        }
        if !(self.min_marker_perimeter_px >= 4.0 && self.min_marker_perimeter_px.is_finite()) {
            return bad("min_marker_perimeter_px must be finite and at least 4");
        }
        if !(self.max_marker_perimeter_rate > 0.0 && self.max_marker_perimeter_rate.is_finite()) {
            return bad("max_marker_perimeter_rate must be positive");
        }
        let rates =
            [self.polygon_accuracy_rate, self.max_border_error_rate, self.error_correction_rate, self.max_corner_shift_rate, self.max_homography_rms_rate];
        if !rates.iter().all(|r| (0.0..=1.0).contains(r)) {
            return bad("rates (polygon accuracy, border error, error correction, corner shift, homography rms) must be in [0, 1]");
        }
        if !(self.min_contrast >= 0.0 && self.min_contrast.is_finite()) {
            return bad("min_contrast must be finite and non-negative");
        }
        let finite_non_negative = |v: f64| v >= 0.0 && v.is_finite();
        if !(finite_non_negative(self.max_corner_shift_px) && finite_non_negative(self.max_fit_residual_rate)) {
            return bad("max_corner_shift_px and max_fit_residual_rate must be finite and non-negative");
        }
        if self.max_half_window < 2 || self.max_half_window > 50 {
            return bad("max_half_window must be in 2..=50");
        }
        Ok(())
    }
}

/// One decoded marker.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct MarkerDetection {
    /// Marker id in the dictionary.
    pub id: u32,
    /// Corners, pixels: top-left, top-right, bottom-right, bottom-left of the marker as in
    /// [`Charuco::markers`].
    pub corners_px: [Point2<f64>; 4],
}

/// A detected (possibly partial) ChArUco board.
#[derive(Debug, Clone, PartialEq, Default)]
pub struct CharucoDetection {
    /// The board's markers found, sorted by id.
    pub markers: Vec<MarkerDetection>,
    /// Chessboard corner ids ([`Charuco::chessboard_corners_m`] indices), ascending.
    pub ids: Vec<u32>,
    /// Corner positions, pixels, in the order of `ids`.
    pub corners_px: Vec<Point2<f64>>,
}

/// Detect the markers and chessboard corners of `board` in `img` (see the module docs). Parts
/// of the board may be hidden or outside the image; an image without the board gives an empty
/// detection. Non-finite samples are read as black by the search and make the fits near them
/// fail.
///
/// # Errors
/// [`DetectError::EmptyImage`], [`DetectError::BadBuffer`] (buffer and size disagree) and
/// [`DetectError::BadParams`] (invalid parameters, or a board that fails
/// [`Charuco::validate`]).
pub fn find_charuco(img: &ImageF32, board: &Charuco, params: &CharucoParams) -> Result<CharucoDetection, DetectError> {
    if img.width == 0 || img.height == 0 {
        return Err(DetectError::EmptyImage { width: img.width, height: img.height });
    }
    let expected = img.width.saturating_mul(img.height);
    if img.data.len() != expected {
        return Err(DetectError::BadBuffer { expected, actual: img.data.len() });
    }
    board.validate().map_err(|_| DetectError::BadParams { reason: "the board fails Charuco::validate" })?;
    params.validate()?;
    let (search, scale) = search_image(img, params);
    let quads = quads::candidates(&search, scale, params);
    let codes = decode::BoardCodes::new(board, params);
    let decode = |q: &quads::Quad| decode::marker(img, q, board, &codes, params);
    let found: Vec<decode::Decoded> =
        if worth_parallel(quads.len(), PARALLEL_MIN_QUADS) { quads.par_iter().filter_map(decode).collect() } else { quads.iter().filter_map(decode).collect() };
    let markers = consistency::filter(decode::best_per_id(found), board);
    let (ids, corners_px) = corners::interpolate(img, board, &markers, params);
    Ok(CharucoDetection { markers, ids, corners_px })
}

/// The image the candidate search runs on and its scale to full resolution (1 or 2); non-finite
/// samples are replaced by 0.
fn search_image<'a>(img: &'a ImageF32, params: &CharucoParams) -> (Cow<'a, ImageF32>, f64) {
    let (search, finite, scale) = if img.data.len() >= params.downsample_min_pixels && img.width >= 16 && img.height >= 16 {
        let (half, finite) = img.half_checked();
        (Cow::Owned(half), finite, 2.0)
    } else {
        (Cow::Borrowed(img), img.all_finite(), 1.0)
    };
    if finite {
        return (search, scale);
    }
    let mut clean = search.into_owned();
    clean.data.iter_mut().filter(|v| !v.is_finite()).for_each(|v| *v = 0.0);
    (Cow::Owned(clean), scale)
}

#[cfg(test)]
mod tests;
