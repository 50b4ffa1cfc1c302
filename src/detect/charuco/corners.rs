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
//! The prediction is refined by [`refine_saddle`] with the edge directions of the board axes at
//! the corner (the homography's Jacobian). The white margin around the corner (`(square -
//! marker) / 2` on the board) is the locally uniform area the fit window must stay in: with `A`
//! the inverse of the Jacobian scaled by the margin, the largest axis-aligned image square in it
//! has half-size `h_max = min_rows 1 / (|a_r0| + |a_r1|)`; the window half-size is
//! `floor(h_max - 1)` (room for the rounded window centre and the pixel footprint), at least 2
//! and at most `max_half_window`; a corner with `h_max` below 2.5 pixels (where even the
//! smallest window would reach well into the marker borders) is dropped. A refined corner is dropped
//! when the fit fails (window leaving the image, divergence), moves more than
//! `max_corner_shift_rate * h_max` or `max_corner_shift_px` from the prediction, has the wrong
//! amplitude sign, too little contrast or an RMS residual above `max_fit_residual_rate` of the
//! amplitude (clutter in the window), or edge directions more than 15 degrees off the prediction.
//!
//! Reference: OpenCV `modules/objdetect/src/aruco/charuco_detector.cpp`
//! (`interpolateCornersCharucoLocalHom`, `_selectAndRefineChessboardCorners`).

use nalgebra::{Matrix2, Matrix3, Point2, Vector2, Vector3};
use rayon::prelude::*;

use super::{CharucoParams, MarkerDetection};
use crate::detect::par::worth_parallel;
use crate::detect::{refine_saddle, ImageF32, SaddleFitParams};
use crate::math::homography::homography;
use crate::target::Charuco;

/// Smallest image size of the white margin around a corner (`h_max`, see the module docs) for
/// a fit, pixels.
const MIN_MARGIN_PX: f64 = 2.5;
/// Largest sine of the angle between a fitted edge and its predicted direction.
const MAX_EDGE_SINE: f64 = 0.26;

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
pub(super) fn interpolate(img: &ImageF32, board: &Charuco, markers: &[MarkerDetection], params: &CharucoParams) -> (Vec<u32>, Vec<Point2<f64>>) {
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
fn corner(img: &ImageF32, layout: &Layout, markers: &[MarkerDetection], (i, j): (i64, i64), params: &CharucoParams) -> Option<Point2<f64>> {
    let set = layout.markers_for(i, j);
    if set.len() < 2 {
        return None;
    }
    let board = layout.board;
    let src: Vec<Point2<f64>> = set.iter().flat_map(|&k| layout.corners_m[k]).collect();
    let dst: Vec<Point2<f64>> = set.iter().flat_map(|&k| markers[k].corners_px).collect();
    let h = homography(&src, &dst)?;
    let side = dst.chunks_exact(4).map(|q| (0..4).map(|k| (q[(k + 1) % 4] - q[k]).norm()).sum::<f64>() / 4.0).sum::<f64>() / set.len() as f64;
    let rms = (src.iter().zip(&dst).map(|(s, d)| (apply(&h, *s) - d).norm_squared()).sum::<f64>() / src.len() as f64).sqrt();
    if !(rms <= params.max_homography_rms_rate * side) {
        return None;
    }
    let c = Point2::new(i as f64 * board.square_m, j as f64 * board.square_m);
    let (p, jac) = (apply(&h, c), jacobian(&h, c));
    let margin = 0.5 * (board.square_m - board.marker_m);
    let a = (jac * margin).try_inverse()?;
    let h_max = (0..2).map(|r| 1.0 / (a[(r, 0)].abs() + a[(r, 1)].abs())).fold(f64::INFINITY, f64::min);
    if !(h_max >= MIN_MARGIN_PX) {
        return None;
    }
    let hw = ((h_max - 1.0).floor() as usize).clamp(2, params.max_half_window);
    let fp = SaddleFitParams {
        half_window: hw,
        fast_half_window: params.refine.fast_half_window.min(hw),
        max_shift_px: (params.max_corner_shift_rate * h_max).min(params.max_corner_shift_px),
        ..params.refine
    };
    let (dx, dy) = (jac.column(0).into_owned(), jac.column(1).into_owned());
    let fit = refine_saddle(img, p, dx, dy, &fp).ok()?;
    // the bottom-left square (i - 1, j) is light when it holds a marker
    let light = board.has_marker((i - 1) as u32, j as u32);
    let towards_bottom_left = jac * Vector2::new(-0.5 * margin, 0.5 * margin);
    let side_of = |t: f64| Vector2::new(-t.sin(), t.cos()).dot(&towards_bottom_left).signum();
    let sign_ok = (fit.amplitude * side_of(fit.angles[0]) * side_of(fit.angles[1]) > 0.0) == light;
    let edge_ok = |t: f64, d: &Vector2<f64>| Vector2::new(t.cos(), t.sin()).perp(&d.normalize()).abs() <= MAX_EDGE_SINE;
    let fit_ok = 2.0 * fit.amplitude.abs() >= params.min_contrast && fit.rms_residual <= params.max_fit_residual_rate * fit.amplitude.abs();
    let ok = sign_ok && fit_ok && edge_ok(fit.angles[0], &dx) && edge_ok(fit.angles[1], &dy);
    ok.then_some(fit.point)
}

/// `h` applied to a point.
fn apply(h: &Matrix3<f64>, p: Point2<f64>) -> Point2<f64> {
    let v = h * Vector3::new(p.x, p.y, 1.0);
    Point2::new(v.x / v.z, v.y / v.z)
}

/// Jacobian of the map of `h` at `p` (columns: image derivatives along board x and y).
fn jacobian(h: &Matrix3<f64>, p: Point2<f64>) -> Matrix2<f64> {
    let v = h * Vector3::new(p.x, p.y, 1.0);
    let (u, w) = (Vector2::new(v.x, v.y), v.z);
    let col = |k: usize| (Vector2::new(h[(0, k)], h[(1, k)]) - u * (h[(2, k)] / w)) / w;
    Matrix2::from_columns(&[col(0), col(1)])
}
