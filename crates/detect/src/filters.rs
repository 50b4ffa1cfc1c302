//! Separable running minimum and maximum filters (square window), O(1) per pixel, borders clamped
//! to the image.
//!
//! Reference: M. van Herk, "A fast algorithm for local minimum and maximum filters on rectangular
//! and octagonal kernels", Pattern Recognition Letters 13 (1992); J. Gil, M. Werman, "Computing
//! 2-D min, median and max filters", IEEE PAMI 15 (1993).

use std::cmp::Ordering;

use super::ImageF32;

/// The median (upper median for an even count) of `v` by `cmp`, reordering `v`; `None` when empty.
pub fn median_by<T: Copy>(v: &mut [T], cmp: fn(&T, &T) -> Ordering) -> Option<T> {
    if v.is_empty() {
        return None;
    }
    let mid = v.len() / 2;
    v.select_nth_unstable_by(mid, cmp);
    Some(v[mid])
}

/// The larger (`max`) or smaller of `a` and `b`, by plain comparisons (not `f32::max`, which
/// handles NaN) so that the filter loops vectorise.
#[inline(always)]
fn pick_extreme(max: bool, a: f32, b: f32) -> f32 {
    if max {
        if a > b {
            a
        } else {
            b
        }
    } else if a < b {
        a
    } else {
        b
    }
}

/// van Herk / Gil-Werman along a sequence of `n` equal-length lanes (`lanes[k]` is the k-th
/// element of every lane): the running extreme over `[k - r, k + r]`, clamped to the sequence.
/// Lanes are rows of an image when filtering vertically (all columns at once, cache-friendly) and
/// single values when filtering a row.
fn vhgw(lanes: &[&[f32]], r: usize, max: bool, out: &mut [Vec<f32>]) {
    let n = lanes.len();
    if n == 0 {
        return;
    }
    let width = lanes[0].len();
    let pick = |a: f32, b: f32| pick_extreme(max, a, b);
    let k = 2 * r + 1;
    let ident = if max { f32::NEG_INFINITY } else { f32::INFINITY };
    // Padded index p in [0, n + 2r): element p - r, identity outside.
    let padded = n + 2 * r;
    let get = |p: usize| -> Option<&[f32]> { p.checked_sub(r).filter(|q| *q < n).map(|q| lanes[q]) };
    // g: running extreme from each block's start; h: to each block's end.
    let mut g = vec![vec![ident; width]; padded];
    let mut h = vec![vec![ident; width]; padded];
    for p in 0..padded {
        let (before, rest) = g.split_at_mut(p);
        let gp = &mut rest[0];
        match get(p) {
            Some(src) => gp.copy_from_slice(src),
            None => gp.fill(ident),
        }
        if p % k != 0 {
            for (a, b) in gp.iter_mut().zip(&before[p - 1]) {
                *a = pick(*a, *b);
            }
        }
    }
    for p in (0..padded).rev() {
        let (left, right) = h.split_at_mut(p + 1);
        let hp = &mut left[p];
        match get(p) {
            Some(src) => hp.copy_from_slice(src),
            None => hp.fill(ident),
        }
        if (p + 1) % k != 0 && p + 1 < padded {
            for (a, b) in hp.iter_mut().zip(&right[0]) {
                *a = pick(*a, *b);
            }
        }
    }
    // Window of element i in padded coordinates: [i, i + 2r].
    for (i, o) in out.iter_mut().enumerate().take(n) {
        let (lo, hi) = (i, i + 2 * r);
        for ((dst, a), b) in o.iter_mut().zip(&h[lo]).zip(&g[hi]) {
            *dst = pick(*a, *b);
        }
    }
}

/// Minimum (`max = false`) or maximum over the (2r+1) x (2r+1) window around every pixel, the
/// window clamped to the image.
pub fn extreme_filter(img: &ImageF32, r: usize, max: bool) -> ImageF32 {
    let (w, h) = (img.width, img.height);
    if w == 0 || h == 0 || img.data.len() != w * h {
        return img.clone();
    }
    // Rows: the scalar form of the same algorithm.
    let mut tmp = vec![0.0f32; w * h];
    let pick = |a: f32, b: f32| pick_extreme(max, a, b);
    let ident = if max { f32::NEG_INFINITY } else { f32::INFINITY };
    let k = 2 * r + 1;
    let padded = w + 2 * r;
    let (mut g, mut hh) = (vec![ident; padded], vec![ident; padded]);
    for (src, dst) in img.data.chunks(w).zip(tmp.chunks_mut(w)) {
        for p in 0..padded {
            let v = if p >= r && p - r < w { src[p - r] } else { ident };
            g[p] = if p % k == 0 { v } else { pick(v, g[p - 1]) };
        }
        for p in (0..padded).rev() {
            let v = if p >= r && p - r < w { src[p - r] } else { ident };
            hh[p] = if (p + 1) % k == 0 || p + 1 == padded { v } else { pick(v, hh[p + 1]) };
        }
        for (i, d) in dst.iter_mut().enumerate() {
            *d = pick(hh[i], g[i + 2 * r]);
        }
    }
    // Columns: the rows are the lanes.
    let lanes: Vec<&[f32]> = tmp.chunks(w).collect();
    let mut cols = vec![vec![0.0f32; w]; h];
    vhgw(&lanes, r, max, &mut cols);
    ImageF32 { width: w, height: h, data: cols.concat() }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn matches_brute_force() {
        let (w, h) = (13, 7);
        let data: Vec<f32> = (0..w * h).map(|i| ((i * 37) % 23) as f32).collect();
        let img = ImageF32::new(w, h, data).unwrap();
        for r in [0, 1, 3, 20] {
            for max in [false, true] {
                let f = extreme_filter(&img, r, max);
                for y in 0..h {
                    for x in 0..w {
                        let mut best = img.at(x, y);
                        for yy in y.saturating_sub(r)..=(y + r).min(h - 1) {
                            for xx in x.saturating_sub(r)..=(x + r).min(w - 1) {
                                let v = img.at(xx, yy);
                                best = if max { best.max(v) } else { best.min(v) };
                            }
                        }
                        assert_eq!(f.at(x, y), best, "r {r} max {max} at ({x}, {y})");
                    }
                }
            }
        }
    }
}
