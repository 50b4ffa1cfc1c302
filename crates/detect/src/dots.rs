//! Dark dots on a lighter surround: blob cores by a local threshold, centres by the
//! background-subtracted intensity centroid.
//!
//! 1. Local levels: running minimum `lo` and maximum `hi` over a window of about `2 * window_px + 1`
//!    (computed on 4 x 4 min / max pooled images).
//!    A pixel is in a dot's *core* when `I < lo + core_fraction * (hi - lo)` and the local contrast
//!    `hi - lo` exceeds `min_contrast`. The low fraction (0.25) keeps a mid-grey background (the
//!    S-path target's, around the sphere) out of the cores even where a dot touches the outline.
//! 2. Cores are 8-connected components; too small or too large ones, and those the image border
//!    cuts, are dropped.
//! 3. Centre: over the core grown by `grow_px`, the weight of a pixel is its darkness
//!    `(S - I) / (S - D)`, with `S` the surround level at that pixel (the morphological closing of
//!    the dot's neighbourhood, which removes the dot but keeps larger structures such as the
//!    sphere's outline exactly, so a dot touching the outline is weighed against the right level;
//!    its lift over the image in the ring around the dot, from noise peaks, is subtracted) and
//!    `D` the dot level (median of the core's darkest half); pixels of other dots' grown cores are
//!    left out. On a noise-free box-filtered render this is exactly the
//!    coverage-weighted centroid of the blob (`centroid_px` of the truth labels). Weights are
//!    clamped to [-min_weight, 1]: not at 0, so that surround noise cancels instead of biasing.
//!    Pixels more than one pixel from any clearly dark one (weight > 0.1) are left out: they
//!    hold only noise, at a long lever arm; so are clearly dark pixels not joined to the core
//!    through clearly dark pixels (a neighbouring sliver's head beyond the region's rim).
//!    Clearly dark pixels that two grown cores claim equally go to the one dot next to them;
//!    dots whose clearly dark pixels touch are marked [`Dot::touching`] (two slivers meeting end
//!    to end: where one ends is not in the image).
//! 4. Where a dot meets a two-level edge (the sphere's outline) the surround is an edge model
//!    (`EdgeSurround`), measured on the lines across the edge that no dot touches and bridged
//!    by the whole image's outline conic ([`Outline`]); the weights then depend on whether the
//!    blob is paint on the bright side, a bead behind the edge or one in front of it
//!    (`edge_weights`).
//!
//! Reference: the intensity-weighted centroid is the classic estimator of circular-target centres
//! (Shortis, Clarke, Short, "A comparison of some techniques for the subpixel location of discrete
//! target images", SPIE 2350, 1994).

use nalgebra::Point2;

use super::edge_surround::EdgeSurround;
use super::filters::{extreme_filter, median_by};
use super::outline::Outline;
use super::par::map_indexed;
use super::runs::Run;
use super::{DetectError, ImageF32};
use blob::{bbox, blob_region, closed_window, components, dark_level, darker_than_rim, edge_weights, is_thin, merge_fragments, paint_level, split_large};
use centroid::{settle_touching, ties, weighted_centroid, Centroid, Measured};

/// Parameters of [`find_dots`].
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct DotParams {
    /// Half-size of the local-level window, pixels (about twice the largest dot radius).
    pub window_px: usize,
    /// Core threshold as a fraction of the local range above the local minimum.
    pub core_fraction: f32,
    /// Smallest local contrast (grey levels) for a core pixel.
    pub min_contrast: f32,
    /// Smallest core, pixels.
    pub min_core_px: usize,
    /// Largest core, pixels.
    pub max_core_px: usize,
    /// Growth of the core for the centroid window, pixels.
    pub grow_px: usize,
    /// Darkness weights are clamped to [-min_weight, 1] (negative weights let surround noise cancel).
    pub min_weight: f64,
}

impl Default for DotParams {
    fn default() -> Self {
        Self { window_px: 12, core_fraction: 0.25, min_contrast: 40.0, min_core_px: 2, max_core_px: 4000, grow_px: 2, min_weight: 0.5 }
    }
}

