//! Chessboard inner-corner detection: saddle response, seed quads, grid growing by local
//! prediction, exact size check and orientation, then unbiased sub-pixel saddle fits.
//!
//! Ordering rule (documented, stable): the result has `rows` rows of `cols` corners, row-major.
//! Rows run along the grid direction that has `cols` corners. Among the labelings allowed by the
//! grid shape, only those with image handedness "row direction x column direction > 0" (i.e. a
//! row running right has its next row below it, as an unmirrored board seen by OpenCV) are kept;
//! of these (two, or four for square grids) the one whose first corner is nearest the image
//! origin (top-left) wins. On upright boards this equals OpenCV's classic ordering; OpenCV's SB
//! detector often returns the 180-degree rotation.
//!
//! Reference: OpenCV `findChessboardCorners`; A. Geiger et al., "Automatic camera and range sensor
//! calibration using a single shot", ICRA 2012; D. Bennett, J. Lasenby, "ChESS - Quick and robust
//! detection of chess-board features", CVIU 2014.

use std::borrow::Cow;

use nalgebra::Point2;

use super::grid::{grow_grid, Grid, GrowParams};
use super::response::{find_candidates, local_peak, saddle_response, Candidate};
use super::saddle_fit::SaddleFitParams;
use super::{DetectError, GreyWindow, ImageF32, ImageU8};
use complete::recovered;
pub use complete::CompleteParams;
use erosion::{min_filter, EROSION_RADII_PX};
use order::{orient, polygon_area, to_rows};
pub(crate) use refine::fit_half_window;
use refine::refine_all;
use trust::even_steps;
pub use trust::{corners_to_leave_out, MAX_STEP_RATIO, OUTLIER_SIGMA_FACTOR, TRUSTED_CORNER_PX};

mod complete;
mod erosion;
mod grid_lens;
mod junction;
mod order;
mod quad_pair;
mod refine;
mod trust;

/// Parameters of [`find_chessboard`].
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct ChessboardParams {
    /// Inner corners per row.
    pub cols: usize,
    /// Inner corners per column (number of rows).
    pub rows: usize,
    /// Gaussian smoothing before the saddle response, pixels.
    pub smoothing_sigma_px: f64,
    /// Candidates must exceed this fraction of the strongest response.
    pub candidate_rel_threshold: f32,
    /// Maximum number of candidates kept (strongest first).
    pub max_candidates: usize,
    /// Maximum number of seeds tried before giving up (by default as many as there are
    /// candidates: a small board in a cluttered scene can have its corners far down the list of
    /// response strengths, below text, faces and furniture; corners of a grid already grown are
    /// not tried again, so the cost stays bounded).
    pub max_seeds: usize,
    /// After a complete board was found, try at most this many further seeds (looking for a
    /// larger board, e.g. when a small copy of the board is visible on a monitor).
    pub extra_seeds_after_found: usize,
    /// Grid-growing tunables.
    pub grow: GrowParams,
    /// Sub-pixel fit tunables; `half_window` is the upper bound, the actual window is at most
    /// `window_frac` of the local grid step.
    pub refine: SaddleFitParams,
    /// Fit half-window as a fraction of the shortest local grid step.
    pub window_frac: f64,
    /// Refine the corners in parallel (rayon) when there are at least this many and rayon's pool
    /// has more than one thread.
    pub parallel_min_corners: usize,
    /// Structure recovery when no complete board was grown (module `complete`).
    pub complete: CompleteParams,
}

impl ChessboardParams {
    /// Defaults for a board with `cols` x `rows` inner corners.
    pub fn new(cols: usize, rows: usize) -> Self {
        Self { cols, rows, ..Self::default() }
    }
}

impl Default for ChessboardParams {
    fn default() -> Self {
        Self {
            cols: 9,
            rows: 6,
            smoothing_sigma_px: 1.0,
            candidate_rel_threshold: 0.04,
            max_candidates: 3000,
            max_seeds: 3000,
            extra_seeds_after_found: 8,
            grow: GrowParams::default(),
            refine: SaddleFitParams::default(),
            window_frac: 0.4,
            parallel_min_corners: 16,
            complete: CompleteParams::default(),
        }
    }
}

