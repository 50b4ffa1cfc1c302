//! Adaptive mean threshold, as OpenCV's `adaptiveThreshold(ADAPTIVE_THRESH_MEAN_C,
//! THRESH_BINARY_INV)` in the ArUco detector: a pixel is dark when it lies more than an offset
//! below the mean of the square window around it (clamped to the image). The dark pixels come
//! out as horizontal runs, the input of the run-based component labelling; `erode` removes the
//! dark pixels with a light 4-neighbour (binary erosion by a cross), which cuts dark shapes that
//! touch only at a corner.
//!
//! Images of 8-bit levels and their 2 x 2 means (every sample a multiple of 1/4 below 1024, as
//! decoded images and their half-resolution search images are) take an integer path with the
//! same result: the table holds four times the samples in wrapping u32 sums, whose window
//! differences are exact, and windows small enough that every sum stays below 2^24 compare in f32
//! (four lanes where f64 has two; the comparison is exact either way, so the dark pixels are the
//! same as the f64 path's).
//!
//! Reference: OpenCV `modules/objdetect/src/aruco/aruco_detector.cpp` (`_threshold`); F. C. Crow,
//! "Summed-area tables for texture mapping", SIGGRAPH 1984.

use crate::runs::Run;
use crate::ImageF32;

/// Summed-area table of an image, `(w + 1) x (h + 1)`. Its buffer is reused by the next table
/// built on the same thread (a fresh one of a few megabytes costs a page fault per 4 KiB
/// written, more than the sums themselves).
pub(super) struct Integral {
    w: usize,
    h: usize,
    sums: Sums,
}

/// The table's sums.
enum Sums {
    /// Four times the samples (all integers `0..QUARTERS_BELOW`, at most `max`), wrapping u32:
    /// any window's sum below 2^32 comes out exact.
    Quarters { sum: Vec<u32>, max: u32 },
    /// f64 sums (exact for 8-bit levels).
    Float(Vec<f64>),
}

/// Four times a sample must lie below this for the integer path.
const QUARTERS_BELOW: f32 = 1024.0;
/// 2^23: adding it to a float in `[0, 2^23)` rounds it to an integer.
const SHIFT: f32 = 8_388_608.0;

thread_local! {
    /// The buffer of the last dropped f64 [`Integral`] of this thread.
    static SPARE: std::cell::Cell<Vec<f64>> = const { std::cell::Cell::new(Vec::new()) };
    /// The buffer of the last dropped integer [`Integral`] of this thread.
    static SPARE_U32: std::cell::Cell<Vec<u32>> = const { std::cell::Cell::new(Vec::new()) };
}

/// Row segments summed as independent chains in [`Integral::new`] (latency of the additions).
const CHAINS: usize = 4;

impl Integral {
    /// The table of `img` (whose samples must be finite): the integer one when every sample is a
    /// multiple of 1/4 in `[0, 256)`, else f64.
    pub(super) fn new(img: &ImageF32) -> Self {
        Self::quarters(img).unwrap_or_else(|| Self::float(img))
    }

    /// The integer table, `None` when a sample is not a multiple of 1/4 in `[0, 256)`.
    fn quarters(img: &ImageF32) -> Option<Self> {
        let (w, h) = (img.width, img.height);
        // each entry written once (row 0 and column 0 zero), no pass zeroing the buffer first
        let mut sum = SPARE_U32.try_with(std::cell::Cell::take).unwrap_or_default();
        sum.clear();
        sum.reserve((w + 1) * (h + 1));
        sum.resize(w + 1, 0);
        let mut row = vec![0u32; w];
        let mut out = vec![0u32; w + 1];
        let mut max = 0u32;
        for (y, src) in img.data.chunks_exact(w.max(1)).take(h).enumerate() {
            let mut exact = true;
            for (q, v) in row.iter_mut().zip(src) {
                // f + 2^23 rounds f in [0, 2^23) to an integer, which is then the low bits of
                // its representation (float operations only, so the loop vectorises)
                let f = v * 4.0;
                let g = f + SHIFT;
                exact &= g - SHIFT == f && (0.0..QUARTERS_BELOW).contains(&f);
                *q = g.to_bits().wrapping_sub(SHIFT.to_bits());
            }
            if !exact {
                let _ = SPARE_U32.try_with(|s| s.set(sum));
                return None;
            }
            max = max.max(row.iter().copied().max().unwrap_or(0));
            let prev = &sum[y * (w + 1)..][1..=w];
            let mut acc = 0u32;
            for ((o, p), q) in out[1..].iter_mut().zip(prev).zip(&row) {
                acc = acc.wrapping_add(*q);
                *o = p.wrapping_add(acc);
            }
            sum.extend_from_slice(&out);
        }
        Some(Self { w, h, sums: Sums::Quarters { sum, max } })
    }

