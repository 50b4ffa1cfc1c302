//! ChArUco corners by local homographies (OpenCV's `interpolateCornersCharucoLocalHom`) and the
//! saddle-model fit.
//!
//! Marker rule: an inner corner is interpolated when a detected marker sits in one of its four
//! adjacent squares. The homography (board plane to image) is fitted to the corners of the
//! adjacent detected markers when there are two; with one, the nearest other detected marker
//! whose square centre lies within 2.5 squares of the corner (either axis) joins it; a corner
//! with fewer than two markers (8 point pairs) is skipped. A fit whose RMS residual exceeds
//! `max_homography_rms_rate` of the marker side is refused.
//!
//! The prediction is refined by [`refine_junction`] (see `markers::corners`) in a window kept
//! out of the two markers next to the corner ([`Area::Inset`]: the white margin,
//! `(square - marker) / 2` on the board, runs along both edges of each light square, and the
//! dark squares are uniform to their far side), so that a tilted or rolled board, whose margin
//! square around the corner is thin or turned in the image, keeps a window of 5 x 5 pixels or
//! more; where even that reaches into a marker, its pixels there read as the light square. The
//! sign is checked on the bottom-left square (light when it holds a marker).
//!
//! Reference: OpenCV `modules/objdetect/src/aruco/charuco_detector.cpp`
//! (`interpolateCornersCharucoLocalHom`, `_selectAndRefineChessboardCorners`).

use nalgebra::{Point2, Vector2};
use rayon::prelude::*;

use crate::markers::corners::{local_homography, refine_junction, Area, CornerParams, Junction};
use crate::markers::Samples;
use crate::par::worth_parallel;
use crate::MarkerDetection;
use synthcam_core::target::Charuco;

/// The board with its detected markers indexed by square.
struct Layout<'a> {
    board: &'a Charuco,
    /// Board corners (x, y), metres, of each detected marker.
    corners_m: Vec<[Point2<f64>; 4]>,
    /// Square of each detected marker.
    squares: Vec<[i64; 2]>,
    /// Index of the detected marker in each square (row-major), if any.
    at: Vec<Option<usize>>,
}

impl<'a> Layout<'a> {
    fn new(board: &'a Charuco, markers: &[MarkerDetection]) -> Self {
        let layout = board.markers();
        let [nx, ny] = board.squares;
        let mut at = vec![None; nx as usize * ny as usize];
        let (mut corners_m, mut squares) = (Vec::new(), Vec::new());
        for (k, m) in markers.iter().enumerate() {
            let Some(e) = m.id.checked_sub(board.first_id).and_then(|i| layout.get(i as usize)) else { continue };
            at[(e.square[1] * nx + e.square[0]) as usize] = Some(k);
            corners_m.push(e.corners_m.map(|c| Point2::new(c.x, c.y)));
            squares.push([i64::from(e.square[0]), i64::from(e.square[1])]);
        }
        // `corners_m` / `squares` are indexed like `markers` only if every marker is on the board,
        // which `decode` guarantees; otherwise use none.
        if corners_m.len() != markers.len() {
            return Self { board, corners_m: Vec::new(), squares: Vec::new(), at: vec![None; at.len()] };
        }
        Self { board, corners_m, squares, at }
    }

    /// Detected marker in square `(x, y)`.
    fn marker(&self, x: i64, y: i64) -> Option<usize> {
        let [nx, ny] = self.board.squares;
        if x < 0 || y < 0 || x >= i64::from(nx) || y >= i64::from(ny) {
            return None;
        }
        self.at[(y * i64::from(nx) + x) as usize]
    }

    /// The markers of corner `(i, j)`'s homography (see the module docs).
    fn markers_for(&self, i: i64, j: i64) -> Vec<usize> {
        let mut set: Vec<usize> = [(i - 1, j - 1), (i, j - 1), (i - 1, j), (i, j)].iter().filter_map(|&(x, y)| self.marker(x, y)).collect();
        if set.len() == 1 {
            let d2 = |k: usize| {
                let [x, y] = self.squares[k];
                (2 * x + 1 - 2 * i).pow(2) + (2 * y + 1 - 2 * j).pow(2)
            };
            let near = (i - 3..=i + 2).flat_map(|x| (j - 3..=j + 2).filter_map(move |y| self.marker(x, y))).filter(|k| !set.contains(k)).min_by_key(|&k| d2(k));
            set.extend(near);
        }
        set
    }
}

/// The refined corners: ids ascending and positions.
pub(super) fn interpolate<I: Samples + ?Sized>(img: &I, board: &Charuco, markers: &[MarkerDetection], params: &CornerParams) -> (Vec<u32>, Vec<Point2<f64>>) {
    let layout = Layout::new(board, markers);
    let [nx, ny] = board.squares;
    let jobs: Vec<(u32, i64, i64)> =
        (1..i64::from(ny)).flat_map(|j| (1..i64::from(nx)).map(move |i| (((j - 1) * (i64::from(nx) - 1) + i - 1) as u32, i, j))).collect();
    let job = |&(id, i, j): &(u32, i64, i64)| Some((id, corner(img, &layout, markers, (i, j), params)?));
    let found: Vec<(u32, Point2<f64>)> = if worth_parallel(jobs.len(), params.parallel_min_corners.max(1)) {
        jobs.par_iter().filter_map(job).collect()
    } else {
        jobs.iter().filter_map(job).collect()
    };
    found.into_iter().unzip()
}

/// Corner `(i, j)` (board point `(i s, j s)`), refined; `None` when it is not measurable.
fn corner<I: Samples + ?Sized>(img: &I, layout: &Layout, markers: &[MarkerDetection], (i, j): (i64, i64), params: &CornerParams) -> Option<Point2<f64>> {
    let set = layout.markers_for(i, j);
    if set.len() < 2 {
        return None;
    }
    let board = layout.board;
    let src: Vec<Point2<f64>> = set.iter().flat_map(|&k| layout.corners_m[k]).collect();
    let dst: Vec<Point2<f64>> = set.iter().flat_map(|&k| markers[k].corners_px).collect();
    let h = local_homography(&src, &dst, params)?;
    let margin_m = 0.5 * (board.square_m - board.marker_m);
    // the bottom-left square (i - 1, j) is light when it holds a marker
    let probe_light = board.has_marker((i - 1) as u32, j as u32);
    let junction = Junction {
        h,
        c: Point2::new(i as f64 * board.square_m, j as f64 * board.square_m),
        margin_m,
        // the light squares are (i - 1, j) and (i, j - 1), or (i - 1, j - 1) and (i, j)
        area: Area::Inset { light: if probe_light { [-1.0, 1.0] } else { [1.0, 1.0] }, square_m: board.square_m },
        probe_m: Vector2::new(-0.5 * margin_m, 0.5 * margin_m),
        probe_light,
        seed_px: None,
        predicted: false,
    };
    refine_junction(img, &junction, params)
}
