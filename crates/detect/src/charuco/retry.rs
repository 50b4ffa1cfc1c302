//! Full-resolution retry of the marker search. The candidate search runs at half resolution on
//! large images, where markers below about 16 px (5x5 codes: a 1-cell black border and a white
//! margin of about 2 px, less on a tilted board) merge with the black squares around them or
//! lose their border. After that pass, the board's homography (fitted to the corners of the
//! markers decoded, at least two: 8 point pairs, as the corner interpolation) predicts every
//! other marker of the board; the markers predicted wholly inside the image with a perimeter the
//! search accepts are the ones the board's geometry implies. When any of them was not decoded,
//! the search runs again at full resolution in the bounding box of their predicted outlines,
//! padded by one predicted square (the homography of markers at one end of a tilted board,
//! under lens distortion, predicts the other end only within a fraction of a square) plus the
//! threshold window; with fewer than two markers decoded there is no prediction and the retry
//! searches the whole image. Markers that are decoded stay as they are: candidates centred
//! inside them are not decoded again.
//!
//! The retry thresholds with one window chosen from the expected marker size: reaching one code
//! cell to each side (`2 floor(c) + 1` pixels, `c` the median predicted side of the missing
//! markers over the cells across a marker, border included; 3 at least, and the whole-image
//! retry uses the smallest window allowed for markers at the smallest perimeter searched). A
//! pixel of the black border then always sees the white margin or the code in its window, and
//! the black squares' interiors, whose windows see only black, stay light: the thin margins
//! between small markers and the squares around them are not bridged, which wider windows do
//! on foreshortened boards.
//!
//! Reference: OpenCV's `refineDetectedMarkers` (the board's reprojection predicts the markers
//! the first search missed) and `ArucoDetector` with `useAruco3Detection` (the search image's
//! resolution chosen from the smallest expected marker).

use nalgebra::Point2;

use crate::markers::corners::{apply, homography};
use crate::markers::{MarkerParams, Window};
use crate::MarkerDetection;
use synthcam_core::target::Charuco;

/// Predicted corners must lie at least this far inside the image, pixels (the candidate search
/// drops components touching the border, the outline fit samples across each side).
const INSIDE_PX: f64 = 2.0;

/// The full-resolution retry: where and with which threshold window.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub(super) struct Retry {
    /// Part of the image searched.
    pub window: Window,
    /// Side of the adaptive-threshold window, pixels.
    pub threshold_px: usize,
}

/// Threshold window reaching one code cell of a marker of mean side `side_px` to each side.
fn threshold_px(side_px: f64, cells: usize) -> usize {
    let c = (side_px / cells as f64).floor();
    if c.is_finite() {
        2 * (c.clamp(1.0, 1e4) as usize) + 1
    } else {
        3
    }
}

