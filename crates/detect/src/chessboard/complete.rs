//! Structure recovery for the boards the fast path leaves incomplete: strong distortion (rows bent
//! into arcs, outer squares compressed to a fraction of the centre's), corners near the image
//! border or the dark image circle, uneven contrast (blooming, vignetting, glare).
//!
//! The fast path accepts a corner at the strongest saddle-response peak near its prediction when
//! the peak is strong relative to its neighbours; the response grows with the square of the
//! contrast, so a washed-out or compressed corner fails that test although it is plainly there.
//! Here the best partial grid grown at any pyramid level is carried to full resolution and
//! completed by the board's known size, each missing corner validated by what the image says
//! at it, not by how strong it is relative to others: a full-resolution saddle-model fit
//! ([`refine_saddle`]) must converge near the prediction, explain the window (small residual
//! against the light/dark amplitude), have its two edge lines along the grid's two directions,
//! give the X-junction the polarity the checkerboard parity demands, and cut the window into
//! four sectors that alternate light and dark (module `junction`: an L-junction at a board's
//! outer corner passes the rest). The fit starts from the grid's local extrapolations, then from
//! the saddle-response peak near them, then from the whole partial grid's homography through a
//! one-term lens (module `grid_lens`) and the peak near that: towards a fisheye's fold the
//! squares shrink so fast from row to row that the local extrapolations overshoot. Holes
//! inside the grid are filled first; then whole lines are added, one side at a time, a line
//! only when every corner on it validates. A completed grid that could be grown by one more
//! valid line on any side is part of a larger pattern and is rejected, as is any grid that
//! cannot be completed: a board is reported whole or not at all.
//!
//! One exception for holes: a saturated highlight (a glossy board under a lamp) can clip every
//! pixel around a corner, and then no image shows it. A hole inside the grid that nothing
//! validates and whose fit window is at least a quarter clipped (at the image's maximum) is
//! *blind*: it is placed at the grid's prediction (holes next to each other one after another)
//! and reported untrusted (infinite sigma: calibrations leave it out), so the rest of the board
//! is not lost. At most [`MAX_BLIND_FRACTION`] of the board's corners may be blind.
//!
//! Reference: A. Geiger, F. Moosmann, O. Car, B. Schuster, "Automatic camera and range sensor
//! calibration using a single shot", ICRA 2012 (structure recovery by growing a chessboard from
//! validated corners, neighbour predictions following curved rows); the prediction is the
//! grid's own ([`Grid::predict`]); the validating fit is the one every corner is refined with.

use std::sync::OnceLock;

use nalgebra::{Point2, Vector2};

use super::super::grid::Grid;
use super::super::markers::quads::Quad;
use super::super::response::local_peak;
use super::super::saddle_fit::{refine_saddle, SaddleFitParams};
use super::super::{GreyWindow, ImageF32};
use super::grid_lens::GridLens;
use super::junction::{fit_is_corner, quadrant_contrast};
use super::order::{orient, to_rows};
use super::quad_pair::{dark_quads, quad_pair_corner};
use super::refine::refine_all;
use super::{ChessboardCorners, ChessboardParams};

/// Smoothing of the saddle response whose peak is a completed corner's last guess (the fast
/// path's default, `ChessboardParams::smoothing_sigma_px`).
const RESPONSE_SIGMA_PX: f64 = 1.0;

/// The response peak a completed corner's fit may start from lies within this many fit
/// half-windows of the prediction.
const PEAK_WINDOWS: usize = 3;

/// Fit window of a completed corner: this fraction of the local step, as the refinement of
/// found grids (`ChessboardParams::window_frac`'s default).
const WINDOW_FRAC: f64 = 0.4;

