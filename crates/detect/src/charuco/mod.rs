//! ChArUco board detection: the ArUco markers of a [`Charuco`] board, then its chessboard
//! corners by local-homography interpolation and an unbiased saddle-model fit.
//!
//! 1. Markers ([`find_markers`], 1-bit border): adaptive
//!    threshold, dark components, quads, sub-pixel outline, decoding of the board's ids (see
//!    `detect::markers`); large images are searched at half resolution.
//! 2. Consistency: markers that disagree with every detected neighbour on the board are dropped.
//! 3. Full-resolution retry (`retry`): where the board's homography, fitted to the markers
//!    found, implies markers inside the image that the half-resolution search missed (small or
//!    foreshortened markers, whose thin white margins merge at half resolution), the search runs
//!    again at full resolution around them, with a threshold window chosen from their predicted
//!    size; the new markers go through the consistency check with the others.
//! 4. ChArUco corners (`corners`): OpenCV's local-homography interpolation: each inner corner
//!    with at least one detected marker in an adjacent square is predicted by the homography
//!    fitted to that marker's corners and those of the nearest other detected marker(s) (the two
//!    adjacent markers when both are found, else the adjacent one and the nearest marker within
//!    two squares), and refined with [`refine_saddle`](super::refine_saddle) in a window that
//!    stays out of the markers (along the white margins and into the black squares), or whose
//!    pixels in a marker are set to the light level where the margin is thinner than the
//!    smallest window.
//!
//! [`find_charuco_u8`] reads 8-bit samples directly (the CLI's path): same results, without
//! converting the image to f32.
//!
//! References: S. Garrido-Jurado, R. Munoz-Salinas, F. J. Madrid-Cuevas, M. J. Marin-Jimenez,
//! "Automatic generation and detection of highly reliable fiducial markers under occlusion",
//! Pattern Recognition 47(6), 2014; OpenCV `modules/objdetect/src/aruco/aruco_detector.cpp`
//! (`detectMarkers`, `refineDetectedMarkers`) and `charuco_detector.cpp`
//! (`interpolateCornersCharucoLocalHom`);
//! N. Otsu, "A threshold selection method from gray-level histograms", IEEE SMC 9(1), 1979;
//! A. M. Andrew, "Another efficient algorithm for convex hulls in two dimensions", IPL 9(5),
//! 1979.

use nalgebra::Point2;

use super::markers::consistency::{self, Placement};
use super::markers::{
    check_image, check_image_u8, find_markers, find_markers_in, find_markers_u8, searched_at_half, CornerParams, MarkerParams, MarkerSet, Samples,
};
use super::{DetectError, ImageF32, ImageU8, MarkerDetection};
use synthcam_core::target::Charuco;

mod corners;
mod retry;

/// Parameters of [`find_charuco`].
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct CharucoParams {
    /// Marker search and decoding.
    pub markers: MarkerParams,
    /// Chessboard-corner refinement.
    pub corners: CornerParams,
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
    check_image(img)?;
    let set = marker_set(board, params)?;
    let found = find_markers(img, &set, &params.markers)?;
    Ok(board_from_markers(img, board, &set, found, params))
}

/// [`find_charuco`] on 8-bit samples, with identical results, without converting the image to
/// f32: the half-resolution search image is made from the 8-bit samples (a quarter of the
/// memory traffic) and the outlines, codes and corners are sampled from them.
///
/// # Errors
/// As [`find_charuco`].
pub fn find_charuco_u8(img: &ImageU8, board: &Charuco, params: &CharucoParams) -> Result<CharucoDetection, DetectError> {
    check_image_u8(img)?;
    let set = marker_set(board, params)?;
    let found = find_markers_u8(img, &set, &params.markers)?;
    Ok(board_from_markers(img, board, &set, found, params))
}

/// The board's markers as a marker set (parameters and board checked).
fn marker_set(board: &Charuco, params: &CharucoParams) -> Result<MarkerSet, DetectError> {
    board.validate().map_err(|_| DetectError::BadParams { reason: "the board fails Charuco::validate" })?;
    params.corners.validate()?;
    Ok(MarkerSet {
        dictionary: board.dictionary,
        border_bits: 1,
        first_id: board.first_id,
        count: board.markers().len() as u32,
        margin_rate: 0.5 * (board.square_m - board.marker_m) / board.marker_m,
        touching_corners: false,
    })
}

/// Steps 2-4 (see the module docs) after the marker search found `found`.
fn board_from_markers<I: Samples + ?Sized>(img: &I, board: &Charuco, set: &MarkerSet, found: Vec<MarkerDetection>, params: &CharucoParams) -> CharucoDetection {
    let layout = board.markers();
    let place = |id: u32| {
        let e = layout.get(id.checked_sub(board.first_id)? as usize)?;
        Some(Placement { cell: e.square.map(i64::from), corners_m: e.corners_m.map(|c| Point2::new(c.x, c.y)) })
    };
    let mut markers = consistency::filter(found, board.marker_m, place);
    let (w, h) = (img.width(), img.height());
    if searched_at_half(w, h, &params.markers) {
        if let Some(r) = retry::plan((w, h), board, &markers, &params.markers) {
            let known: Vec<[Point2<f64>; 4]> = markers.iter().map(|m| m.corners_px).collect();
            let retry_params = MarkerParams { threshold_windows_px: [r.threshold_px, 0, 0], ..params.markers };
            let more = find_markers_in(img, set, &retry_params, r.window, &known);
            if !more.is_empty() {
                let have: Vec<u32> = markers.iter().map(|m| m.id).collect();
                markers.extend(more.into_iter().filter(|m| !have.contains(&m.id)));
                markers.sort_by_key(|m| m.id);
                markers = consistency::filter(markers, board.marker_m, place);
            }
        }
    }
    let (ids, corners_px) = corners::interpolate(img, board, &markers, &params.corners);
    CharucoDetection { markers, ids, corners_px }
}

#[cfg(test)]
mod tests;
