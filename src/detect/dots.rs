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
//!
//! Reference: the intensity-weighted centroid is the classic estimator of circular-target centres
//! (Shortis, Clarke, Short, "A comparison of some techniques for the subpixel location of discrete
//! target images", SPIE 2350, 1994).

use imageproc::region_labelling::{connected_components, Connectivity};
use nalgebra::Point2;

use super::edge_surround::EdgeSurround;
use super::filters::extreme_filter;
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

fn median(v: &mut [f32]) -> f32 {
    if v.is_empty() {
        return 0.0;
    }
    let mid = v.len() / 2;
    v.select_nth_unstable_by(mid, f32::total_cmp);
    v[mid]
}

fn median_f64(mut v: Vec<f64>) -> f64 {
    if v.is_empty() {
        return 0.0;
    }
    let mid = v.len() / 2;
    v.select_nth_unstable_by(mid, f64::total_cmp);
    v[mid]
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
    let labels = connected_components(&mask, Connectivity::Eight, image::Luma([0u8]));
    log::debug!("dots: filters+mask {t1:.1} ms, components {:.1} ms", t0.elapsed().as_secs_f64() * 1e3 - t1);
    // Per label: pixel list.
    let mut cores: Vec<Vec<(usize, usize)>> = Vec::new();
    for (x, y, l) in labels.enumerate_pixels() {
        let l = l[0] as usize;
        if l == 0 {
            continue;
        }
        if cores.len() < l {
            cores.resize(l, Vec::new());
        }
        cores[l - 1].push((x as usize, y as usize));
    }
    let keep: Vec<usize> = (0..cores.len()).filter(|&k| (params.min_core_px..=params.max_core_px).contains(&cores[k].len())).collect();
    // Owner map of the grown cores (label of the grown core covering a pixel, or 0).
    let g = params.grow_px as i64;
    let mut owner = vec![0u32; w * h];
    for &k in &keep {
        for &(x, y) in &cores[k] {
            for dy in -g..=g {
                for dx in -g..=g {
                    let (xx, yy) = (x as i64 + dx, y as i64 + dy);
                    if xx >= 0 && yy >= 0 && (xx as usize) < w && (yy as usize) < h {
                        let o = &mut owner[yy as usize * w + xx as usize];
                        *o = if *o == 0 || *o == k as u32 + 1 { k as u32 + 1 } else { u32::MAX };
                    }
                }
            }
        }
    }
    let mut dots = Vec::with_capacity(keep.len());
    for &k in &keep {
        let core = &cores[k];
        let id = k as u32 + 1;
        let (mut x0, mut y0, mut x1, mut y1) = (usize::MAX, usize::MAX, 0, 0);
        for &(x, y) in core {
            x0 = x0.min(x);
            y0 = y0.min(y);
            x1 = x1.max(x);
            y1 = y1.max(y);
        }
        let pad = params.grow_px + 1;
        // A blob cut by the image border has a biased centre: not reported.
        if x0 < pad || y0 < pad || x1 + pad >= w || y1 + pad >= h {
            continue;
        }
        let (bx0, by0) = (x0.saturating_sub(pad), y0.saturating_sub(pad));
        let (bx1, by1) = ((x1 + pad).min(w - 1), (y1 + pad).min(h - 1));
        let mut core_vals: Vec<f32> = core.iter().map(|&(x, y)| img.data[y * w + x]).collect();
        core_vals.sort_by(f32::total_cmp);
        let half = core_vals.len().div_ceil(2);
        let d = f64::from(median(&mut core_vals[..half]));
        // Closing (dilation then erosion) of the dot's neighbourhood: the surround level with the
        // dot removed, exact on straight (anti-aliased) edges such as the sphere's outline. It
        // rides on noise peaks; the median lift of the ring is subtracted below.
        let r = params.window_px;
        let (cx0, cy0) = (bx0.saturating_sub(2 * r), by0.saturating_sub(2 * r));
        let (cx1, cy1) = ((bx1 + 2 * r).min(w - 1), (by1 + 2 * r).min(h - 1));
        let cw = cx1 - cx0 + 1;
        let crop = ImageF32 {
            width: cw,
            height: cy1 - cy0 + 1,
            data: (cy0..=cy1).flat_map(|y| img.data[y * w + cx0..=y * w + cx1].iter().copied()).collect(),
        };
        let closed = extreme_filter(&extreme_filter(&crop, r, true), r, false);
        let closed_at = |x: usize, y: usize| closed.data[(y - cy0) * cw + (x - cx0)];
        // A two-level edge (the sphere's outline) through the window: modelled, not closed.
        let edge = EdgeSurround::fit(img, [cx0, cy0, cx1, cy1], &closed_at, &|x, y| owner[y * w + x] != 0, f64::from(params.min_contrast));
        // Lift of the closing over the image in the ring around the grown core (noise peaks).
        let mut lift = Vec::new();
        if edge.is_none() {
            for y in by0..=by1 {
                for x in bx0..=bx1 {
                    if owner[y * w + x] == 0 {
                        lift.push(closed_at(x, y) - img.data[y * w + x]);
                    }
                }
            }
        }
        let lift = f64::from(median(&mut lift));
        let surround_at = |x: usize, y: usize| match &edge {
            Some(e) => e.level_at(x, y),
            None => f64::from(closed_at(x, y)) - lift,
        };
        let s_core = median_f64(core.iter().map(|&(x, y)| surround_at(x, y)).collect());
        if !(s_core - d > f64::from(params.min_contrast) * 0.5) {
            continue;
        }
        let (mut sw, mut su, mut sv) = (0.0, 0.0, 0.0);
        for y in by0..=by1 {
            for x in bx0..=bx1 {
                if owner[y * w + x] != id {
                    continue;
                }
                let s = surround_at(x, y);
                // Not clamped at 0: noise in the surround then averages out instead of biasing.
                let wgt = ((s - f64::from(img.data[y * w + x])) / (s - d).max(1e-6)).clamp(-params.min_weight, 1.0);
                sw += wgt;
                su += wgt * x as f64;
                sv += wgt * y as f64;
            }
        }
        if sw > 0.0 {
            dots.push(Dot { centre_px: Point2::new(su / sw, sv / sw), area_px: sw, core_px: core.len(), contrast: s_core - d });
        }
    }
    Ok(dots)
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Area-sampled dark disc at (cx, cy), radius r, on a light surround.
    fn disc(w: usize, h: usize, cx: f64, cy: f64, r: f64) -> ImageF32 {
        let n = 16;
        let mut data = vec![0.0f32; w * h];
        for y in 0..h {
            for x in 0..w {
                let mut cov = 0.0;
                for j in 0..n {
                    for i in 0..n {
                        let u = x as f64 - 0.5 + (i as f64 + 0.5) / n as f64 - cx;
                        let v = y as f64 - 0.5 + (j as f64 + 0.5) / n as f64 - cy;
                        cov += f64::from(u8::from(u * u + v * v < r * r));
                    }
                }
                cov /= (n * n) as f64;
                data[y * w + x] = (225.0 - 205.0 * cov) as f32;
            }
        }
        ImageF32::new(w, h, data).unwrap()
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

    #[test]
    fn blank_and_tiny_images_have_no_dots() {
        assert!(find_dots(&ImageF32::new(50, 50, vec![128.0; 2500]).unwrap(), &DotParams::default()).unwrap().is_empty());
        assert!(find_dots(&ImageF32::new(1, 1, vec![0.0]).unwrap(), &DotParams::default()).unwrap().is_empty());
        assert!(find_dots(&ImageF32 { width: 5, height: 5, data: vec![] }, &DotParams::default()).is_err());
    }
}