/// A detected board.
#[derive(Debug, Clone, PartialEq)]
pub struct ChessboardCorners {
    /// Corners, row-major: `rows` rows of `cols` corners (see the module doc for the start rule).
    pub points_px: Vec<Point2<f64>>,
    /// Columns (corners per row).
    pub cols: usize,
    /// Rows.
    pub rows: usize,
    /// Per corner: true when the saddle fit succeeded (else the response peak is reported).
    pub refined: Vec<bool>,
    /// Per corner: the standard deviation of its position from its own saddle fit, pixels
    /// ([`SaddleFit::position_sigma_px`](super::SaddleFit::position_sigma_px)); infinite where
    /// the fit failed or its window had to reach the neighbouring corners.
    pub position_sigma_px: Vec<f64>,
    /// RMS fit residual over the refined corners, grey levels.
    pub rms_fit_residual: f64,
    /// Number of response candidates.
    pub candidates: usize,
    /// Seeds tried until the board was found.
    pub seeds_tried: usize,
}

/// Find the full `cols` x `rows` inner-corner grid.
///
/// Returns `Ok(None)` when no complete grid of exactly that size (in either orientation) is found.
///
/// # Errors
/// [`DetectError::EmptyImage`], [`DetectError::BadBuffer`] (size mismatch or non-finite samples)
/// and [`DetectError::BadParams`] (fewer than 2 corners per side).
pub fn find_chessboard(img: &ImageF32, params: &ChessboardParams) -> Result<Option<ChessboardCorners>, DetectError> {
    let expected = check_buffer(img.width, img.height, img.data.len())?;
    // the first pyramid level (see `find_in`) and the finiteness check share one pass over the image
    let first_half = if expected >= PYRAMID_MIN_PIXELS {
        let (half, finite) = img.half_checked();
        finite.then_some(Some(half))
    } else {
        img.all_finite().then_some(None)
    };
    let Some(first_half) = first_half else {
        return Err(DetectError::BadBuffer { expected, actual: img.data.len() });
    };
    check_params(params)?;
    Ok(find_in(img, first_half, || Cow::Borrowed(img), params))
}

/// [`find_chessboard`] on 8-bit samples, with identical results: the pyramid is built from the
/// bytes and the sub-pixel fits read their windows from them, so the full image is converted to
/// f32 only if the search has to fall back to full resolution.
///
/// # Errors
/// As [`find_chessboard`] (8-bit samples are always finite).
pub fn find_chessboard_u8(img: &ImageU8, params: &ChessboardParams) -> Result<Option<ChessboardCorners>, DetectError> {
    let expected = check_buffer(img.width, img.height, img.data.len())?;
    check_params(params)?;
    let first_half = (expected >= PYRAMID_MIN_PIXELS).then(|| img.half());
    Ok(find_in(img, first_half, || Cow::Owned(img.to_f32()), params))
}

/// Non-empty image whose buffer matches its size: the pixel count.
fn check_buffer(width: usize, height: usize, len: usize) -> Result<usize, DetectError> {
    if width == 0 || height == 0 {
        return Err(DetectError::EmptyImage { width, height });
    }
    let expected = width.saturating_mul(height);
    if len != expected {
        return Err(DetectError::BadBuffer { expected, actual: len });
    }
    Ok(expected)
}

fn check_params(params: &ChessboardParams) -> Result<(), DetectError> {
    if params.cols < 2 || params.rows < 2 {
        return Err(DetectError::BadParams { reason: "cols and rows must be at least 2" });
    }
    if !(params.smoothing_sigma_px > 0.0 && params.smoothing_sigma_px < 50.0) {
        return Err(DetectError::BadParams { reason: "smoothing_sigma_px must be in (0, 50)" });
    }
    Ok(())
}

