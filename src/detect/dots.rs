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
//!    hold only noise, at a long lever arm.
//! 4. Where a dot meets a two-level edge (the sphere's outline) the surround is an edge model
//!    (`EdgeSurround`), measured on the lines across the edge that no dot touches and bridged
//!    by the whole image's outline conic ([`Outline`]); the weights then depend on whether the
//!    blob is paint on the bright side, a bead behind the edge or one in front of it
//!    (`edge_weights`).
//!
//! Reference: the intensity-weighted centroid is the classic estimator of circular-target centres
//! (Shortis, Clarke, Short, "A comparison of some techniques for the subpixel location of discrete
//! target images", SPIE 2350, 1994).

use imageproc::region_labelling::{connected_components, Connectivity};
use nalgebra::Point2;

use super::edge_surround::EdgeSurround;
use super::filters::{extreme_filter, median_by};
use super::outline::Outline;
use super::{DetectError, ImageF32};

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
    /// Pixels in the core.
    pub core_px: usize,
    /// Surround minus dot level, grey levels.
    pub contrast: f64,
}

/// Weight of a pixel that surely belongs to a blob (some 10 noise sigmas at sigma 1 grey level).
const SIGNIFICANT_WEIGHT: f64 = 0.1;

/// Pooling factor of the local-level images.
const POOL: usize = 4;