    /// The f64 table.
    fn float(img: &ImageF32) -> Self {
        let (w, h) = (img.width, img.height);
        let mut sum = SPARE.try_with(std::cell::Cell::take).unwrap_or_default();
        sum.clear();
        sum.resize((w + 1) * (h + 1), 0.0);
        // each row's prefix sums as CHAINS independent running sums over equal segments, then
        // the segments' offsets and the row above added
        let seg = w.div_ceil(CHAINS).max(1);
        let mut acc = vec![0.0f64; w];
        for (y, src) in img.data.chunks_exact(w.max(1)).take(h).enumerate() {
            let mut run = [0.0f64; CHAINS];
            for k in 0..seg {
                for (c, r) in run.iter_mut().enumerate() {
                    if let Some(v) = src.get(c * seg + k).filter(|_| k < seg) {
                        *r += f64::from(*v);
                        acc[c * seg + k] = *r;
                    }
                }
            }
            let (prev, cur) = sum.split_at_mut((y + 1) * (w + 1));
            let prev = &prev[y * (w + 1)..][1..=w];
            let mut offset = 0.0;
            for ((o, p), a) in cur[1..=w].chunks_mut(seg).zip(prev.chunks(seg)).zip(acc.chunks(seg)) {
                for ((o, p), a) in o.iter_mut().zip(p).zip(a) {
                    *o = p + (offset + a);
                }
                offset += a.last().copied().unwrap_or(0.0);
            }
        }
        Self { w, h, sums: Sums::Float(sum) }
    }
}

impl Drop for Integral {
    fn drop(&mut self) {
        match &mut self.sums {
            Sums::Quarters { sum, .. } => {
                let sum = std::mem::take(sum);
                let _ = SPARE_U32.try_with(|s| s.set(sum));
            }
            Sums::Float(sum) => {
                let sum = std::mem::take(sum);
                let _ = SPARE.try_with(|s| s.set(sum));
            }
        }
    }
}