/// The detector proper on a checked image: `first_half` is its first pyramid level (when it has
/// at least [`PYRAMID_MIN_PIXELS`] pixels), `full` gives it in f32 for a full-resolution search.
///
/// Coarse to fine: halve the image while it has at least PYRAMID_MIN_PIXELS pixels, look for the
/// grid from the coarsest level down (the response and candidate search cost 4x less per level),
/// carry the corners down to level 1 by local response peaks, and refine every corner at full
/// resolution.
///
/// When that finds no board, the search runs again on the image with its dark regions grown by
/// a grey-level erosion (a minimum filter) of each radius in [`EROSION_RADII_PX`]: over-exposed
/// light squares bloom over the junctions until the dark squares no longer meet, and no saddle is
/// left to find (OpenCV's classic detector dilates its binary image for the same reason). The
/// erosion re-joins them; as blur and clipping before it, a symmetric structuring element keeps
/// every junction point-symmetric about the true corner, so the corners are fitted, unbiased,
/// on the eroded image.
fn find_in<'a, I: GreyWindow>(
    img: &I,
    first_half: Option<ImageF32>,
    full: impl Fn() -> Cow<'a, ImageF32>,
    params: &ChessboardParams,
) -> Option<ChessboardCorners> {
    if let Some(b) = find_direct(img, first_half, &full, params) {
        return Some(b);
    }
    let original = full();
    EROSION_RADII_PX.iter().find_map(|&r| {
        let eroded = min_filter(&original, r);
        let half = (eroded.width * eroded.height >= PYRAMID_MIN_PIXELS).then(|| eroded.half());
        let found = find_direct(&eroded, half, &|| Cow::Borrowed(&eroded), params);
        if found.is_some() {
            log::debug!("board found after a grey erosion of radius {r} px (over-exposure)");
        }
        found
    })
}

/// One search over the pyramid (see [`find_in`]), with structure recovery.
fn find_direct<'a, I: GreyWindow>(
    img: &I,
    first_half: Option<ImageF32>,
    full: &impl Fn() -> Cow<'a, ImageF32>,
    params: &ChessboardParams,
) -> Option<ChessboardCorners> {
    if img.width() < 8 || img.height() < 8 {
        return None;
    }
    let mut pyramid: Vec<ImageF32> = first_half.into_iter().collect(); // pyramid[k] is level k + 1
    while let Some(top) = pyramid.last().filter(|t| t.width * t.height >= PYRAMID_MIN_PIXELS) {
        let next = top.half();
        pyramid.push(next);
    }
    // the best partial grid of any level (most corners; the finer level on ties), for recovery
    let mut partial: Option<(usize, Grid)> = None;
    for level in (0..=pyramid.len()).rev() {
        let found = match level {
            0 => search(&full(), params),
            _ => search(&pyramid[level - 1], params),
        };
        if let Some((grid, n_cands, seeds)) = found.board {
            let grid = grid.into_iter().map(|row| row.into_iter().map(|p| carry_down(p, level, &pyramid, params)).collect()).collect();
            return even_steps(refine_all(img, orient(grid, params.cols, params.rows), params, n_cands, seeds));
        }
        if let Some(g) = found.partial.filter(|g| partial.as_ref().is_none_or(|b| g.cells.len() >= b.1.cells.len())) {
            partial = Some((level, g));
        }
    }
    let (level, mut g) = partial?;
    log::debug!("no complete board; completing a grid of {} corners from level {level}", g.cells.len());
    for q in g.cells.values_mut() {
        *q = carry_down(*q, level, &pyramid, params);
    }
    if log::log_enabled!(log::Level::Trace) {
        let mut cells: Vec<_> = g.cells.iter().map(|(k, q)| format!("{k:?}=({:.1},{:.1})", q.x, q.y)).collect();
        cells.sort();
        log::trace!("partial grid: {}", cells.join(" "));
    }
    recovered(img, &full(), &g, params).and_then(even_steps)
}

/// A corner found at pyramid `level` carried to full resolution: doubled at each level, snapped
/// to the local response peak of each finer level but the finest (the sub-pixel fit does that).
fn carry_down(mut p: Point2<f64>, level: usize, pyramid: &[ImageF32], params: &ChessboardParams) -> Point2<f64> {
    for finer in (0..level).rev() {
        // A pixel i of one level covers pixels 2i and 2i + 1 of the next finer: centre 2i + 0.5.
        p = Point2::new(2.0 * p.x + 0.5, 2.0 * p.y + 0.5);
        if finer > 0 {
            p = local_peak(&pyramid[finer - 1], p, LOCAL_PEAK_RADIUS, params.smoothing_sigma_px).unwrap_or(p);
        }
    }
    p
}

/// Search radius of the local response peak when carrying a corner one level down, pixels of the
/// finer level (the coarse peak maps to within about 1 px of it).
const LOCAL_PEAK_RADIUS: usize = 2;

/// Levels with at least this many pixels are halved for the coarse search (640 x 480 -> 320 x 240;
/// 1280 x 1024 -> 640 x 512 -> 320 x 256).
pub const PYRAMID_MIN_PIXELS: usize = 300_000;

