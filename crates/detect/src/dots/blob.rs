//! Per-blob helpers of the dot finder: the closing that gives a dot's surround, core splitting
//! and fragment merging, the rim test, the dark level and the grown region of a blob.

use crate::runs::{run_pixels, runs_where, Run};

use super::super::edge_surround::EdgeSurround;
use super::super::filters::{extreme_filter, median_by};
use super::super::ImageF32;
use super::DotParams;

/// The morphological closing (window `r`) of `img` over `bbox` grown by `margin` (clipped to the
/// image), and that rectangle.
pub(super) fn closed_window(img: &ImageF32, bbox: [usize; 4], margin: usize, r: usize) -> (ImageF32, [usize; 4]) {
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
///
/// `paint`: the dot level of the image's wholly dark blobs ([`paint_level`]), if any.
pub(super) fn edge_weights(img: &ImageF32, e: &EdgeSurround, region: &[(usize, usize)], weights: &mut [f64], dark: f64, top: f64, paint: Option<f64>) {
    let w = img.width;
    let level: Vec<f64> = region.iter().map(|&(x, y)| e.level_at(x, y)).collect();
    let frac: Vec<f64> = level.iter().map(|l| e.bright_fraction(*l)).collect();
    let value = |k: usize| f64::from(img.data[region[k].1 * w + region[k].0]);
    // The dot level can be darker than `dark` (a thin blob has no wholly dark pixel): the bounds
    // take the darkest pixel of the region, or the other dots' level, if it is darker (a sliver
    // on the outline, its darkest pixel 61 against 20: the paint bound missed by 0.01 levels and
    // the blob was weighed as an occluder, 0.13 px off).
    let (lo, hi) = e.levels();
    let darkest = (0..region.len()).map(value).fold(dark, f64::min);
    let darkest = paint.map_or(darkest, |p| darkest.min(p));
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
pub(super) fn bbox(pixels: &[(usize, usize)]) -> [usize; 4] {
    pixels.iter().fold([usize::MAX, usize::MAX, 0, 0], |b, &(x, y)| [b[0].min(x), b[1].min(y), b[2].max(x), b[3].max(y)])
}

/// The cores inside a too-large component: its pixels darker than halfway between its darkest
/// level and its median (the background it swallowed), 8-connected.
pub(super) fn split_large(img: &ImageF32, comp: &[(usize, usize)], params: &DotParams) -> Vec<Vec<(usize, usize)>> {
    let w = img.width;
    let mut vals: Vec<f32> = comp.iter().map(|&(x, y)| img.data[y * w + x]).collect();
    let lo = vals.iter().copied().fold(f32::INFINITY, f32::min);
    let Some(m) = median_by(&mut vals, f32::total_cmp) else { return Vec::new() };
    if !(m - lo > 0.5 * params.min_contrast) {
        return Vec::new();
    }
    let t = lo + 0.5 * (m - lo);
    let [x0, y0, x1, y1] = bbox(comp);
    let mut dark = vec![false; (x1 - x0 + 1) * (y1 - y0 + 1)];
    for &(x, y) in comp {
        dark[(y - y0) * (x1 - x0 + 1) + x - x0] = img.data[y * w + x] < t;
    }
    components(&runs_where(x1 - x0 + 1, y1 - y0 + 1, |x, y| dark[y * (x1 - x0 + 1) + x]), (x0, y0))
}

/// Whether `core`'s darker half lies below most of the pixels bordering it (8-connected) by at
/// least a quarter of `min_contrast`: a dot's core does, a patch of flat background does not.
pub(super) fn darker_than_rim(img: &ImageF32, core: &[(usize, usize)], params: &DotParams) -> bool {
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
/// Is the core thin (about two pixels across at most: a sliver seen edge-on)?
pub(super) fn is_thin(core: &[(usize, usize)]) -> bool {
    let [x0, y0, x1, y1] = bbox(core);
    core.len() <= 2 * (x1 - x0 + 1).max(y1 - y0 + 1)
}

/// The dot level of the image: the median [`dark_level`] of the cores `keep` that are not thin
/// (every dot of a target is painted alike); `None` without any.
pub(super) fn paint_level(img: &ImageF32, cores: &[Vec<(usize, usize)>], keep: &[usize]) -> Option<f64> {
    let mut levels: Vec<f32> = keep.iter().filter(|&&k| !is_thin(&cores[k])).filter_map(|&k| dark_level(img, &cores[k])).collect();
    median_by(&mut levels, f32::total_cmp).map(f64::from)
}

pub(super) fn dark_level(img: &ImageF32, core: &[(usize, usize)]) -> Option<f32> {
    let mut vals: Vec<f32> = core.iter().map(|&(x, y)| img.data[y * img.width + x]).collect();
    vals.sort_by(f32::total_cmp);
    let half = vals.len().div_ceil(2);
    median_by(&mut vals[..half], f32::total_cmp)
}

/// The 8-connected components of the set pixels of `mask` (whose top-left pixel is `origin` in
/// the image), as pixel lists in raster order, in label order.
pub(super) fn components(runs: &[Run], origin: (usize, usize)) -> Vec<Vec<(usize, usize)>> {
    crate::runs::components(runs, true, |_| true).iter().map(|c| run_pixels(c, origin)).collect()
}

/// Cores of at most this many pixels are fragment candidates for [`merge_fragments`].
pub(super) const FRAGMENT_PX: usize = 6;

/// Farthest gap, in pixels, that [`merge_fragments`] bridges between two cores.
const FRAGMENT_GAP: i64 = 2;

/// Join each small core (at most [`FRAGMENT_PX`] pixels) to a core up to [`FRAGMENT_GAP`] pixels
/// away (nearest first) when every pixel on the line between them is darker than
/// [`JOIN_DARKNESS`] against the local levels: the threshold breaks a one- or two-pixel-thin
/// sliver (a dot seen edge-on) into pieces along its staircase, and a piece measured apart pulls
/// the rest's centre away (1.4 px on a 10-pixel sliver seen 83 degrees from its normal).
pub(super) fn merge_fragments(cores: &mut [Vec<(usize, usize)>], w: usize, h: usize, params: &DotParams, darkness: &dyn Fn(usize, usize) -> f32) {
    let in_range = |c: &Vec<(usize, usize)>| (1..=params.max_core_px).contains(&c.len());
    // Core of each core pixel (a map: the cores hold a small share of the image).
    let mut id: std::collections::HashMap<usize, u32> = std::collections::HashMap::new();
    for (k, c) in cores.iter().enumerate().filter(|(_, c)| in_range(c)) {
        for &(x, y) in c {
            id.insert(y * w + x, k as u32);
        }
    }
    let inside = |x: i64, y: i64| x >= 0 && y >= 0 && (x as usize) < w && (y as usize) < h;
    // Every pixel strictly between (x, y) and (x + dx, y + dy), on the rounded line, is dark.
    let dark_between = |x: i64, y: i64, dx: i64, dy: i64, r: i64| {
        (1..r).all(|s| {
            let (mx, my) = (x + (dx * s + r / 2).div_euclid(r), y + (dy * s + r / 2).div_euclid(r));
            inside(mx, my) && f64::from(darkness(mx as usize, my as usize)) > JOIN_DARKNESS
        })
    };
    for k in 0..cores.len() {
        if cores[k].is_empty() || cores[k].len() > FRAGMENT_PX {
            continue;
        }
        let mut target = None;
        'search: for r in 2..=FRAGMENT_GAP + 1 {
            for &(x, y) in &cores[k] {
                let (x, y) = (x as i64, y as i64);
                for (dx, dy) in (-r..=r).flat_map(|dy| (-r..=r).map(move |dx| (dx, dy))).filter(|&(dx, dy)| dx.abs().max(dy.abs()) == r) {
                    let Some(&o) = inside(x + dx, y + dy).then(|| id.get(&((y + dy) as usize * w + (x + dx) as usize))).flatten() else { continue };
                    if o as usize != k && dark_between(x, y, dx, dy, r) {
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

/// Darkness above which the pixels between two threshold pieces make them one core.
pub(super) const JOIN_DARKNESS: f64 = 0.4;

/// Darkness above which a free pixel next to a thin blob's region joins it: a sliver's tapering
/// end (at 0.4 the flood stopped two pixels short of a 12-pixel sliver's end, 0.1 px off).
const FLOOD_DARKNESS: f64 = 0.15;

/// Darkness of a clearly painted pixel, for [`blob_region`]'s test of a neighbour's pixels.
const CLEAR_DARKNESS: f64 = 0.5;

/// The pixels a blob's centre is computed over: its grown core (`owner == id` in `bbox`); with a
/// `reach` (a thin blob), also the free pixels darker than [`FLOOD_DARKNESS`] flooded from it (the
/// rest of a sliver whose core the threshold broke up or cut short) at most `reach` pixels beyond
/// `bbox` and inside `limits`, and a one-pixel ring of free pixels round the whole (the sliver's
/// anti-aliased rim, whose ends can lie beyond the grown core). The flood and the ring also take a
/// pixel another dot owns where they step from a clearly dark pixel of this blob and no clearly
/// dark pixel of the owner is next to it: a sliver's tapering end within a neighbour's grown core (two
/// such pixels, 13 % and 9 % of a sliver's paint, left it 0.106 px off). The owner keeps it too:
/// there it holds no paint of the owner's and weighs next to nothing.
pub(super) fn blob_region(
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
    // A pixel another dot owns (nearest to its core) but that holds none of that dot's paint
    // beside it: no clearly dark pixel of the owner next to it, one of this blob's next to it.
    let foreign_end = |x: usize, y: usize, from: (usize, usize)| {
        let o = owner[y * w + x];
        o != 0
            && o != id
            && o != u32::MAX
            && darkness(from.0, from.1) > CLEAR_DARKNESS
            && neighbours(x, y).all(|(a, b)| owner[b * w + a] != o || darkness(a, b) <= CLEAR_DARKNESS)
    };
    let mut k = 0;
    while k < region.len() {
        let (x, y) = region[k];
        k += 1;
        for (xx, yy) in neighbours(x, y) {
            let i = (yy - y0) * bw + (xx - x0);
            if !inside[i] && (owner[yy * w + xx] == 0 || foreign_end(xx, yy, (x, y))) && darkness(xx, yy) > FLOOD_DARKNESS {
                inside[i] = true;
                region.push((xx, yy));
            }
        }
    }
    for k in 0..region.len() {
        let (x, y) = region[k];
        for (xx, yy) in neighbours(x, y) {
            let i = (yy - y0) * bw + (xx - x0);
            if !inside[i] && (owner[yy * w + xx] == 0 || foreign_end(xx, yy, (x, y))) {
                inside[i] = true;
                region.push((xx, yy));
            }
        }
    }
    region
}