/// The dark runs of `img` (row by row, left to right) into `runs`: pixels below the mean of the
/// `(2 r + 1)^2` window minus `offset` (compared as `(v + offset) * count < sum`, exact for 8-bit
/// levels and their quarter steps).
pub(super) fn dark_runs(img: &ImageF32, integral: &Integral, r: usize, offset: f32, runs: &mut Vec<Run>) {
    runs.clear();
    let (w, h) = (integral.w, integral.h);
    let mut dark = vec![0u8; w];
    let lo: Vec<usize> = (0..w).map(|x| x.saturating_sub(r)).collect();
    let hi: Vec<usize> = (0..w).map(|x| (x + r + 1).min(w)).collect();
    // columns whose window is not clamped: x in r..w - r - 1
    let inner = r..w.saturating_sub(r + 1).max(r);
    let area = ((2 * r + 1) * (2 * r + 1)) as f64;
    for (y, row) in img.data.chunks_exact(w.max(1)).take(h).enumerate() {
        let (y0, y1) = (y.saturating_sub(r), (y + r + 1).min(h));
        let rows = (y1 - y0) as f64;
        match &integral.sums {
            Sums::Float(sum) => {
                let (top, bot) = (&sum[y0 * (w + 1)..][..=w], &sum[y1 * (w + 1)..][..=w]);
                let offset = f64::from(offset);
                for x in (0..inner.start.min(w)).chain(inner.end..w) {
                    let (a, b) = (lo[x], hi[x]);
                    dark[x] = u8::from((f64::from(row[x]) + offset) * ((b - a) as f64 * rows) < bot[b] - bot[a] - top[b] + top[a]);
                }
                // the unclamped columns in one vectorisable pass: window [x - r, x + r + 1)
                let count = rows * (2 * r + 1) as f64;
                let n = inner.len();
                if n > 0 {
                    let (b0, b1, t0, t1) = (&bot[..n], &bot[2 * r + 1..][..n], &top[..n], &top[2 * r + 1..][..n]);
                    let src = &row[inner.clone()];
                    for (((((d, v), p), q), u), t) in dark[inner.clone()].iter_mut().zip(src).zip(b1).zip(b0).zip(t1).zip(t0) {
                        *d = u8::from((f64::from(*v) + offset) * count < p - q - u + t);
                    }
                }
            }
            Sums::Quarters { sum, max } => {
                let (top, bot) = (&sum[y0 * (w + 1)..][..=w], &sum[y1 * (w + 1)..][..=w]);
                // four times both sides: 4 v + 4 offset against the window's sum of 4 v
                let offset4 = 4.0 * f64::from(offset);
                let window = |a: usize, b: usize| bot[b].wrapping_sub(bot[a]).wrapping_sub(top[b]).wrapping_add(top[a]);
                for x in (0..inner.start.min(w)).chain(inner.end..w) {
                    let (a, b) = (lo[x], hi[x]);
                    dark[x] = u8::from((4.0 * f64::from(row[x]) + offset4) * ((b - a) as f64 * rows) < f64::from(window(a, b)));
                }
                let count = rows * (2 * r + 1) as f64;
                let n = inner.len();
                if n == 0 {
                    push_runs(&dark, y as u32, runs);
                    continue;
                }
                let (b0, b1, t0, t1) = (&bot[..n], &bot[2 * r + 1..][..n], &top[..n], &top[2 * r + 1..][..n]);
                let src = &row[inner.clone()];
                let out = &mut dark[inner.clone()];
                // f32 is exact when the offset is a quarter step and every product and sum stays
                // below 2^24
                let f32_exact = offset4 == offset4.trunc() && (f64::from(*max) + offset4.abs()) * area < f64::from(1u32 << 24);
                if f32_exact {
                    let (offset4, count) = (offset4 as f32, count as f32);
                    for (((((d, v), p), q), u), t) in out.iter_mut().zip(src).zip(b1).zip(b0).zip(t1).zip(t0) {
                        let s = p.wrapping_sub(*q).wrapping_sub(*u).wrapping_add(*t) as i32 as f32;
                        *d = u8::from((4.0 * v + offset4) * count < s);
                    }
                } else {
                    for (((((d, v), p), q), u), t) in out.iter_mut().zip(src).zip(b1).zip(b0).zip(t1).zip(t0) {
                        let s = f64::from(p.wrapping_sub(*q).wrapping_sub(*u).wrapping_add(*t));
                        *d = u8::from((4.0 * f64::from(*v) + offset4) * count < s);
                    }
                }
            }
        }
        push_runs(&dark, y as u32, runs);
    }
}

/// Append the runs of dark pixels (1; light: 0) of row `y`.
fn push_runs(dark: &[u8], y: u32, runs: &mut Vec<Run>) {
    let mut x = 0;
    loop {
        let x0 = next(dark, x, true);
        if x0 >= dark.len() {
            return;
        }
        let x1 = next(dark, x0, false);
        runs.push(Run { y, x0: x0 as u32, x1: x1 as u32 });
        x = x1;
    }
}

/// The first index from `x` whose flag (0 or 1) is `dark`, `flags.len()` when none: eight flags
/// at a time as the bytes of a u64 (most of a row is long stretches of one value).
fn next(flags: &[u8], mut x: usize, dark: bool) -> usize {
    const ONES: u64 = 0x0101_0101_0101_0101;
    while let Some(bytes) = flags.get(x..x + 8).and_then(|b| <[u8; 8]>::try_from(b).ok()) {
        let word = u64::from_le_bytes(bytes);
        let hits = if dark { word } else { word ^ ONES };
        if hits != 0 {
            return x + (hits.trailing_zeros() / 8) as usize;
        }
        x += 8;
    }
    x + flags.get(x..).map_or(0, |rest| rest.iter().position(|f| (*f != 0) == dark).unwrap_or(rest.len()))
}