/// One detected dot.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Dot {
    /// Intensity-weighted centre, pixels (OpenCV convention).
    pub centre_px: Point2<f64>,
    /// Sum of the darkness weights: the blob's area in pixels^2.
    pub area_px: f64,
    /// Standard deviation of the darkness along the blob's major axis, pixels (a disc of radius
    /// r: r / 2; two blobs measured as one stand out by it against their neighbours).
    pub spread_px: f64,
    /// Pixels in the core.
    pub core_px: usize,
    /// Surround minus dot level, grey levels.
    pub contrast: f64,
    /// Its dark pixels touch another dot's (two slivers seen edge-on meeting end to end): where
    /// one ends is not in the image, so the centre is only good for ordering, not as a
    /// measurement (off by up to 2 px on independent renders).
    pub touching: bool,
}

/// Weight of a pixel that surely belongs to a blob (some 10 noise sigmas at sigma 1 grey level).
const SIGNIFICANT_WEIGHT: f64 = 0.1;

/// Pooling factor of the local-level images.
const POOL: usize = 4;

/// POOL x POOL minimum and maximum pooling in one pass; partial blocks at the right and bottom
/// edges.
fn pool_min_max(img: &ImageF32) -> (ImageF32, ImageF32) {
    let (pw, ph) = (img.width.div_ceil(POOL), img.height.div_ceil(POOL));
    let (mut lo, mut hi) = (vec![f32::INFINITY; pw * ph], vec![f32::NEG_INFINITY; pw * ph]);
    for (y, row) in img.data.chunks(img.width).enumerate() {
        let out = (y / POOL) * pw..(y / POOL + 1) * pw;
        for ((l, h), block) in lo[out.clone()].iter_mut().zip(&mut hi[out]).zip(row.chunks(POOL)) {
            for v in block {
                *l = l.min(*v);
                *h = h.max(*v);
            }
        }
    }
    (ImageF32 { width: pw, height: ph, data: lo }, ImageF32 { width: pw, height: ph, data: hi })
}

/// The runs of the core pixels (step 1 of the module docs): `I < lo + core_fraction (hi - lo)`
/// where the local contrast `hi - lo` exceeds `min_contrast`, with `lo`, `hi` per 4 x 4 block.
/// The threshold is the block's: a block whose contrast is too low, or whose own darkest pixel
/// (`block_min`) does not pass, holds no core pixel and is skipped.
fn core_runs(img: &ImageF32, (lo, hi): (&ImageF32, &ImageF32), block_min: &ImageF32, params: &DotParams) -> Vec<Run> {
    let thr: Vec<f32> = lo
        .data
        .iter()
        .zip(&hi.data)
        .zip(&block_min.data)
        .map(|((l, hh), m)| {
            let t = l + params.core_fraction * (hh - l);
            if hh - l > params.min_contrast && *m < t {
                t
            } else {
                f32::NEG_INFINITY
            }
        })
        .collect();
    let (w, pw) = (img.width, lo.width);
    let mut runs = Vec::new();
    for (y, row) in img.data.chunks(w).enumerate() {
        let mut start: Option<usize> = None;
        for (bx, t) in thr[(y / POOL) * pw..(y / POOL + 1) * pw].iter().enumerate() {
            let x0 = bx * POOL;
            if *t == f32::NEG_INFINITY {
                if let Some(s) = start.take() {
                    runs.push(Run { y: y as u32, x0: s as u32, x1: x0 as u32 });
                }
                continue;
            }
            for (x, v) in row.iter().enumerate().take((x0 + POOL).min(w)).skip(x0) {
                match (*v < *t, start) {
                    (true, None) => start = Some(x),
                    (false, Some(s)) => {
                        runs.push(Run { y: y as u32, x0: s as u32, x1: x as u32 });
                        start = None;
                    }
                    _ => {}
                }
            }
        }
        if let Some(s) = start {
            runs.push(Run { y: y as u32, x0: s as u32, x1: w as u32 });
        }
    }
    runs
}

