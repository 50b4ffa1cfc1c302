//! The centre of one blob from its region's weights, and the blobs whose dark pixels touch.

use nalgebra::Point2;

use super::{Dot, SIGNIFICANT_WEIGHT};

/// Pixel positions (x, y).
pub(super) type Pixels = Vec<(usize, usize)>;

/// A blob's weighted centroid, area (the weight sum) and spread, and the clearly dark pixels
/// they were computed from.
pub(super) struct Centroid {
    pub centre_px: Point2<f64>,
    pub area_px: f64,
    /// Standard deviation of the weights along the blob's major axis, pixels.
    pub spread_px: f64,
    pub dark: Pixels,
}

/// The weighted centroid over the pixels within one pixel of a clearly dark one joined to the
/// `core`; `None` without weight.
pub(super) fn weighted_centroid(region: &[(usize, usize)], weights: &[f64], core: &[(usize, usize)]) -> Option<Centroid> {
    // Pixels farther than one pixel from any clearly dark one (weight above
    // SIGNIFICANT_WEIGHT) carry nothing of the blob (the box filter spreads a boundary over
    // one pixel), only noise at their lever arm: left out. Clearly dark pixels count only when
    // they join the core through clearly dark pixels: the head of a neighbouring sliver one clean
    // pixel beyond the region's rim is another dot (0.16 px pull on a sliver 84 degrees from its
    // normal).
    let mut dark: Vec<(usize, usize)> = region.iter().zip(weights).filter(|(_, w)| **w > SIGNIFICANT_WEIGHT).map(|(p, _)| *p).collect();
    dark.sort_unstable();
    let sorted = joined_to_core(&dark, core);
    let near_dark = |x: usize, y: usize| around(x, y).any(|p| sorted.binary_search(&p).is_ok());
    let used: Vec<((f64, f64), f64)> =
        region.iter().zip(weights).filter(|(p, _)| near_dark(p.0, p.1)).map(|(&(x, y), &wgt)| ((x as f64, y as f64), wgt)).collect();
    let sw: f64 = used.iter().map(|u| u.1).sum();
    if !(sw > 0.0) {
        return None;
    }
    let (cu, cv) = (used.iter().map(|u| u.1 * u.0 .0).sum::<f64>() / sw, used.iter().map(|u| u.1 * u.0 .1).sum::<f64>() / sw);
    let moment = |f: &dyn Fn(f64, f64) -> f64| used.iter().map(|&((x, y), wgt)| wgt * f(x - cu, y - cv)).sum::<f64>() / sw;
    let (a, b, c) = (moment(&|x, _| x * x), moment(&|x, y| x * y), moment(&|_, y| y * y));
    let major = 0.5 * (a + c) + (0.25 * (a - c) * (a - c) + b * b).sqrt();
    Some(Centroid { centre_px: Point2::new(cu, cv), area_px: sw, spread_px: major.max(0.0).sqrt(), dark: sorted })
}

/// The 3 x 3 pixels around (x, y), itself included, clipped at 0 (callers bound the far edges).
fn around(x: usize, y: usize) -> impl Iterator<Item = (usize, usize)> {
    (y.saturating_sub(1)..=y + 1).flat_map(move |yy| (x.saturating_sub(1)..=x + 1).map(move |xx| (xx, yy)))
}

/// The pixels of `dark` (sorted) 8-connected through `dark` to a core pixel, sorted; all of
/// `dark` when no core pixel is in it.
pub(super) fn joined_to_core(dark: &[(usize, usize)], core: &[(usize, usize)]) -> Vec<(usize, usize)> {
    let mut reached = vec![false; dark.len()];
    let mut stack: Vec<usize> = core.iter().filter_map(|p| dark.binary_search(p).ok()).collect();
    if stack.is_empty() {
        return dark.to_vec();
    }
    for &i in &stack {
        reached[i] = true;
    }
    while let Some(i) = stack.pop() {
        let (x, y) = dark[i];
        for j in around(x, y).filter_map(|p| dark.binary_search(&p).ok()) {
            if !reached[j] {
                reached[j] = true;
                stack.push(j);
            }
        }
    }
    dark.iter().zip(&reached).filter(|(_, r)| **r).map(|(p, _)| *p).collect()
}

