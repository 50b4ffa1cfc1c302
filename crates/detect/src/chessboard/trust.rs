//! Whether a found board and its corners can be trusted: the steps along its rows and columns
//! (no corner twice, no skipped square), each corner's own fit (its position sigma), and which
//! untrusted corners a calibration should leave out.

use nalgebra::Point2;

use super::ChessboardCorners;

impl ChessboardCorners {
    /// Indices of the corners whose own fit cannot place them within `tolerance_px` (at two
    /// standard deviations): the fit failed, its window had to reach the neighbouring corners
    /// (squares under 5 px across), or its residuals leave the position that uncertain. Which of
    /// them a calibration should leave out: [`corners_to_leave_out`].
    pub fn untrusted(&self, tolerance_px: f64) -> Vec<usize> {
        (0..self.points_px.len()).filter(|&k| !(2.0 * self.position_sigma_px.get(k).copied().unwrap_or(f64::INFINITY) <= tolerance_px)).collect()
    }
}

/// The accuracy a corner must be placed to, pixels, to be trusted ([`ChessboardCorners::untrusted`]).
pub const TRUSTED_CORNER_PX: f64 = 0.1;

/// Of the `untrusted` points of one view, those a calibration should leave out: the ones whose
/// fit failed (infinite or missing sigma) and those far less certain than the rest of their view
/// (`position_sigma_px` above [`OUTLIER_SIGMA_FACTOR`] times the view's median). A view whose
/// corners are all uncertain alike (a blurred, noisy or over-exposed photo: its corners scatter
/// by a few tenths of a pixel) keeps them: their scatter shows in the calibration's residuals and
/// uncertainties, while one corner an order worse than its neighbours (a board edge-on at the
/// border of a fisheye's field) would pull the whole fit.
pub fn corners_to_leave_out(position_sigma_px: &[f64], untrusted: &[usize]) -> Vec<usize> {
    let mut finite: Vec<f64> = position_sigma_px.iter().copied().filter(|s| s.is_finite()).collect();
    finite.sort_by(f64::total_cmp);
    let median = finite.get(finite.len() / 2).copied().unwrap_or(f64::INFINITY);
    untrusted.iter().copied().filter(|&k| position_sigma_px.get(k).is_none_or(|s| !s.is_finite() || *s > OUTLIER_SIGMA_FACTOR * median)).collect()
}

/// A corner's sigma this many times its view's median makes it an outlier
/// ([`corners_to_leave_out`]).
pub const OUTLIER_SIGMA_FACTOR: f64 = 3.0;

/// The board when no two corners coincide and every pair of consecutive steps along its rows and
/// columns differ by less than a factor [`MAX_STEP_RATIO`]: a one-to-one lens maps the evenly spaced corners of a line to
/// points whose spacing changes smoothly, so neighbouring steps stay within a small factor of
/// each other even where the outer squares are compressed to a fraction of the centre's; a
/// corner reported twice, or a grid that skipped a square, breaks it.
pub(super) fn even_steps(b: ChessboardCorners) -> Option<ChessboardCorners> {
    let (c, r) = (b.cols, b.rows);
    let at = |row: usize, col: usize| b.points_px[row * c + col];
    let ok = |p: Point2<f64>, q: Point2<f64>, s: Point2<f64>| {
        let (d1, d2) = ((q - p).norm(), (s - q).norm());
        d1.min(d2) * MAX_STEP_RATIO >= d1.max(d2)
    };
    let rows_ok = (0..r).all(|row| (1..c.saturating_sub(1)).all(|k| ok(at(row, k - 1), at(row, k), at(row, k + 1))));
    let cols_ok = (0..c).all(|col| (1..r.saturating_sub(1)).all(|k| ok(at(k - 1, col), at(k, col), at(k + 1, col))));
    // no corner on top of another one (the 4-neighbour steps above do not see a diagonal twin)
    let distinct = (0..r * c).all(|k| {
        let (row, col) = (k / c, k % c);
        let nb = [(row.wrapping_sub(1), col), (row + 1, col), (row, col.wrapping_sub(1)), (row, col + 1)];
        let step = nb.iter().filter(|&&(y, x)| y < r && x < c).map(|&(y, x)| (at(y, x) - at(row, col)).norm()).fold(f64::INFINITY, f64::min);
        (k + 1..r * c).all(|m| (b.points_px[m] - b.points_px[k]).norm() >= MIN_SEPARATION_FRAC * step)
    });
    if rows_ok && cols_ok && distinct {
        Some(b)
    } else {
        log::debug!("board rejected: uneven steps along a row or column (a corner twice, or a skipped square)");
        None
    }
}

/// Largest ratio of two consecutive steps along a row or column of a found board (a larger one
/// rejects it: a corner reported twice, or a skipped square).
pub const MAX_STEP_RATIO: f64 = 3.0;

/// Two corners of a board are at least this fraction of the shorter one's shortest 4-neighbour
/// step apart (a sheared cell's short diagonal is about half a step at 60 degrees of shear).
const MIN_SEPARATION_FRAC: f64 = 0.25;