/// Find dark dots.
///
/// # Errors
/// [`DetectError::BadBuffer`] when the buffer does not match the size.
pub fn find_dots(img: &ImageF32, params: &DotParams) -> Result<Vec<Dot>, DetectError> {
    let (w, h) = (img.width, img.height);
    if img.data.len() != w * h {
        return Err(DetectError::BadBuffer { expected: w * h, actual: img.data.len() });
    }
    if w < 3 || h < 3 {
        return Ok(Vec::new());
    }
    let (cores, keep) = find_cores(img, params);
    let owner = owner_map(&cores, &keep, w, h, params.grow_px);
    let paint = paint_level(img, &cores, &keep);
    // Each dot's window (closing, edge fit) in parallel; the whole image's outline is fitted
    // with the levels of the first window, in the cores' order, that holds an edge, and bridges
    // that window's edge and those of the windows after it (as measured one by one).
    let windows = map_indexed(keep.len(), PARALLEL_MIN_DOTS, |i| dot_window(img, params, &owner, &cores[keep[i]]));
    let first = windows.iter().position(|w| w.as_ref().is_some_and(|w| w.fitted.is_some()));
    let outline = first.and_then(|f| windows[f].as_ref()?.fitted.as_ref()).map(|e| {
        let (lo, hi) = e.levels();
        Outline::fit(img, lo, hi, &|x, y| owner[y * w + x] != 0)
    });
    let measured = map_indexed(keep.len(), PARALLEL_MIN_DOTS, |i| {
        let known = first.is_some_and(|f| i >= f).then_some(outline.as_ref()).flatten();
        measure(img, params, (&owner, paint), &cores[keep[i]], keep[i] as u32 + 1, (windows[i].as_ref()?, known))
    });
    Ok(settle_touching(measured.into_iter().flatten().collect(), w))
}

/// Steps 1 and 2 (module docs): the cores, and which of them are dots (size, darker than the rim).
fn find_cores(img: &ImageF32, params: &DotParams) -> (Vec<Vec<(usize, usize)>>, Vec<usize>) {
    let (w, h) = (img.width, img.height);
    let t0 = std::time::Instant::now();
    // Local levels for the cores, on 4 x 4 min / max pooled images (16x fewer pixels; the window
    // grows to a multiple of 4, which only matters far from any dot).
    let r4 = params.window_px.div_ceil(POOL);
    let (block_min, block_max) = pool_min_max(img);
    let lo = extreme_filter(&block_min, r4, false);
    let hi = extreme_filter(&block_max, r4, true);
    let pw = lo.width;
    let runs = core_runs(img, (&lo, &hi), &block_min, params);
    let t1 = t0.elapsed().as_secs_f64() * 1e3;
    let mut cores = components(&runs, (0, 0));
    log::debug!("dots: filters+mask {t1:.1} ms, components {:.1} ms", t0.elapsed().as_secs_f64() * 1e3 - t1);
    // A dot straddling the sphere's outline can join the mid-grey background into one huge core
    // (where the local minimum is the dot's mixed pixels, the background passes the threshold):
    // its darker pixels are thresholded again against the component's own level.
    let mut split: Vec<Vec<(usize, usize)>> = cores.iter().filter(|c| c.len() > params.max_core_px).flat_map(|c| split_large(img, c, params)).collect();
    cores.append(&mut split);
    merge_fragments(&mut cores, w, h, params, &|x, y| {
        let i = (y / POOL) * pw + x / POOL;
        (hi.data[i] - img.data[y * w + x]) / (hi.data[i] - lo.data[i]).max(1e-6)
    });
    // Only cores darker than their rim own pixels: a patch of mid-grey background that passed the
    // threshold next to a faint sliver (where the local minimum is the sliver's) would otherwise
    // take the sliver's pixels from it.
    let keep: Vec<usize> =
        (0..cores.len()).filter(|&k| (params.min_core_px..=params.max_core_px).contains(&cores[k].len()) && darker_than_rim(img, &cores[k], params)).collect();
    (cores, keep)
}

/// Owner map of the grown cores `keep`: the label (index + 1) of the grown core covering a pixel,
/// 0 for none, `u32::MAX` where two cores are equally near.
fn owner_map(cores: &[Vec<(usize, usize)>], keep: &[usize], w: usize, h: usize, grow_px: usize) -> Vec<u32> {
    let g = grow_px as i64;
    // A pixel in two grown cores goes to the nearer core (squared distance to its nearest core
    // pixel); at equal distance to neither (u32::MAX): between touching dots, the darkness of a
    // pixel belongs mostly to the dot it is nearer to.
    let mut owner = vec![0u32; w * h];
    // Squared distances within a grown core are at most 2 g^2 (small): one byte per pixel.
    let mut owner_d2 = vec![u8::MAX; w * h];
    for &k in keep {
        let id = k as u32 + 1;
        for &(x, y) in &cores[k] {
            for dy in -g..=g {
                for dx in -g..=g {
                    let (xx, yy) = (x as i64 + dx, y as i64 + dy);
                    if xx >= 0 && yy >= 0 && (xx as usize) < w && (yy as usize) < h {
                        let i = yy as usize * w + xx as usize;
                        let d2 = u8::try_from(dx * dx + dy * dy).unwrap_or(u8::MAX - 1);
                        let (o, od) = (&mut owner[i], &mut owner_d2[i]);
                        if *o == 0 || *o == id || d2 < *od {
                            *o = id;
                            *od = (*od).min(d2);
                        } else if d2 == *od {
                            *o = u32::MAX;
                        }
                    }
                }
            }
        }
    }
    owner
}