/// The clearly dark pixels next to `dark` (a blob's) that two grown cores claim equally
/// (`owner` `u32::MAX`), with their `weight`s, sorted: the blob's own where no other blob is next
/// to them, else they join it to another ([`settle_touching`]).
pub(super) fn ties(dark: &[(usize, usize)], owner: &[u32], (w, h): (usize, usize), weight: &dyn Fn(usize, usize) -> f64) -> Vec<((usize, usize), f64)> {
    let mut out: Vec<((usize, usize), f64)> = dark
        .iter()
        .flat_map(|&(x, y)| around(x, y))
        .filter(|&(x, y)| x < w && y < h && owner[y * w + x] == u32::MAX)
        .map(|(x, y)| ((x, y), weight(x, y)))
        .filter(|&(_, v)| v > SIGNIFICANT_WEIGHT)
        .collect();
    out.sort_unstable_by_key(|t| t.0);
    out.dedup_by_key(|t| t.0);
    out
}

/// One blob's measurement before its neighbours are known.
pub(super) struct Measured {
    /// The centre and area from the blob's own pixels.
    pub dot: Dot,
    /// Its clearly dark pixels (sorted), as `weighted_centroid` returns them.
    pub dark: Vec<(usize, usize)>,
    /// Clearly dark pixels next to `dark` that two grown cores claim equally, with their weights.
    pub ties: Vec<((usize, usize), f64)>,
    /// A thin blob (a sliver seen edge-on): its core is a small part of it, so where it touches
    /// another blob their cores do not tell them apart (round blobs split well at equal
    /// distance from their cores: touching beads are measured to 0.043 px).
    pub thin: bool,
}

/// The dots, each tie pixel that only it is next to added to it, and `touching` set where its
/// clearly dark pixels (with its ties) touch (8-neighbours or shared) another dot's, one of the
/// two thin: where two slivers seen edge-on meet end to end, the image does not say where one
/// ends (the join is as dark as either), so neither centre is known (0.35 and 1.8 px off on a
/// pair 84-86 degrees from their normals). A tie pixel left out pulled a sliver by 0.09 px.
pub(super) fn settle_touching(measured: Vec<Measured>, w: usize) -> Vec<Dot> {
    let key = |(x, y): (usize, usize)| y * w + x;
    let sets: Vec<Vec<usize>> = measured.iter().map(|m| m.dark.iter().copied().chain(m.ties.iter().map(|t| t.0)).map(key).collect()).collect();
    // The last dot to hold each pixel; a pixel two dots share is next to itself, so the
    // neighbourhood test below finds shared pixels too.
    let at: std::collections::HashMap<usize, usize> = sets.iter().enumerate().flat_map(|(k, set)| set.iter().map(move |&i| (i, k))).collect();
    let mut touching = vec![false; measured.len()];
    for (k, set) in sets.iter().enumerate() {
        let near = |i: usize| around(i % w, i / w).filter(|&(x, _)| x < w).map(key);
        for &i in set {
            for o in near(i).filter_map(|j| at.get(&j).copied()).filter(|&o| o != k && (measured[o].thin || measured[k].thin)) {
                touching[k] = true;
                touching[o] = true;
            }
        }
    }
    let mut claims: std::collections::HashMap<usize, usize> = std::collections::HashMap::new();
    for m in &measured {
        for t in &m.ties {
            *claims.entry(key(t.0)).or_default() += 1;
        }
    }
    let own = |p: (usize, usize)| claims.get(&key(p)) == Some(&1);
    measured.into_iter().zip(touching).map(|(m, touching)| with_ties(m, touching, &own)).collect()
}

/// The dot of `m` with the weights of its ties that are its `own` (no other dot's) added to its
/// centroid (a dot that touches another keeps its own pixels' centre: it is not a measurement).
fn with_ties(m: Measured, touching: bool, own: &dyn Fn((usize, usize)) -> bool) -> Dot {
    let Measured { dot, mut ties, .. } = m;
    ties.retain(|t| own(t.0));
    if touching || ties.is_empty() {
        return Dot { touching, ..dot };
    }
    let (mut sw, mut su, mut sv) = (dot.area_px, dot.area_px * dot.centre_px.x, dot.area_px * dot.centre_px.y);
    for ((x, y), wgt) in ties {
        sw += wgt;
        su += wgt * x as f64;
        sv += wgt * y as f64;
    }
    Dot { centre_px: Point2::new(su / sw, sv / sw), area_px: sw, ..dot }
}
