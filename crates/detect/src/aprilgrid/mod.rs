//! Kalibr AprilGrid detection: the tags of an [`AprilGrid`] (AprilTag codes with Kalibr's 2-bit
//! border, or 1 bit), then each tag corner refined as the X-junction it forms with the black
//! square at its gap crossing.
//!
//! 1. Tags ([`find_markers`] with the grid's border width and id
//!    range; `detect::markers`): adaptive threshold, 4-connected dark components (a tag touches
//!    the black gap squares only diagonally, so they stay apart), quads, sub-pixel outline,
//!    decoding. Kalibr prints tag `k` as OpenCV's marker image of id `first_id + k` turned by 180
//!    degrees on the page, so the decoded corners (marker top-left, top-right, bottom-right,
//!    bottom-left) are Kalibr's corners 1, 0, 3, 2 (bottom-left, bottom-right, top-right,
//!    top-left, y up the page); they are reordered to Kalibr's order.
//! 2. Consistency: tags that disagree with every detected neighbour on the grid are dropped.
//! 3. Corners (`corners`): each tag corner is an X-junction (the tag's black border meets the
//!    gap square diagonally, white gap on the other two sides). It is predicted by the homography
//!    of the detected tags around its gap crossing (the tag alone when its neighbours are missing
//!    or disagree) and refined with [`refine_saddle`](super::refine_saddle) in a window inside the
//!    uniform area (the smaller of the tag's black border and the gap), with the checks of
//!    [`CornerParams`].
//!
//! References: Kalibr (`aslam_cv/aslam_cameras_april/src/GridCalibrationTargetAprilgrid.cpp`,
//! `computeObservation`; `kalibr_create_target_pdf`); E. Olson, "AprilTag: A robust and flexible
//! visual fiducial system", ICRA 2011; J. Wang, E. Olson, "AprilTag 2: Efficient and robust
//! fiducial detection", IROS 2016; OpenCV `aruco_detector.cpp` (`markerBorderBits`).

use nalgebra::Point2;

use super::markers::consistency::{self, Placement};
use super::markers::{check_image, find_markers, CornerParams, MarkerParams, MarkerSet};
use super::{DetectError, ImageF32, MarkerDetection};
use synthcam_core::target::AprilGrid;

mod corners;

/// Parameters of [`find_aprilgrid`].
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct AprilGridParams {
    /// Tag search and decoding.
    pub markers: MarkerParams,
    /// Corner refinement.
    pub corners: CornerParams,
}

impl Default for AprilGridParams {
    /// [`MarkerParams::default`] and [`CornerParams::default`] with a saddle-fit half-window of
    /// up to 8 pixels (the uniform area around a tag corner, 2 border bits, is wider than
    /// ChArUco's white margin; the larger window averages more pixels).
    fn default() -> Self {
        Self { markers: MarkerParams::default(), corners: CornerParams { max_half_window: 8, ..CornerParams::default() } }
    }
}

/// A detected (possibly partial) AprilGrid.
#[derive(Debug, Clone, PartialEq, Default)]
pub struct AprilGridDetection {
    /// The grid's tags found, sorted by id; corners in Kalibr's order (bottom-left, bottom-right,
    /// top-right, top-left of the printed tag, as [`AprilGrid::tag_corners_m`]), from the
    /// tag outlines (not refined).
    pub tags: Vec<MarkerDetection>,
    /// Refined corner ids `4 k + c` (tag `k = id - first_id`, corner `c` in Kalibr's order; the
    /// indices of [`AprilGrid::corners_by_id_m`]), ascending.
    pub ids: Vec<u32>,
    /// Corner positions, pixels, in the order of `ids`.
    pub corners_px: Vec<Point2<f64>>,
}

/// Kalibr corner `c` of a tag is decoded corner `KALIBR_FROM_DECODED[c]` (and vice versa).
const KALIBR_FROM_DECODED: [usize; 4] = [1, 0, 3, 2];

/// Detect the tags and tag corners of `grid` in `img` (see the module docs). Parts of the grid
/// may be hidden or outside the image; an image without the grid gives an empty detection.
/// Non-finite samples are read as black by the search and make the fits near them fail.
///
/// # Errors
/// [`DetectError::EmptyImage`], [`DetectError::BadBuffer`] (buffer and size disagree) and
/// [`DetectError::BadParams`] (invalid parameters, or a grid that fails [`AprilGrid::validate`]).
pub fn find_aprilgrid(img: &ImageF32, grid: &AprilGrid, params: &AprilGridParams) -> Result<AprilGridDetection, DetectError> {
    check_image(img)?;
    grid.validate().map_err(|_| DetectError::BadParams { reason: "the grid fails AprilGrid::validate" })?;
    params.corners.validate()?;
    let [nx, ny] = grid.tags;
    let set = MarkerSet {
        dictionary: grid.family,
        border_bits: grid.border_bits,
        first_id: grid.first_id,
        count: nx * ny,
        margin_rate: grid.spacing,
        touching_corners: true,
    };
    let found: Vec<MarkerDetection> = find_markers(img, &set, &params.markers)?
        .into_iter()
        .map(|m| MarkerDetection { id: m.id, corners_px: KALIBR_FROM_DECODED.map(|k| m.corners_px[k]) })
        .collect();
    let place = |id: u32| {
        let k = id.checked_sub(grid.first_id).filter(|k| *k < nx * ny)?;
        Some(Placement { cell: [i64::from(k % nx), i64::from(k / nx)], corners_m: grid.tag_corners_m(k).map(|c| Point2::new(c.x, c.y)) })
    };
    let tags = consistency::filter(found, grid.tag_m, place);
    let (ids, corners_px) = corners::refine(img, grid, &tags, &params.corners);
    Ok(AprilGridDetection { tags, ids, corners_px })
}

#[cfg(test)]
mod tests;