/// The runs of `runs` (row order) eroded by the 3 x 3 cross: a pixel stays dark when it and its
/// four neighbours are dark (pixels outside the image count as light).
pub(super) fn erode(runs: &[Run]) -> Vec<Run> {
    // each row's runs as a slice
    let mut rows: Vec<(u32, usize, usize)> = Vec::new();
    for (i, r) in runs.iter().enumerate() {
        match rows.last_mut() {
            Some(last) if last.0 == r.y => last.2 = i + 1,
            _ => rows.push((r.y, i, i + 1)),
        }
    }
    let mut out = Vec::new();
    let (mut a, mut b) = (Vec::new(), Vec::new());
    for (k, &(y, s, e)) in rows.iter().enumerate() {
        let above = k.checked_sub(1).map(|j| rows[j]).filter(|r| r.0 + 1 == y);
        let below = rows.get(k + 1).copied().filter(|r| r.0 == y + 1);
        let (Some(above), Some(below)) = (above, below) else { continue };
        a.clear();
        a.extend(runs[s..e].iter().filter(|r| r.x1 > r.x0 + 2).map(|r| (r.x0 + 1, r.x1 - 1)));
        intersect(&a, &runs[above.1..above.2], &mut b);
        intersect(&b, &runs[below.1..below.2], &mut a);
        out.extend(a.iter().map(|&(x0, x1)| Run { y, x0, x1 }));
    }
    out
}

/// `out` = the intersection of the sorted disjoint intervals `a` with the runs `b` of one row.
fn intersect(a: &[(u32, u32)], b: &[Run], out: &mut Vec<(u32, u32)>) {
    out.clear();
    let (mut i, mut j) = (0, 0);
    while i < a.len() && j < b.len() {
        let (x0, x1) = (a[i].0.max(b[j].x0), a[i].1.min(b[j].x1));
        if x0 < x1 {
            out.push((x0, x1));
        }
        if a[i].1 < b[j].x1 {
            i += 1;
        } else {
            j += 1;
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The integer table gives the f64 table's dark pixels on 8-bit levels and their quarter
    /// steps (the half-resolution search image), for every window and offset; other samples take
    /// the f64 table.
    #[test]
    fn integer_and_float_tables_agree() {
        let (w, h) = (53, 41);
        let mut seed = 99u64;
        let mut next = move || {
            seed = seed.wrapping_mul(6364136223846793005).wrapping_add(1442695040888963407);
            (seed >> 33) as u32
        };
        let quarters: Vec<f32> = (0..w * h).map(|_| (next() % 1024) as f32 * 0.25).collect();
        let img = ImageF32::new(w, h, quarters).unwrap();
        let (int, float) = (Integral::new(&img), Integral::float(&img));
        assert!(matches!(int.sums, Sums::Quarters { .. }) && matches!(float.sums, Sums::Float(_)));
        let (mut a, mut b) = (Vec::new(), Vec::new());
        for r in [0, 1, 4, 13, 30] {
            for offset in [7.0, 0.0, -3.0, 2.3, 255.0] {
                dark_runs(&img, &int, r, offset, &mut a);
                dark_runs(&img, &float, r, offset, &mut b);
                assert_eq!(a, b, "r {r} offset {offset}");
            }
        }
        for bad in [0.1f32, -0.25, 256.0, f32::NAN] {
            let mut img = img.clone();
            img.data[7] = bad;
            assert!(matches!(Integral::new(&img).sums, Sums::Float(_)), "{bad}");
        }
    }

    #[test]
    fn runs_of_a_row() {
        let mut runs = Vec::new();
        for n in [0usize, 1, 7, 8, 9, 17, 40] {
            for seed in 0..40u64 {
                let flags: Vec<u8> = (0..n).map(|k| u8::from((seed.wrapping_mul(2654435761) >> (k % 29)) & 1 == 1 || (k as u64 + seed) % 11 < 3)).collect();
                runs.clear();
                push_runs(&flags, 3, &mut runs);
                let mut back = vec![0u8; n];
                for r in &runs {
                    assert!(r.x0 < r.x1 && r.y == 3);
                    back[r.x0 as usize..r.x1 as usize].iter_mut().for_each(|f| *f = 1);
                }
                assert_eq!(back, flags);
                assert!(runs.windows(2).all(|p| p[0].x1 < p[1].x0), "runs are maximal");
            }
        }
    }

    #[test]
    fn erosion_by_a_cross() {
        let run = |y, x0, x1| Run { y, x0, x1 };
        // a 5 x 3 block and a diagonal neighbour: only the block's middle row survives, shrunk
        let runs = [run(0, 0, 5), run(1, 0, 5), run(2, 0, 5), run(3, 5, 6)];
        assert_eq!(erode(&runs), vec![run(1, 1, 4)]);
        // a hole above splits the eroded row (the pixel below the gap goes)
        let runs = [run(0, 0, 3), run(0, 4, 9), run(1, 0, 9), run(2, 0, 9)];
        assert_eq!(erode(&runs), vec![run(1, 1, 3), run(1, 4, 8)]);
    }
}