/// POOL x POOL minimum (or maximum) pooling; partial blocks at the right and bottom edges.
fn pool(img: &ImageF32, max: bool) -> ImageF32 {
    let (pw, ph) = (img.width.div_ceil(POOL), img.height.div_ceil(POOL));
    let mut data = vec![if max { f32::NEG_INFINITY } else { f32::INFINITY }; pw * ph];
    for y in 0..img.height {
        let row = &img.data[y * img.width..(y + 1) * img.width];
        let out = &mut data[(y / POOL) * pw..(y / POOL + 1) * pw];
        for (x, v) in row.iter().enumerate() {
            let o = &mut out[x / POOL];
            *o = if max { o.max(*v) } else { o.min(*v) };
        }
    }
    ImageF32 { width: pw, height: ph, data }
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
    let t0 = std::time::Instant::now();
    // Local levels for the cores, on 4 x 4 min / max pooled images (16x fewer pixels; the window
    // grows to a multiple of 4, which only matters far from any dot).
    let r4 = params.window_px.div_ceil(POOL);
    let lo = extreme_filter(&pool(img, false), r4, false);
    let hi = extreme_filter(&pool(img, true), r4, true);
    let pw = lo.width;
    let mask = image::GrayImage::from_fn(w as u32, h as u32, |x, y| {
        let i = (y as usize / POOL) * pw + x as usize / POOL;
        let (l, hh, v) = (lo.data[i], hi.data[i], img.data[y as usize * w + x as usize]);
        image::Luma([u8::from(hh - l > params.min_contrast && v < l + params.core_fraction * (hh - l))])
    });
    let t1 = t0.elapsed().as_secs_f64() * 1e3;
    let mut cores = components(&mask, (0, 0));
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
    // Owner map of the grown cores (label of the grown core covering a pixel, or 0).
    let g = params.grow_px as i64;
    // A pixel in two grown cores goes to the nearer core (squared distance to its nearest core
    // pixel); at equal distance to neither (u32::MAX): between touching dots, the darkness of a
    // pixel belongs mostly to the dot it is nearer to.
    let mut owner = vec![0u32; w * h];
    // Squared distances within a grown core are at most 2 g^2 (small): one byte per pixel.
    let mut owner_d2 = vec![u8::MAX; w * h];
    for &k in &keep {
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
    let mut dots = Vec::with_capacity(keep.len());
    let mut outline: Option<Option<Outline>> = None;
    for &k in &keep {
        let core = &cores[k];
        let id = k as u32 + 1;
        let [x0, y0, x1, y1] = bbox(core);
        let pad = params.grow_px + 1;
        // A blob cut by the image border has a biased centre: not reported.
        if x0 < pad || y0 < pad || x1 + pad >= w || y1 + pad >= h {
            continue;
        }
        let (bx0, by0) = (x0.saturating_sub(pad), y0.saturating_sub(pad));
        let (bx1, by1) = ((x1 + pad).min(w - 1), (y1 + pad).min(h - 1));
        let d = f64::from(dark_level(img, core).unwrap_or(0.0));
        // Closing (dilation then erosion) of the dot's neighbourhood: the surround level with the
        // dot removed, exact on straight (anti-aliased) edges such as the sphere's outline. It
        // rides on noise peaks; the median lift of the ring is subtracted below.
        let r = params.window_px;
        let (closed, [cx0, cy0, cx1, cy1]) = closed_window(img, [bx0, by0, bx1, by1], 2 * r, r);
        let cw = cx1 - cx0 + 1;
        let closed_at = |x: usize, y: usize| closed.data[(y - cy0) * cw + (x - cx0)];
        // A two-level edge (the sphere's outline) through the window: modelled, not closed.
        let is_dot = |x: usize, y: usize| owner[y * w + x] != 0;
        // Whether the closing shows an edge in the window at all.
        let closed_has_edge = {
            let (cmin, cmax) = closed.data.iter().fold((f32::INFINITY, f32::NEG_INFINITY), |(a, b), v| (a.min(*v), b.max(*v)));
            cmax - cmin > params.min_contrast
        };
        let edge = EdgeSurround::fit(img, [cx0, cy0, cx1, cy1], &closed_at, &is_dot, f64::from(params.min_contrast)).or_else(|| {
            // Too few clean lines across the edge (neighbouring dots along the outline hide
            // them): a window half as large again, where the first window holds an edge at all.
            if !closed_has_edge {
                return None;
            }
            let (big, rect) = closed_window(img, [bx0, by0, bx1, by1], 3 * r, r);
            let bw = rect[2] - rect[0] + 1;
            EdgeSurround::fit(img, rect, &|x, y| big.data[(y - rect[1]) * bw + (x - rect[0])], &is_dot, f64::from(params.min_contrast))
        });
        // Where the whole-image outline agrees with the window's clean lines, it bridges the
        // lines the dots hide (fitted once, at the first dot with an edge, with its levels).
        // Where no window holds enough clean lines, the outline alone, if the closing shows an
        // edge in the window.
        let edge = match edge {
            Some(e) => {
                let whole = outline.get_or_insert_with(|| {
                    let (lo, hi) = e.levels();
                    Outline::fit(img, lo, hi, &is_dot)
                });
                match whole {
                    Some(o) => e.along(o, [cx0, cy0, cx1, cy1]).or(Some(e)),
                    None => Some(e),
                }
            }
            None => match &outline {
                Some(Some(o)) if closed_has_edge => EdgeSurround::from_outline(o, [cx0, cy0, cx1, cy1]),
                _ => None,
            },
        };
        // The free pixels around the grown core.
        let ring: Vec<(usize, usize)> = (by0..=by1).flat_map(|y| (bx0..=bx1).map(move |x| (x, y))).filter(|&(x, y)| owner[y * w + x] == 0).collect();
        // Only thin cores (about two pixels across at most: a sliver seen edge-on) are flooded.
        let thin = core.len() <= 2 * (x1 - x0 + 1).max(y1 - y0 + 1);
        let reach = if thin { params.window_px / 3 } else { 0 };
        let darkness_over = |s: f64, x: usize, y: usize| (s - f64::from(img.data[y * w + x])) / (s - d).max(1e-6);
        let region_under = |surround: &dyn Fn(usize, usize) -> f64| {
            blob_region(&owner, w, id, [bx0, by0, bx1, by1], [cx0, cy0, cx1, cy1], reach, &|x, y| darkness_over(surround(x, y), x, y))
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
            continue;
        }
        let darkness = |x: usize, y: usize| darkness_over(surround_at(x, y), x, y);
        // Not clamped at 0: noise in the surround then averages out instead of biasing.
        // A thin blob has no wholly dark pixel, so its dark level `d` is too light and its
        // darkness overshoots 1 where the blob is darkest: not clamped there (the overshoot is a
        // common scale, which the centroid does not see).
        let top = if thin { 2.0 } else { 1.0 };
        let mut weights: Vec<f64> = region.iter().map(|&(x, y)| darkness(x, y).clamp(-params.min_weight, top)).collect();
        if let Some(e) = &edge {
            edge_weights(img, e, &region, &mut weights, d, top);
        }
        // Pixels farther than one pixel from any clearly dark one (weight above
        // SIGNIFICANT_WEIGHT) carry nothing of the blob (the box filter spreads a boundary over
        // one pixel), only noise at their lever arm: left out.
        let mut sorted: Vec<(usize, usize)> = region.iter().zip(&weights).filter(|(_, w)| **w > SIGNIFICANT_WEIGHT).map(|(p, _)| *p).collect();
        sorted.sort_unstable();
        let near_dark =
            |x: usize, y: usize| (y.saturating_sub(1)..=y + 1).any(|yy| (x.saturating_sub(1)..=x + 1).any(|xx| sorted.binary_search(&(xx, yy)).is_ok()));
        let (mut sw, mut su, mut sv) = (0.0, 0.0, 0.0);
        for (&(x, y), &wgt) in region.iter().zip(&weights) {
            if !near_dark(x, y) {
                continue;
            }
            sw += wgt;
            su += wgt * x as f64;
            sv += wgt * y as f64;
        }
        if sw > 0.0 {
            dots.push(Dot { centre_px: Point2::new(su / sw, sv / sw), area_px: sw, core_px: core.len(), contrast: s_core - d });
        }
    }
    Ok(dots)
}

/// The morphological closing (window `r`) of `img` over `bbox` grown by `margin` (clipped to the
/// image), and that rectangle.
fn closed_window(img: &ImageF32, bbox: [usize; 4], margin: usize, r: usize) -> (ImageF32, [usize; 4]) {
    let (w, h) = (img.width, img.height);
    let (x0, y0) = (bbox[0].saturating_sub(margin), bbox[1].saturating_sub(margin));
    let (x1, y1) = ((bbox[2] + margin).min(w - 1), (bbox[3] + margin).min(h - 1));
    let crop = ImageF32 { width: x1 - x0 + 1, height: y1 - y0 + 1, data: (y0..=y1).flat_map(|y| img.data[y * w + x0..=y * w + x1].iter().copied()).collect() };
    (extreme_filter(&extreme_filter(&crop, r, true), r, false), [x0, y0, x1, y1])
}

/// Weights of a blob at a two-level edge (the sphere's outline), from the edge model `e`, given
/// the plain darkness weights. Three cases, told apart by how much the blob darkens each pixel
/// against its modelled level `S` (beyond noise and the edge model's error, 12 grey levels):
/// - *paint* (a cap painted on the sphere) covers only the bright side: at most the pixel's
///   bright share times `(hi - dot level)`; coverage `(S - I) / (hi - dark)`, at most `top`;
/// - *behind* (a bead on the sphere just past its limb, which the sphere hides where they
///   overlap) covers only the dark side: at most the dark share times `(lo - dot level)`;
///   coverage `(S - I) / (lo - dark)`;
/// - otherwise an *occluder* (a bead in front of the outline) covers both: where its rim
///   crosses the edge the coverage comes from [`EdgeSurround::occluder_coverage`] with the rim
///   taken square to the direction of the blob's centre.
fn edge_weights(img: &ImageF32, e: &EdgeSurround, region: &[(usize, usize)], weights: &mut [f64], dark: f64, top: f64) {
    let w = img.width;
    let level: Vec<f64> = region.iter().map(|&(x, y)| e.level_at(x, y)).collect();
    let frac: Vec<f64> = level.iter().map(|l| e.bright_fraction(*l)).collect();
    let value = |k: usize| f64::from(img.data[region[k].1 * w + region[k].0]);
    // The dot level can be darker than `dark` (a thin blob has no wholly dark pixel): the bounds
    // take the darkest pixel of the region if it is darker.
    let (lo, hi) = e.levels();
    let darkest = (0..region.len()).map(value).fold(dark, f64::min);
    let within = |share: &dyn Fn(usize) -> f64, range: f64| (0..region.len()).all(|k| level[k] - value(k) <= share(k) * range + 12.0);
    let coverage_over = |range: f64, weights: &mut [f64]| {
        for (k, wt) in weights.iter_mut().enumerate() {
            *wt = ((level[k] - value(k)) / range.max(1e-6)).clamp(-0.5, top);
        }
    };
    if within(&|k| frac[k], hi - darkest) {
        coverage_over(hi - dark, weights);
    } else if within(&|k| 1.0 - frac[k], lo - darkest) {
        coverage_over(lo - dark, weights);
    } else {
        let sw: f64 = weights.iter().map(|v| v.max(0.0)).sum();
        if sw <= 0.0 {
            return;
        }
        let cu = region.iter().zip(weights.iter()).map(|(p, v)| v.max(0.0) * p.0 as f64).sum::<f64>() / sw;
        let cv = region.iter().zip(weights.iter()).map(|(p, v)| v.max(0.0) * p.1 as f64).sum::<f64>() / sw;
        for (k, wt) in weights.iter_mut().enumerate() {
            let (x, y) = region[k];
            let (dx, dy) = (cu - x as f64, cv - y as f64);
            let len = dx.hypot(dy);
            if (0.02..=0.98).contains(&frac[k]) && (0.02..=0.98).contains(wt) && len > 1e-9 {
                *wt = e.occluder_coverage(x, y, value(k), dark, [dx / len, dy / len]);
            }
        }
    }
    // On the edge itself a pixel brighter than the model is the model's error (a few tenths of a
    // pixel of edge position near a row of dots), not noise to be averaged out: not negative.
    for (a, wt) in frac.iter().zip(weights.iter_mut()) {
        if (0.02..=0.98).contains(a) {
            *wt = wt.max(0.0);
        }
    }
}

/// Bounding box `[x0, y0, x1, y1]` (inclusive) of a non-empty pixel list.
fn bbox(pixels: &[(usize, usize)]) -> [usize; 4] {
    pixels.iter().fold([usize::MAX, usize::MAX, 0, 0], |b, &(x, y)| [b[0].min(x), b[1].min(y), b[2].max(x), b[3].max(y)])
}

/// The cores inside a too-large component: its pixels darker than halfway between its darkest
/// level and its median (the background it swallowed), 8-connected.
fn split_large(img: &ImageF32, comp: &[(usize, usize)], params: &DotParams) -> Vec<Vec<(usize, usize)>> {
    let w = img.width;
    let mut vals: Vec<f32> = comp.iter().map(|&(x, y)| img.data[y * w + x]).collect();
    let lo = vals.iter().copied().fold(f32::INFINITY, f32::min);
    let Some(m) = median_by(&mut vals, f32::total_cmp) else { return Vec::new() };
    if !(m - lo > 0.5 * params.min_contrast) {
        return Vec::new();
    }
    let t = lo + 0.5 * (m - lo);
    let [x0, y0, x1, y1] = bbox(comp);
    let mut dark = image::GrayImage::new((x1 - x0 + 1) as u32, (y1 - y0 + 1) as u32);
    for &(x, y) in comp {
        dark.put_pixel((x - x0) as u32, (y - y0) as u32, image::Luma([u8::from(img.data[y * w + x] < t)]));
    }
    components(&dark, (x0, y0))
}

/// Whether `core`'s darker half lies below most of the pixels bordering it (8-connected) by at
/// least a quarter of `min_contrast`: a dot's core does, a patch of flat background does not.
fn darker_than_rim(img: &ImageF32, core: &[(usize, usize)], params: &DotParams) -> bool {
    let (w, h) = (img.width, img.height);
    let [x0, y0, x1, y1] = bbox(core);
    let (ox, oy) = (x0.saturating_sub(1), y0.saturating_sub(1));
    let bw = (x1 + 1).min(w - 1) - ox + 1;
    let bh = (y1 + 1).min(h - 1) - oy + 1;
    let mut in_core = vec![false; bw * bh];
    for &(x, y) in core {
        in_core[(y - oy) * bw + (x - ox)] = true;
    }
    let mut rim: Vec<f32> = Vec::new();
    for by in 0..bh {
        for bx in 0..bw {
            if in_core[by * bw + bx] {
                continue;
            }
            let touches = (by.saturating_sub(1)..=(by + 1).min(bh - 1)).any(|yy| (bx.saturating_sub(1)..=(bx + 1).min(bw - 1)).any(|xx| in_core[yy * bw + xx]));
            if touches {
                rim.push(img.data[(oy + by) * w + ox + bx]);
            }
        }
    }
    rim.sort_by(f32::total_cmp);
    let (Some(d), Some(r)) = (dark_level(img, core), rim.get(rim.len() / 5).copied()) else {
        return true;
    };
    r - d > 0.25 * params.min_contrast
}

/// A core's dark level: the median of its darker half.
fn dark_level(img: &ImageF32, core: &[(usize, usize)]) -> Option<f32> {
    let mut vals: Vec<f32> = core.iter().map(|&(x, y)| img.data[y * img.width + x]).collect();
    vals.sort_by(f32::total_cmp);
    let half = vals.len().div_ceil(2);
    median_by(&mut vals[..half], f32::total_cmp)
}

/// The 8-connected components of the set pixels of `mask` (whose top-left pixel is `origin` in
/// the image), as pixel lists in raster order, in label order.
fn components(mask: &image::GrayImage, origin: (usize, usize)) -> Vec<Vec<(usize, usize)>> {
    let labels = connected_components(mask, Connectivity::Eight, image::Luma([0u8]));
    let mut out: Vec<Vec<(usize, usize)>> = Vec::new();
    for (x, y, l) in labels.enumerate_pixels() {
        let l = l[0] as usize;
        if l > 0 {
            if out.len() < l {
                out.resize(l, Vec::new());
            }
            out[l - 1].push((x as usize + origin.0, y as usize + origin.1));
        }
    }
    out
}

/// Cores of at most this many pixels are fragment candidates for [`merge_fragments`].
const FRAGMENT_PX: usize = 6;

/// Join each small core (at most [`FRAGMENT_PX`] pixels) to a core one pixel away when a pixel
/// between them is darker than [`JOIN_DARKNESS`] against the local levels: the threshold breaks a
/// one-pixel-thin sliver (a dot seen edge-on) into pieces along its staircase.
fn merge_fragments(cores: &mut [Vec<(usize, usize)>], w: usize, h: usize, params: &DotParams, darkness: &dyn Fn(usize, usize) -> f32) {
    let in_range = |c: &Vec<(usize, usize)>| (1..=params.max_core_px).contains(&c.len());
    // Core of each core pixel (a map: the cores hold a small share of the image).
    let mut id: std::collections::HashMap<usize, u32> = std::collections::HashMap::new();
    for (k, c) in cores.iter().enumerate().filter(|(_, c)| in_range(c)) {
        for &(x, y) in c {
            id.insert(y * w + x, k as u32);
        }
    }
    for k in 0..cores.len() {
        if cores[k].is_empty() || cores[k].len() > FRAGMENT_PX {
            continue;
        }
        let mut target = None;
        'search: for &(x, y) in &cores[k] {
            for dy in -2i64..=2 {
                for dx in -2i64..=2 {
                    let (qx, qy) = (x as i64 + dx, y as i64 + dy);
                    if dx.abs().max(dy.abs()) != 2 || qx < 0 || qy < 0 || qx as usize >= w || qy as usize >= h {
                        continue;
                    }
                    let Some(&o) = id.get(&(qy as usize * w + qx as usize)) else { continue };
                    if o as usize == k {
                        continue;
                    }
                    // A pixel next to both.
                    let (mx, my) = ((x as i64 + qx).div_euclid(2) as usize, (y as i64 + qy).div_euclid(2) as usize);
                    if f64::from(darkness(mx, my)) > JOIN_DARKNESS {
                        target = Some(o as usize);
                        break 'search;
                    }
                }
            }
        }
        if let Some(o) = target {
            let moved = std::mem::take(&mut cores[k]);
            for &(x, y) in &moved {
                id.insert(y * w + x, o as u32);
            }
            cores[o].extend(moved);
        }
    }
}

