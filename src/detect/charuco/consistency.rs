//! Board-consistency check of the decoded markers: the homography of a marker's own four corners
//! (board to image) must predict the corners of at least one detected marker within two squares
//! of it, within a quarter of its side. A marker with detected neighbours that agrees with none
//! of them (a wrong id, or a misread quad) is dropped; an isolated marker is kept.
//!
//! Reference: the same idea as OpenCV's `CharucoDetector` filtering of markers against the
//! board layout (`filterCornersWithoutMinMarkers`) and `refineDetectedMarkers` (reprojection of
//! the board to find and validate markers).

use nalgebra::{Matrix3, Point2};

use super::decode::square_to_quad;

use super::MarkerDetection;
use crate::target::Charuco;

/// Largest prediction error of a neighbour's corner, as a fraction of the marker's side.
const TOLERANCE: f64 = 0.25;
/// Neighbours are detected markers at most this many squares away (either axis).
const REACH: i64 = 2;

/// The markers (sorted by id) that are consistent with their detected neighbours.
pub(super) fn filter(markers: Vec<MarkerDetection>, board: &Charuco) -> Vec<MarkerDetection> {
    let layout = board.markers();
    let entry = |m: &MarkerDetection| layout.get(m.id.checked_sub(board.first_id)? as usize);
    let fits: Vec<Option<Matrix3<f64>>> = markers
        .iter()
        .map(|m| {
            // board -> unit square (the marker's square, corner 0 at its top-left) -> image
            let (c0, side) = (entry(m)?.corners_m[0], board.marker_m);
            let to_unit = Matrix3::new(1.0 / side, 0.0, -c0.x / side, 0.0, 1.0 / side, -c0.y / side, 0.0, 0.0, 1.0);
            Some(square_to_quad(&m.corners_px)? * to_unit)
        })
        .collect();
    let keep: Vec<bool> = (0..markers.len())
        .map(|i| {
            let (Some(h), Some(e)) = (fits[i], entry(&markers[i])) else { return false };
            let side = (0..4).map(|k| (markers[i].corners_px[(k + 1) % 4] - markers[i].corners_px[k]).norm()).sum::<f64>() / 4.0;
            let mut neighbours = (0..markers.len()).filter(|&j| j != i).filter_map(|j| Some((j, entry(&markers[j])?))).filter(|(_, o)| {
                let d = |a: u32, b: u32| (i64::from(a) - i64::from(b)).abs();
                d(o.square[0], e.square[0]) <= REACH && d(o.square[1], e.square[1]) <= REACH
            });
            let mut any = false;
            let agrees = neighbours.any(|(j, o)| {
                any = true;
                o.corners_m.iter().zip(&markers[j].corners_px).all(|(b, px)| {
                    let p = h * nalgebra::Vector3::new(b.x, b.y, 1.0);
                    (Point2::new(p.x / p.z, p.y / p.z) - px).norm() <= TOLERANCE * side
                })
            });
            agrees || !any
        })
        .collect();
    markers.into_iter().zip(keep).filter(|(_, k)| *k).map(|(m, _)| m).collect()
}