/// What the validating fit must show, as fractions of the local grid step or of the fitted
/// amplitude (dimensionless, so they hold at any image scale and exposure).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct CompleteParams {
    /// The fitted corner may move at most this fraction of the local step from the prediction.
    pub max_shift_frac: f64,
    /// RMS residual of the fit at most this fraction of the fitted amplitude (half the
    /// light/dark difference): an L- or T-junction, a blob or clutter leave much more.
    pub max_residual_frac: f64,
    /// Each fitted edge line within this angle of one of the grid's two directions, degrees.
    pub max_angle_deg: f64,
    /// Fitted amplitude at least this many grey levels (half the light/dark difference).
    pub min_amplitude: f64,
    /// A corner whose local step is below this many pixels cannot be validated (the fit window
    /// would reach the neighbouring corners).
    pub min_step_px: f64,
    /// The fitted lines' four sectors must alternate: the darker light sector's mean grey above
    /// the lighter dark sector's by at least this fraction of the fitted contrast (Geiger et
    /// al.'s corner test, `quadrant_contrast`: about 1 at an X-junction, at most 0 at the
    /// L-junction of a board's outer corner, which the saddle fit alone can pass).
    pub min_quadrant_contrast: f64,
}

impl Default for CompleteParams {
    fn default() -> Self {
        Self { max_shift_frac: 0.35, max_residual_frac: 0.6, max_angle_deg: 30.0, min_amplitude: 4.0, min_step_px: 5.0, min_quadrant_contrast: 0.25 }
    }
}

/// The board completed from the partial grid `g` ([`complete`]), oriented and refined
/// ([`refine_all`]); its blind corners stay at their predictions, untrusted. Corners whose final
/// fit fails otherwise, or cannot place them within a pixel at two sigma ([`UNPLACED_SIGMA_PX`]),
/// came from the partial grid unvalidated (found at a coarser level, where
/// squares compressed to a pixel or two can put a corner on the wrong junction): their cells are
/// emptied and the grid completed once more, so that each is validated at full resolution like
/// any other completed corner, or the board is not reported.
pub(super) fn recovered<I: GreyWindow>(img: &I, full: &ImageF32, g: &Grid, params: &ChessboardParams) -> Option<ChessboardCorners> {
    let (dims, (refine, p)) = ((params.cols, params.rows), (&params.refine, &params.complete));
    let mut g = complete(img, full, g, dims, refine, p)?;
    for again in [true, false] {
        let blind = blind_points(&g);
        let grid = orient(to_rows(&g, params.cols, params.rows)?, params.cols, params.rows);
        let placed: Vec<Point2<f64>> = grid.iter().flatten().copied().collect();
        let mut corners = refine_all(img, grid, params, 0, 0);
        let unplaced = |k: usize| !corners.refined[k] || !(corners.position_sigma_px[k] <= UNPLACED_SIGMA_PX);
        let failed: Vec<Point2<f64>> = (0..placed.len()).filter(|&k| unplaced(k) && !blind.contains(&placed[k])).map(|k| placed[k]).collect();
        if again && !failed.is_empty() {
            log::debug!("completion: {} corners whose fit failed are placed again", failed.len());
            g.cells.retain(|_, q| !failed.contains(q));
            let Grid { cells, strength, .. } = &mut g;
            strength.retain(|k, _| cells.contains_key(k));
            g = complete(img, full, &g, dims, refine, p)?;
            continue;
        }
        for (k, q) in placed.iter().enumerate().filter(|(_, q)| blind.contains(q)) {
            (corners.points_px[k], corners.refined[k], corners.position_sigma_px[k]) = (*q, false, f64::INFINITY);
        }
        return Some(corners);
    }
    None
}

/// A corner whose final fit gives a larger position sigma, pixels, has not been found there
/// ([`recovered`]).
const UNPLACED_SIGMA_PX: f64 = 0.5;

