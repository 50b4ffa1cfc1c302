//! The sub-pixel stage: every corner of a found grid refined by the saddle fit, its window from
//! the local grid step and kept inside the image.

use nalgebra::{Point2, Vector2};

use super::super::par::map_indexed;
use super::super::saddle_fit::{refine_saddle, SaddleFitParams};
use super::{ChessboardCorners, ChessboardParams, GreyWindow};

/// Refine every corner with the saddle fit; window from the local grid step.
pub(super) fn refine_all(
    img: &impl GreyWindow,
    g: Vec<Vec<Point2<f64>>>,
    params: &ChessboardParams,
    candidates: usize,
    seeds_tried: usize,
) -> ChessboardCorners {
    let (rows, cols) = (params.rows, params.cols);
    let at = |r: usize, c: usize| g[r][c];
    let job = |k: usize| {
        let (r, c) = (k / cols, k % cols);
        let p = at(r, c);
        let d_row: Vector2<f64> = if c + 1 < cols { at(r, c + 1) - p } else { p - at(r, c - 1) };
        let d_col: Vector2<f64> = if r + 1 < rows { at(r + 1, c) - p } else { p - at(r - 1, c) };
        let mut step = d_row.norm().min(d_col.norm());
        if c > 0 {
            step = step.min((p - at(r, c - 1)).norm());
        }
        if r > 0 {
            step = step.min((p - at(r - 1, c)).norm());
        }
        let wanted = (params.window_frac * step).floor() as usize;
        let fp = SaddleFitParams { half_window: fit_half_window(img, p, step, params.window_frac, params.refine.half_window), ..params.refine };
        match refine_saddle(img, p, d_row, d_col, &fp) {
            // a window wider than the geometry allows holds parts of the neighbouring corners
            Ok(f) => (f.point, true, f.rms_residual, if wanted >= 2 { f.position_sigma_px } else { f64::INFINITY }),
            Err(_) => (p, false, 0.0, f64::INFINITY),
        }
    };
    let n = rows * cols;
    let res: Vec<(Point2<f64>, bool, f64, f64)> = map_indexed(n, params.parallel_min_corners, job);
    let nref = res.iter().filter(|r| r.1).count();
    let rms = if nref > 0 { (res.iter().filter(|r| r.1).map(|r| r.2 * r.2).sum::<f64>() / nref as f64).sqrt() } else { 0.0 };
    ChessboardCorners {
        points_px: res.iter().map(|r| r.0).collect(),
        cols,
        rows,
        refined: res.iter().map(|r| r.1).collect(),
        position_sigma_px: res.iter().map(|r| r.3).collect(),
        rms_fit_residual: rms,
        candidates,
        seeds_tried,
    }
}

/// The saddle fit's half-window at `p` for a local grid step `step`: `frac` of the step (2 to
/// `max_hw` pixels), kept inside the image ([`inside_window`]). One rule for the refinement of
/// found grids and the validation of completed corners.
pub(crate) fn fit_half_window(img: &impl GreyWindow, p: Point2<f64>, step: f64, frac: f64, max_hw: usize) -> usize {
    inside_window(img, p, ((frac * step).floor() as usize).clamp(2, max_hw.max(2)))
}

/// The fit half-window `hw` at `p`, shrunk (to no less than 2) so the window stays inside the
/// image: a corner a few pixels from the border is fitted on what the image holds of it.
fn inside_window(img: &impl GreyWindow, p: Point2<f64>, hw: usize) -> usize {
    let (cx, cy) = (p.x.round(), p.y.round());
    if !(cx.is_finite() && cy.is_finite()) {
        return hw;
    }
    let room = cx.min(cy).min(img.width() as f64 - 1.0 - cx).min(img.height() as f64 - 1.0 - cy);
    if room >= hw as f64 {
        hw
    } else {
        (room.max(0.0) as usize).max(2)
    }
}