/// Steps 3 and 4 (module docs) for one core (`id` its label in `owner`): the surround, the
/// weights and the centre; `None` for a blob cut by the border, too faint, or without weight.
/// `paint`: the image's dot level ([`paint_level`]).
fn measure(
    img: &ImageF32,
    params: &DotParams,
    (owner, paint): (&[u32], Option<f64>),
    core: &[(usize, usize)],
    id: u32,
    (win, outline): (&DotWindow, Option<&Option<Outline>>),
) -> Option<Measured> {
    let (w, h) = (img.width, img.height);
    let (d, [bx0, by0, bx1, by1], [cx0, cy0, cx1, cy1]) = (win.dark, win.bbox, win.crect);
    let cw = cx1 - cx0 + 1;
    let closed_at = |x: usize, y: usize| win.closed.data[(y - cy0) * cw + (x - cx0)];
    let edge = window_edge(win, outline);
    // The free pixels around the grown core.
    let ring: Vec<(usize, usize)> = (by0..=by1).flat_map(|y| (bx0..=bx1).map(move |x| (x, y))).filter(|&(x, y)| owner[y * w + x] == 0).collect();
    // Only thin cores (about two pixels across at most: a sliver seen edge-on) are flooded.
    let thin = is_thin(core);
    let reach = if thin { params.window_px / 3 } else { 0 };
    let darkness_over = |s: f64, x: usize, y: usize| (s - f64::from(img.data[y * w + x])) / (s - d).max(1e-6);
    let region_under = |surround: &dyn Fn(usize, usize) -> f64| {
        blob_region(owner, w, id, [bx0, by0, bx1, by1], [cx0, cy0, cx1, cy1], reach, &|x, y| darkness_over(surround(x, y), x, y))
    };
    // The model must explain the ring outside the blob (a cubic bridging too long a hidden
    // stretch can miss the edge by pixels there): mean error at most 8 grey levels.
    let edge = edge.and_then(|e| {
        let region = region_under(&|x, y| e.level_at(x, y));
        let mut sorted = region.clone();
        sorted.sort_unstable();
        let free: Vec<&(usize, usize)> = ring.iter().filter(|p| sorted.binary_search(p).is_err()).collect();
        let err: f64 = free.iter().map(|&&(x, y)| (e.level_at(x, y) - f64::from(img.data[y * w + x])).abs()).sum();
        (free.is_empty() || err / free.len() as f64 <= 8.0).then_some((e, region))
    });
    let (edge, region, lift) = match edge {
        Some((e, region)) => (Some(e), region, 0.0),
        None => {
            // Lift of the closing over the image in the ring (noise peaks).
            let mut lift: Vec<f32> = ring.iter().map(|&(x, y)| closed_at(x, y) - img.data[y * w + x]).collect();
            let lift = f64::from(median_by(&mut lift, f32::total_cmp).unwrap_or(0.0));
            (None, region_under(&|x, y| f64::from(closed_at(x, y)) - lift), lift)
        }
    };
    let surround_at = |x: usize, y: usize| match &edge {
        Some(e) => e.level_at(x, y),
        None => f64::from(closed_at(x, y)) - lift,
    };
    let s_core = median_by(&mut core.iter().map(|&(x, y)| surround_at(x, y)).collect::<Vec<_>>(), f64::total_cmp).unwrap_or(0.0);
    if !(s_core - d > f64::from(params.min_contrast) * 0.5) {
        return None;
    }
    let darkness = |x: usize, y: usize| darkness_over(surround_at(x, y), x, y);
    // Not clamped at 0: noise in the surround then averages out instead of biasing.
    // A thin blob has no wholly dark pixel, so its dark level `d` is too light and its
    // darkness overshoots 1 where the blob is darkest: not clamped there (the overshoot is a
    // common scale, which the centroid does not see).
    let top = if thin { 2.0 } else { 1.0 };
    let mut weights: Vec<f64> = region.iter().map(|&(x, y)| darkness(x, y).clamp(-params.min_weight, top)).collect();
    if let Some(e) = &edge {
        edge_weights(img, e, &region, &mut weights, d, top, paint);
    }
    let Centroid { centre_px, area_px, spread_px, dark } = weighted_centroid(&region, &weights, core)?;
    let ties = ties(&dark, owner, (w, h), &|x, y| darkness(x, y).min(top));
    Some(Measured { dot: Dot { centre_px, area_px, spread_px, core_px: core.len(), contrast: s_core - d, touching: false }, dark, ties, thin })
}