/// Darkness above which a pixel next to a blob's region joins it.
const JOIN_DARKNESS: f64 = 0.4;

/// The pixels a blob's centre is computed over: its grown core (`owner == id` in `bbox`); with a
/// `reach` (a thin blob), also the free pixels darker than [`JOIN_DARKNESS`] flooded from it (the
/// rest of a sliver whose core the threshold broke up or cut short) at most `reach` pixels beyond
/// `bbox` and inside `limits`, and a one-pixel ring of free pixels round the whole (the sliver's
/// anti-aliased rim, whose ends can lie beyond the grown core).
fn blob_region(
    owner: &[u32],
    w: usize,
    id: u32,
    bbox: [usize; 4],
    limits: [usize; 4],
    reach: usize,
    darkness: &dyn Fn(usize, usize) -> f64,
) -> Vec<(usize, usize)> {
    let [bx0, by0, bx1, by1] = bbox;
    let mut region: Vec<(usize, usize)> = (by0..=by1).flat_map(|y| (bx0..=bx1).map(move |x| (x, y))).filter(|&(x, y)| owner[y * w + x] == id).collect();
    if reach == 0 {
        return region;
    }
    let x0 = bx0.saturating_sub(reach).max(limits[0]);
    let y0 = by0.saturating_sub(reach).max(limits[1]);
    let x1 = (bx1 + reach).min(limits[2]);
    let y1 = (by1 + reach).min(limits[3]);
    let bw = x1 - x0 + 1;
    let mut inside = vec![false; bw * (y1 - y0 + 1)];
    for &(x, y) in &region {
        inside[(y - y0) * bw + (x - x0)] = true;
    }
    let neighbours = |x: usize, y: usize| {
        (-1i64..=1)
            .flat_map(move |dy| (-1i64..=1).map(move |dx| (x as i64 + dx, y as i64 + dy)))
            .filter_map(move |(xx, yy)| (xx >= x0 as i64 && yy >= y0 as i64 && xx <= x1 as i64 && yy <= y1 as i64).then_some((xx as usize, yy as usize)))
    };
    let mut k = 0;
    while k < region.len() {
        let (x, y) = region[k];
        k += 1;
        for (xx, yy) in neighbours(x, y) {
            let i = (yy - y0) * bw + (xx - x0);
            if !inside[i] && owner[yy * w + xx] == 0 && darkness(xx, yy) > JOIN_DARKNESS {
                inside[i] = true;
                region.push((xx, yy));
            }
        }
    }
    for k in 0..region.len() {
        let (x, y) = region[k];
        for (xx, yy) in neighbours(x, y) {
            let i = (yy - y0) * bw + (xx - x0);
            if !inside[i] && owner[yy * w + xx] == 0 {
                inside[i] = true;
                region.push((xx, yy));
            }
        }
    }
    region
}