/// Complete `g` (full-resolution positions) to `cols` x `rows` corners in either orientation.
/// Returns the completed grid, or `None` when it cannot be completed unambiguously.
fn complete<I: GreyWindow>(img: &I, full: &ImageF32, g: &Grid, (cols, rows): (usize, usize), refine: &SaddleFitParams, p: &CompleteParams) -> Option<Grid> {
    let cx = Ctx { img, full, refine, p, start: g, steps: steps(g), quads: OnceLock::new(), max: OnceLock::new(), lens: OnceLock::new() };
    let (i0, i1, j0, j1) = g.bounds()?;
    let (ni, nj) = (i1 - i0 + 1, j1 - j0 + 1);
    if ni < 3 || nj < 3 {
        return None;
    }
    let (c, r) = (cols as i32, rows as i32);
    let mut out = None;
    for (ti, tj) in [(c, r), (r, c)] {
        if ni > ti || nj > tj || (out.is_some() && c == r) {
            continue;
        }
        if let Some(done) = complete_to(&cx, g.clone(), (ti, tj)) {
            if out.is_some() {
                return None; // both orientations complete: ambiguous
            }
            out = Some(done);
        }
    }
    out
}

/// Complete to `ti` x `tj` (along i, j).
fn complete_to<I: GreyWindow>(cx: &Ctx<'_, I>, mut g: Grid, (ti, tj): (i32, i32)) -> Option<Grid> {
    fill_holes(cx, &mut g, (ti * tj) as usize)?;
    loop {
        let (i0, i1, j0, j1) = g.bounds()?;
        let (ni, nj) = (i1 - i0 + 1, j1 - j0 + 1);
        if ni == ti && nj == tj {
            break;
        }
        let sides = [(ni < ti, Side::I(i0 - 1)), (ni < ti, Side::I(i1 + 1)), (nj < tj, Side::J(j0 - 1)), (nj < tj, Side::J(j1 + 1))];
        let added = sides.iter().filter(|s| s.0).find_map(|&(_, side)| line(cx, &g, side));
        for (key, q) in added? {
            g.cells.insert(key, q);
            g.strength.insert(key, 0.0);
        }
    }
    let (i0, i1, j0, j1) = g.bounds()?;
    let beyond = [Side::I(i0 - 1), Side::I(i1 + 1), Side::J(j0 - 1), Side::J(j1 + 1)];
    if beyond.iter().any(|&side| line(cx, &g, side).is_some()) {
        return None; // a larger pattern (or the wrong extent of it)
    }
    Some(g)
}

/// A line of cells beside the grid: `I(k)` the cells (k, j) for every j of the grid, `J(k)` the
/// cells (i, k).
#[derive(Debug, Clone, Copy)]
enum Side {
    I(i32),
    J(i32),
}

/// A corner placed at a grid cell.
type Placed = ((i32, i32), Point2<f64>);

/// The strength a blind corner is marked with in its grid (module doc).
pub(super) const BLIND: f32 = f32::NEG_INFINITY;

/// At most this fraction of a board's corners may be blind.
pub const MAX_BLIND_FRACTION: f64 = 1.0 / 8.0;

/// At least this fraction of a blind corner's fit window is clipped.
const MIN_CLIPPED_FRACTION: f64 = 0.25;

/// The positions of `g`'s blind corners.
pub(super) fn blind_points(g: &Grid) -> Vec<Point2<f64>> {
    g.cells.iter().filter(|(k, _)| g.strength.get(k) == Some(&BLIND)).map(|(_, q)| *q).collect()
}

/// Fill every hole inside the grid's bounding box, validated, or blind (module doc); `None`
/// when one is neither.
fn fill_holes<I: GreyWindow>(cx: &Ctx<'_, I>, g: &mut Grid, board_corners: usize) -> Option<()> {
    let bounds = g.bounds()?;
    loop {
        let holes = empty_cells(g, bounds);
        if holes.is_empty() {
            return Some(());
        }
        let mut added = false;
        for (i, j) in holes {
            if let Some(q) = validated(cx, g, i, j) {
                g.cells.insert((i, j), q);
                g.strength.insert((i, j), 0.0);
                added = true;
            }
        }
        if !added {
            return fill_blind(cx, g, board_corners);
        }
    }
}

/// The cells of `g`'s bounding box `(i0, i1, j0, j1)` that hold no corner.
fn empty_cells(g: &Grid, (i0, i1, j0, j1): (i32, i32, i32, i32)) -> Vec<(i32, i32)> {
    (i0..=i1).flat_map(|i| (j0..=j1).map(move |j| (i, j))).filter(|k| !g.cells.contains_key(k)).collect()
}