/// Parallel work on the dots pays from this many on.
const PARALLEL_MIN_DOTS: usize = 8;

/// A dot's window before the whole image's outline is known ([`find_dots`]).
struct DotWindow {
    /// The grown core's rectangle.
    bbox: [usize; 4],
    /// The dot level (median of the core's darkest half).
    dark: f64,
    /// The closing of the neighbourhood, and its rectangle `crect`.
    closed: ImageF32,
    crect: [usize; 4],
    /// The two-level edge (the sphere's outline) fitted on the clean lines across it in the
    /// window (in a larger window when too few), if one crosses it.
    fitted: Option<EdgeSurround>,
    /// Whether the closing shows an edge in the window at all.
    closed_has_edge: bool,
}

/// The window of the dot whose core is `core`; `None` for a blob the image border cuts (its
/// centre would be biased: not reported).
fn dot_window(img: &ImageF32, params: &DotParams, owner: &[u32], core: &[(usize, usize)]) -> Option<DotWindow> {
    let (w, h, r) = (img.width, img.height, params.window_px);
    let [x0, y0, x1, y1] = bbox(core);
    let pad = params.grow_px + 1;
    if x0 < pad || y0 < pad || x1 + pad >= w || y1 + pad >= h {
        return None;
    }
    let b = [x0 - pad, y0 - pad, (x1 + pad).min(w - 1), (y1 + pad).min(h - 1)];
    // Closing (dilation then erosion) of the dot's neighbourhood: the surround level with the
    // dot removed, exact on straight (anti-aliased) edges such as the sphere's outline. It
    // rides on noise peaks; the median lift of the ring is subtracted (measure).
    let (closed, crect) = closed_window(img, b, 2 * r, r);
    let cw = crect[2] - crect[0] + 1;
    let is_dot = |x: usize, y: usize| owner[y * w + x] != 0;
    let (cmin, cmax) = closed.data.iter().fold((f32::INFINITY, f32::NEG_INFINITY), |(a, b), v| (a.min(*v), b.max(*v)));
    let closed_has_edge = cmax - cmin > params.min_contrast;
    // A two-level edge (the sphere's outline) through the window: modelled, not closed.
    let fitted =
        EdgeSurround::fit(img, crect, &|x, y| closed.data[(y - crect[1]) * cw + (x - crect[0])], &is_dot, f64::from(params.min_contrast)).or_else(|| {
            // Too few clean lines across the edge (neighbouring dots along the outline hide
            // them): a window half as large again, where the first window holds an edge at all.
            if !closed_has_edge {
                return None;
            }
            let (big, rect) = closed_window(img, b, 3 * r, r);
            let bw = rect[2] - rect[0] + 1;
            EdgeSurround::fit(img, rect, &|x, y| big.data[(y - rect[1]) * bw + (x - rect[0])], &is_dot, f64::from(params.min_contrast))
        });
    Some(DotWindow { bbox: b, dark: f64::from(dark_level(img, core).unwrap_or(0.0)), closed, crect, fitted, closed_has_edge })
}

/// The two-level edge model of the dot's window: the edge fitted in it, bridged by the whole
/// image's outline where they agree; where no window holds enough clean lines, the outline
/// alone, if the closing shows an edge in the window. `outline`: the whole image's outline once
/// fitted (`Some(None)`: fitted, none found).
fn window_edge(win: &DotWindow, outline: Option<&Option<Outline>>) -> Option<EdgeSurround> {
    match (&win.fitted, outline) {
        (Some(e), Some(Some(o))) => e.along(o, win.crect).or_else(|| Some(e.clone())),
        (Some(e), _) => Some(e.clone()),
        (None, Some(Some(o))) if win.closed_has_edge => EdgeSurround::from_outline(o, win.crect),
        (None, _) => None,
    }
}

mod blob;
mod centroid;

#[cfg(test)]
mod tests;