#[cfg(test)]
mod tests {
    use super::super::image::area_sampled;
    use super::*;

    /// Area-sampled dark disc at (cx, cy), radius r, on a light surround.
    fn disc(w: usize, h: usize, cx: f64, cy: f64, r: f64) -> ImageF32 {
        area_sampled(w, h, 16, |u, v| if (u - cx).hypot(v - cy) < r { 20.0 } else { 225.0 })
    }

    #[test]
    fn finds_disc_centre() {
        for (cx, cy, r) in [(20.0, 20.0, 5.0), (20.3, 19.7, 2.0), (19.55, 20.45, 1.5)] {
            let img = disc(40, 40, cx, cy, r);
            let dots = find_dots(&img, &DotParams::default()).unwrap();
            assert_eq!(dots.len(), 1, "r {r}");
            let c = dots[0].centre_px;
            // The coverage-weighted centroid of a sampled disc is within ~0.01 px of its centre.
            assert!((c.x - cx).abs() < 0.01 && (c.y - cy).abs() < 0.01, "{c} vs ({cx}, {cy})");
        }
    }

    /// A bead (level 20, radius 4.5) at `bead` next to the outline of a 450-px sphere (225) on
    /// the background (90), in front of the sphere or behind it (hidden where they overlap),
    /// area-sampled; with the exact centroid of the bead's visible part.
    fn bead_at_outline(bead: [f64; 2], in_front: bool) -> (ImageF32, [f64; 2]) {
        let sphere = [50.3 + 450.0, 47.8];
        let on_bead = |u: f64, v: f64| (u - bead[0]).hypot(v - bead[1]) < 4.5 && (in_front || (u - sphere[0]).hypot(v - sphere[1]) >= 450.0);
        let img = area_sampled(96, 96, 16, |u, v| {
            if on_bead(u, v) {
                20.0
            } else if (u - sphere[0]).hypot(v - sphere[1]) < 450.0 {
                225.0
            } else {
                90.0
            }
        });
        // The exact centroid of the visible part: the bead's coverage of each pixel, weighted.
        let cov = area_sampled(96, 96, 16, |u, v| f64::from(u8::from(on_bead(u, v))));
        let (mut a, mut su, mut sv) = (0.0, 0.0, 0.0);
        for (k, c) in cov.data.iter().enumerate() {
            let c = f64::from(*c);
            a += c;
            su += c * (k % 96) as f64;
            sv += c * (k / 96) as f64;
        }
        (img, [su / a, sv / a])
    }