/// Place the remaining holes of `g` at their predictions when every one is blind (module doc)
/// and they are few enough; `None` otherwise.
fn fill_blind<I: GreyWindow>(cx: &Ctx<'_, I>, g: &mut Grid, board_corners: usize) -> Option<()> {
    let mut holes = empty_cells(g, g.bounds()?);
    if holes.len() as f64 > MAX_BLIND_FRACTION * board_corners as f64 {
        return None;
    }
    let mut work = g.clone();
    while !holes.is_empty() {
        let before = holes.len();
        holes.retain(|&(i, j)| match work.predict(i, j) {
            Some((pred, step, ..)) if clipped_around(cx, pred, step) => {
                work.cells.insert((i, j), pred);
                work.strength.insert((i, j), BLIND);
                false
            }
            _ => true,
        });
        if holes.len() == before {
            return None;
        }
    }
    log::debug!("completion: {} blind (clipped) corners placed at their predictions, untrusted", blind_points(&work).len());
    *g = work;
    Some(())
}

/// Whether at least [`MIN_CLIPPED_FRACTION`] of the fit window at `p` is at the image's maximum.
fn clipped_around<I: GreyWindow>(cx: &Ctx<'_, I>, p: Point2<f64>, step: f64) -> bool {
    let full = cx.full;
    let max = *cx.max.get_or_init(|| full.data.iter().copied().fold(f32::NEG_INFINITY, f32::max));
    let hw = super::fit_half_window(cx.img, p, step, WINDOW_FRAC, cx.refine.half_window) as i64;
    let (cx0, cy0) = (p.x.round() as i64, p.y.round() as i64);
    let (mut clipped, mut n) = (0usize, 0usize);
    for y in (cy0 - hw).max(0)..=(cy0 + hw).min(full.height as i64 - 1) {
        for x in (cx0 - hw).max(0)..=(cx0 + hw).min(full.width as i64 - 1) {
            n += 1;
            clipped += usize::from(full.data[y as usize * full.width + x as usize] >= max);
        }
    }
    n > 0 && clipped as f64 >= MIN_CLIPPED_FRACTION * n as f64
}

/// Every cell of the line beside the grid, each validated (predictions use the cells of the line
/// already placed); `None` unless all are.
fn line<I: GreyWindow>(cx: &Ctx<'_, I>, g: &Grid, side: Side) -> Option<Vec<Placed>> {
    let (i0, i1, j0, j1) = g.bounds()?;
    let keys: Vec<(i32, i32)> = match side {
        Side::I(k) => (j0..=j1).map(|j| (k, j)).collect(),
        Side::J(k) => (i0..=i1).map(|i| (i, k)).collect(),
    };
    let mut work = g.clone();
    let mut out = Vec::with_capacity(keys.len());
    for (i, j) in keys {
        let q = validated(cx, &work, i, j)?;
        work.cells.insert((i, j), q);
        out.push(((i, j), q));
    }
    Some(out)
}

/// What completion works with: the image, in f32 too (for the dark quads), the fit settings, the
/// grid's step range, and the dark quads (found once, when first needed).
struct Ctx<'a, I> {
    img: &'a I,
    full: &'a ImageF32,
    refine: &'a SaddleFitParams,
    p: &'a CompleteParams,
    /// The partial grid completion started from.
    start: &'a Grid,
    /// Shortest and longest step between 4-neighbours of the partial grid, pixels.
    steps: (f64, f64),
    quads: OnceLock<Vec<Quad>>,
    /// The image's largest value (clipped pixels reach it), found when first needed.
    max: OnceLock<f32>,
    /// The partial grid's homography and lens ([`GridLens`]), fitted when first needed.
    lens: OnceLock<Option<GridLens>>,
}

/// Shortest and longest distance between 4-neighbours of `g`.
fn steps(g: &Grid) -> (f64, f64) {
    let mut out = (f64::INFINITY, 0.0f64);
    for (&(i, j), q) in &g.cells {
        for k in [(i + 1, j), (i, j + 1)] {
            if let Some(n) = g.cells.get(&k) {
                let d = (n - q).norm();
                out = (out.0.min(d), out.1.max(d));
            }
        }
    }
    out
}

