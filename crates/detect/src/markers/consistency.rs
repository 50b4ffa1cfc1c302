//! Target-consistency check of decoded markers: the homography of a marker's own four corners
//! (target plane to image) must predict the corners of at least one detected marker within two
//! cells of it on the target, within a quarter of its side. A marker with detected neighbours
//! that agrees with none of them (a wrong id, or a misread quad) is dropped; an isolated marker
//! is kept.
//!
//! Reference: the same idea as OpenCV's `CharucoDetector` filtering of markers against the
//! board layout (`filterCornersWithoutMinMarkers`) and `refineDetectedMarkers` (reprojection of
//! the board to find and validate markers); Kalibr's AprilGrid observation checks
//! (`GridCalibrationTargetAprilgrid::computeObservation`).

use nalgebra::{Matrix3, Point2, Vector3};

use super::decode::square_to_quad;
use super::MarkerDetection;

/// Largest prediction error of a neighbour's corner, as a fraction of the marker's side.
const TOLERANCE: f64 = 0.25;
/// Neighbours are detected markers at most this many cells away (either axis).
const REACH: i64 = 2;

/// Where a marker sits on its target: its cell `[x, y]` on the target's marker grid and its
/// corners on the target plane, metres, in the order of the detection's corners; corner `c` must
/// be `corner0 + side * u_c` with `u` = (0, 0), (1, 0), (1, 1), (0, 1).
#[derive(Debug, Clone, Copy, PartialEq)]
pub(crate) struct Placement {
    /// Cell on the marker grid.
    pub cell: [i64; 2],
    /// Corners on the target plane, metres.
    pub corners_m: [Point2<f64>; 4],
}

/// The markers (sorted by id) that are consistent with their detected neighbours; `place` gives
/// each id's placement (`None`: not on the target, dropped), `side_m` the marker side.
pub(crate) fn filter(markers: Vec<MarkerDetection>, side_m: f64, place: impl Fn(u32) -> Option<Placement>) -> Vec<MarkerDetection> {
    let placed: Vec<Option<Placement>> = markers.iter().map(|m| place(m.id)).collect();
    let fits: Vec<Option<Matrix3<f64>>> = markers
        .iter()
        .zip(&placed)
        .map(|(m, e)| {
            // target plane -> unit square (the marker's square, corner 0 at the origin) -> image
            let c0 = e.as_ref()?.corners_m[0];
            let to_unit = Matrix3::new(1.0 / side_m, 0.0, -c0.x / side_m, 0.0, 1.0 / side_m, -c0.y / side_m, 0.0, 0.0, 1.0);
            Some(square_to_quad(&m.corners_px)? * to_unit)
        })
        .collect();
    let keep: Vec<bool> = (0..markers.len())
        .map(|i| {
            let (Some(h), Some(e)) = (fits[i], placed[i]) else { return false };
            let side = (0..4).map(|k| (markers[i].corners_px[(k + 1) % 4] - markers[i].corners_px[k]).norm()).sum::<f64>() / 4.0;
            let mut neighbours = (0..markers.len())
                .filter(|&j| j != i)
                .filter_map(|j| Some((j, placed[j]?)))
                .filter(|(_, o)| (o.cell[0] - e.cell[0]).abs() <= REACH && (o.cell[1] - e.cell[1]).abs() <= REACH);
            let mut any = false;
            let agrees = neighbours.any(|(j, o)| {
                any = true;
                o.corners_m.iter().zip(&markers[j].corners_px).all(|(b, px)| {
                    let p = h * Vector3::new(b.x, b.y, 1.0);
                    (Point2::new(p.x / p.z, p.y / p.z) - px).norm() <= TOLERANCE * side
                })
            });
            agrees || !any
        })
        .collect();
    markers.into_iter().zip(keep).filter(|(_, k)| *k).map(|(m, _)| m).collect()
}