    #[test]
    fn beads_in_front_of_and_behind_the_outline() {
        // The outline runs near x = 50.3; beads straddle it.
        for (bead, in_front) in [([49.6, 47.2], true), ([51.7, 45.4], false), ([52.4, 47.9], false), ([48.1, 46.6], true)] {
            let (img, truth) = bead_at_outline(bead, in_front);
            let dots = find_dots(&img, &DotParams::default()).unwrap();
            assert_eq!(dots.len(), 1, "{bead:?} in front {in_front}");
            let err = (dots[0].centre_px - Point2::from(truth)).norm();
            // The plain darkness against the closing is off by tenths of a pixel here.
            assert!(err < 0.02, "{bead:?} in front {in_front}: {} vs {truth:?}: {err}", dots[0].centre_px);
        }
    }

    #[test]
    fn blank_and_tiny_images_have_no_dots() {
        assert!(find_dots(&ImageF32::new(50, 50, vec![128.0; 2500]).unwrap(), &DotParams::default()).unwrap().is_empty());
        assert!(find_dots(&ImageF32::new(1, 1, vec![0.0]).unwrap(), &DotParams::default()).unwrap().is_empty());
        assert!(find_dots(&ImageF32 { width: 5, height: 5, data: vec![] }, &DotParams::default()).is_err());
    }
}