/// The corner at cell (i, j) of `g` when the image shows one there: the saddle fit, else a pair
/// of dark quads meeting there (see the module doc).
fn validated<I: GreyWindow>(cx: &Ctx<'_, I>, g: &Grid, i: i32, j: i32) -> Option<Point2<f64>> {
    let (pred, step, si, sj) = g.predict(i, j)?;
    let p = cx.p;
    if !(step >= p.min_step_px) {
        return None;
    }
    let expect = if (i + j).rem_euclid(2) == 0 { g.polarity0 } else { -g.polarity0 };
    // the averaged prediction first, then each single one that differs from those tried
    let mut tried: Vec<Point2<f64>> = Vec::new();
    for guess in std::iter::once(pred).chain(g.predictions(i, j)) {
        if tried.iter().any(|t| (t - guess).norm() < p.max_shift_frac * step) {
            continue;
        }
        tried.push(guess);
        if let Some(q) = validated_at(cx, guess, step, (si, sj), expect) {
            return Some(q);
        }
    }
    // then the saddle-response peak near the prediction (a fit started a few pixels off a
    // corner whose squares are compressed can settle on the wrong lines), and the whole grid's
    // prediction through the lens, with the peak near it (the local extrapolations overshoot
    // where the squares shrink fast). The peak is searched within a few fit windows (enough to
    // bring the fit's start onto the junction, in a patch that fits beside the image border),
    // then as far as the fit may move.
    let hw = super::fit_half_window(cx.img, pred, step, WINDOW_FRAC, cx.refine.half_window);
    let far = ((p.max_shift_frac * step).floor() as usize).max(1);
    let peak_near = |q: Point2<f64>, radius: usize| local_peak(cx.full, q, radius, RESPONSE_SIGMA_PX);
    let peaks_near = |q: Point2<f64>| [peak_near(q, far.min(PEAK_WINDOWS * hw)), peak_near(q, far)];
    let centre = Point2::new((cx.full.width as f64 - 1.0) / 2.0, (cx.full.height as f64 - 1.0) / 2.0);
    let lens = cx.lens.get_or_init(|| GridLens::fit(cx.start, centre)).and_then(|m| m.predict(i, j));
    let lens_peaks = lens.map_or([None, None], peaks_near);
    for guess in peaks_near(pred).into_iter().chain([lens]).chain(lens_peaks).flatten() {
        if tried.iter().any(|t| (t - guess).norm() <= 1.0) {
            continue;
        }
        tried.push(guess);
        if let Some(q) = validated_at(cx, guess, step, (si, sj), expect) {
            return Some(q);
        }
    }
    log::trace!("completion: cell ({i}, {j}) at ({:.1}, {:.1}), step {step:.1}: no corner at {} guesses", pred.x, pred.y, tried.len());
    None
}

/// The corner near the guess `pred`: the saddle fit, else a pair of dark quads.
fn validated_at<I: GreyWindow>(cx: &Ctx<'_, I>, pred: Point2<f64>, step: f64, (si, sj): (Vector2<f64>, Vector2<f64>), expect: i8) -> Option<Point2<f64>> {
    let p = cx.p;
    let half_window = super::fit_half_window(cx.img, pred, step, WINDOW_FRAC, cx.refine.half_window);
    let fp = SaddleFitParams { half_window, max_shift_px: p.max_shift_frac * step, ..*cx.refine };
    if let Ok(fit) = refine_saddle(cx.img, pred, si, sj, &fp) {
        if fit_is_corner(&fit, si, sj, expect, p) && quadrant_contrast(cx.full, &fit, half_window).is_none_or(|c| c >= p.min_quadrant_contrast) {
            return Some(fit.point);
        }
    }
    // the squares along the dark diagonal
    let dark = if expect > 0 { si - sj } else { si + sj };
    quad_pair_corner(cx.full, cx.quads.get_or_init(|| dark_quads(cx.full, cx.steps)), pred, step, dark, (si, sj), p)
}