/// The full-resolution retry, `None` when every marker the decoded ones imply was decoded
/// (`markers`: the board's markers found, consistent, sorted by id).
pub(super) fn plan((width, height): (usize, usize), board: &Charuco, markers: &[MarkerDetection], params: &MarkerParams) -> Option<Retry> {
    let cells = board.dictionary.marker_bits() + 2;
    let whole = Retry { window: Window { x0: 0, y0: 0, x1: width, y1: height }, threshold_px: threshold_px(params.min_marker_perimeter_px / 4.0, cells) };
    let layout = board.markers();
    let placed: Vec<(&MarkerDetection, [Point2<f64>; 4])> = markers
        .iter()
        .filter_map(|m| {
            let e = layout.get(m.id.checked_sub(board.first_id)? as usize)?;
            Some((m, e.corners_m.map(|c| Point2::new(c.x, c.y))))
        })
        .collect();
    if placed.len() < 2 {
        return Some(whole);
    }
    let src: Vec<Point2<f64>> = placed.iter().flat_map(|(_, c)| *c).collect();
    let dst: Vec<Point2<f64>> = placed.iter().flat_map(|(m, _)| m.corners_px).collect();
    let Some(h) = homography(&src, &dst) else { return Some(whole) };
    let (w, ht) = (width as f64, height as f64);
    let max_perimeter = params.max_marker_perimeter_rate * w.max(ht);
    let mut missing: Vec<[Point2<f64>; 4]> = Vec::new();
    let mut sides: Vec<f64> = Vec::new();
    for e in &layout {
        if markers.iter().any(|m| m.id == e.id) {
            continue;
        }
        let q = e.corners_m.map(|c| apply(&h, Point2::new(c.x, c.y)));
        let inside = q.iter().all(|p| p.x >= INSIDE_PX && p.y >= INSIDE_PX && p.x <= w - 1.0 - INSIDE_PX && p.y <= ht - 1.0 - INSIDE_PX);
        let perimeter: f64 = (0..4).map(|k| (q[(k + 1) % 4] - q[k]).norm()).sum();
        if !(inside && perimeter >= params.min_marker_perimeter_px && perimeter <= max_perimeter) {
            continue;
        }
        missing.push(q);
        sides.push(0.25 * perimeter);
    }
    if missing.is_empty() {
        return None;
    }
    let mut sorted = sides.clone();
    sorted.sort_by(f64::total_cmp);
    let threshold = threshold_px(sorted[sorted.len() / 2], cells);
    let (mut lo, mut hi) = (Point2::new(f64::INFINITY, f64::INFINITY), Point2::new(f64::NEG_INFINITY, f64::NEG_INFINITY));
    for (q, side) in missing.iter().zip(&sides) {
        let pad = side * board.square_m / board.marker_m + threshold as f64;
        for p in q {
            lo = Point2::new(lo.x.min(p.x - pad), lo.y.min(p.y - pad));
            hi = Point2::new(hi.x.max(p.x + pad), hi.y.max(p.y + pad));
        }
    }
    let clamp = |v: f64, n: usize| if v.is_finite() { v.clamp(0.0, n as f64) as usize } else { 0 };
    let window =
        Window { x0: clamp(lo.x.floor(), width), y0: clamp(lo.y.floor(), height), x1: clamp(hi.x.ceil() + 1.0, width), y1: clamp(hi.y.ceil() + 1.0, height) };
    (window.x1 > window.x0 && window.y1 > window.y0).then_some(Retry { window, threshold_px: threshold })
}

#[cfg(test)]
mod tests {
    use nalgebra::Matrix3;

    use super::*;
    use synthcam_core::target::Dictionary;

    /// The board's markers seen through `h` (board metres to pixels).
    fn seen(board: &Charuco, h: &Matrix3<f64>) -> Vec<MarkerDetection> {
        board.markers().iter().map(|m| MarkerDetection { id: m.id, corners_px: m.corners_m.map(|c| apply(h, Point2::new(c.x, c.y))) }).collect()
    }

    #[test]
    fn retry_where_the_board_implies_missing_markers() {
        let board = Charuco { squares: [11, 8], square_m: 0.03, marker_m: 0.022, dictionary: Dictionary::Dict5x5_100, legacy: false, first_id: 0 };
        let params = MarkerParams::default();
        let size = (1280, 1024);
        // 800 px per metre, a little perspective: markers of about 17 px
        let h = Matrix3::new(800.0, 30.0, 400.0, -20.0, 780.0, 300.0, 0.2, -0.1, 1.0);
        let all = seen(&board, &h);
        assert_eq!(plan(size, &board, &all, &params), None);
        // fewer than two markers: the whole image, with the window of the smallest markers
        let whole = plan(size, &board, &all[..1], &params).unwrap();
        assert_eq!((whole.window, whole.threshold_px), (Window { x0: 0, y0: 0, x1: 1280, y1: 1024 }, 3));
        // marker 20 missing: a window around it, one square of padding plus the threshold window
        let missing: Vec<MarkerDetection> = all.iter().filter(|m| m.id != 20).copied().collect();
        let r = plan(size, &board, &missing, &params).unwrap();
        let q = all[20].corners_px;
        for p in q {
            assert!(
                p.x > r.window.x0 as f64 + 20.0 && p.x < r.window.x1 as f64 - 20.0 && p.y > r.window.y0 as f64 + 20.0 && p.y < r.window.y1 as f64 - 20.0,
                "{p} outside {:?}",
                r.window
            );
        }
        assert!(r.window.x1 - r.window.x0 < 120 && r.window.y1 - r.window.y0 < 120, "{:?}", r.window);
        // markers of about 17 px over 7 cells: a window of 2 * 2 + 1
        assert_eq!(r.threshold_px, 5);
        // a missing marker outside the image is not implied
        let far = Matrix3::new(800.0, 0.0, -150.0, 0.0, 800.0, 300.0, 0.0, 0.0, 1.0);
        let cut: Vec<MarkerDetection> = seen(&board, &far).into_iter().filter(|m| m.corners_px.iter().all(|p| p.x >= 2.0)).collect();
        assert!(cut.len() < 44 && cut.len() > 2);
        assert_eq!(plan(size, &board, &cut, &params), None);
    }
}
