//! ChArUco board detection: the ArUco markers of a [`Charuco`] board, then its chessboard
//! corners by local-homography interpolation and an unbiased saddle-model fit.
//!
//! 1. Markers ([`find_markers`], 1-bit border): adaptive
//!    threshold, dark components, quads, sub-pixel outline, decoding of the board's ids (see
//!    `detect::markers`).
//! 2. Consistency: markers that disagree with every detected neighbour on the board are dropped.
//! 3. ChArUco corners (`corners`): OpenCV's local-homography interpolation: each inner corner
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

use nalgebra::Point2;

use super::markers::consistency::{self, Placement};
use super::markers::{check_image, find_markers, CornerParams, MarkerParams, MarkerSet};
use super::{DetectError, ImageF32, MarkerDetection};
use crate::target::Charuco;

mod corners;

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
    board.validate().map_err(|_| DetectError::BadParams { reason: "the board fails Charuco::validate" })?;
    params.corners.validate()?;
    let layout = board.markers();
    let set = MarkerSet {
        dictionary: board.dictionary,
        border_bits: 1,
        first_id: board.first_id,
        count: layout.len() as u32,
        margin_rate: 0.5 * (board.square_m - board.marker_m) / board.marker_m,
        touching_corners: false,
    };
    let found = find_markers(img, &set, &params.markers)?;
    let place = |id: u32| {
        let e = layout.get(id.checked_sub(board.first_id)? as usize)?;
        Some(Placement { cell: e.square.map(i64::from), corners_m: e.corners_m.map(|c| Point2::new(c.x, c.y)) })
    };
    let markers = consistency::filter(found, board.marker_m, place);
    let (ids, corners_px) = corners::interpolate(img, board, &markers, &params.corners);
    Ok(CharucoDetection { markers, ids, corners_px })
}

#[cfg(test)]
mod tests;