/// What one pyramid level's search found.
#[derive(Default)]
struct Search {
    /// The complete board (unrefined rows), the candidate count and the seeds tried.
    board: Option<(Rows, usize, usize)>,
    /// Otherwise the largest grid grown that fits inside the board, for [`complete`].
    partial: Option<Grid>,
}

/// Find the grid (unrefined) in `img`.
fn search(img: &ImageF32, params: &ChessboardParams) -> Search {
    if img.width < 8 || img.height < 8 {
        return Search::default();
    }
    let resp = saddle_response(img, params.smoothing_sigma_px);
    let cands = find_candidates(&resp.response, 3, params.candidate_rel_threshold, params.max_candidates);
    let mut used: Vec<Point2<f64>> = Vec::new();
    let mut seeds_tried = 0;
    // several complete boards (e.g. one shown on a monitor): keep the largest in the image
    let mut best: Option<(f64, Rows, usize)> = None;
    let mut partial: Option<Grid> = None;
    for seed in &cands {
        if seeds_tried >= params.max_seeds || best.as_ref().is_some_and(|b| seeds_tried >= b.2 + params.extra_seeds_after_found) {
            break;
        }
        if used.iter().any(|q| (q - seed.point).norm_squared() < 4.0) {
            continue;
        }
        seeds_tried += 1;
        let near = nearest(&cands, seed, 6, params.grow.min_neighbour_frac);
        let Some(mut g) = grow_grid(&resp, seed, &near, &params.grow) else { continue };
        if log::log_enabled!(log::Level::Debug) {
            let b = g.bounds().unwrap_or_default();
            log::debug!(
                "{}x{} image, seed ({:.1}, {:.1}): grid {} x {}, {} corners",
                img.width,
                img.height,
                seed.point.x,
                seed.point.y,
                b.1 - b.0 + 1,
                b.3 - b.2 + 1,
                g.cells.len()
            );
        }
        if g.cells.len() >= 4 {
            used.extend(g.cells.values().copied());
        }
        let (c, r) = (params.cols as i32, params.rows as i32);
        if best.is_none() && fits_inside(&g, c, r) && partial.as_ref().is_none_or(|p| g.cells.len() > p.cells.len()) {
            partial = Some(g.clone());
        }
        let fits = {
            let mut a = g.clone();
            if a.trim_to(c, r) {
                Some(a)
            } else if g.trim_to(r, c) {
                Some(g)
            } else {
                None
            }
        };
        if let Some(grid) = fits.as_ref().and_then(|g| to_rows(g, params.cols, params.rows)) {
            let area = polygon_area(&grid);
            if best.as_ref().is_none_or(|b: &(f64, Rows, usize)| area > b.0) {
                best = Some((area, grid, seeds_tried));
            }
        }
    }
    match best {
        Some((_, grid, st)) => Search { board: Some((grid, cands.len(), st)), partial: None },
        None => Search { board: None, partial },
    }
}

/// The grid's bounding box fits inside a `c` x `r` board in either orientation.
fn fits_inside(g: &Grid, c: i32, r: i32) -> bool {
    g.bounds().is_some_and(|(i0, i1, j0, j1)| {
        let (ni, nj) = (i1 - i0 + 1, j1 - j0 + 1);
        (ni <= c && nj <= r) || (ni <= r && nj <= c)
    })
}

/// Corner positions as rows of `cols` points.
type Rows = Vec<Vec<Point2<f64>>>;

/// The `k` nearest other candidates of `seed` (at least 3 px away, at least `min_frac` of its
/// strength), nearest first.
fn nearest(cands: &[Candidate], seed: &Candidate, k: usize, min_frac: f32) -> Vec<Candidate> {
    let mut best: Vec<(f64, Candidate)> = Vec::with_capacity(k + 1);
    for c in cands {
        let d = (c.point - seed.point).norm_squared();
        if d < 9.0 || c.strength < min_frac * seed.strength {
            continue;
        }
        if best.len() < k || d < best[best.len() - 1].0 {
            let pos = best.partition_point(|b| b.0 <= d);
            best.insert(pos, (d, *c));
            best.truncate(k);
        }
    }
    best.into_iter().map(|b| b.1).collect()
}

#[cfg(test)]
mod tests;
