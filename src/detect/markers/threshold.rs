//! Adaptive mean threshold, as OpenCV's `adaptiveThreshold(ADAPTIVE_THRESH_MEAN_C,
//! THRESH_BINARY_INV)` in the ArUco detector: a pixel is dark when it lies more than an offset
//! below the mean of the square window around it (clamped to the image). The dark pixels come
//! out as horizontal runs, the input of the run-based component labelling; `erode` removes the
//! dark pixels with a light 4-neighbour (binary erosion by a cross), which cuts dark shapes that
//! touch only at a corner.
//!
//! Reference: OpenCV `modules/objdetect/src/aruco/aruco_detector.cpp` (`_threshold`); F. C. Crow,
//! "Summed-area tables for texture mapping", SIGGRAPH 1984.

use crate::detect::ImageF32;

/// Summed-area table of an image, `(w + 1) x (h + 1)`, f64 (exact for 8-bit sums). Its buffer
/// is reused by the next table built on the same thread (a fresh one of a few megabytes costs a
/// page fault per 4 KiB written, more than the sums themselves).
pub(super) struct Integral {
    w: usize,
    h: usize,
    sum: Vec<f64>,
}

thread_local! {
    /// The buffer of the last dropped [`Integral`] of this thread.
    static SPARE: std::cell::Cell<Vec<f64>> = const { std::cell::Cell::new(Vec::new()) };
}

/// Row segments summed as independent chains in [`Integral::new`] (latency of the additions).
const CHAINS: usize = 4;

impl Integral {
    /// The table of `img` (whose samples must be finite).
    pub(super) fn new(img: &ImageF32) -> Self {
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
        Self { w, h, sum }
    }
}

impl Drop for Integral {
    fn drop(&mut self) {
        let sum = std::mem::take(&mut self.sum);
        let _ = SPARE.try_with(|s| s.set(sum));
    }
}

/// A horizontal run of dark pixels: row `y`, columns `x0..x1`.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub(super) struct Run {
    /// Row.
    pub y: u32,
    /// First column.
    pub x0: u32,
    /// One past the last column.
    pub x1: u32,
}

/// The dark runs of `img` (row by row, left to right) into `runs`: pixels below the mean of the
/// `(2 r + 1)^2` window minus `offset` (compared as `(v + offset) * count < sum`, exact for 8-bit
/// levels).
pub(super) fn dark_runs(img: &ImageF32, integral: &Integral, r: usize, offset: f32, runs: &mut Vec<Run>) {
    runs.clear();
    let (w, h) = (integral.w, integral.h);
    let offset = f64::from(offset);
    let mut dark = vec![false; w];
    let lo: Vec<usize> = (0..w).map(|x| x.saturating_sub(r)).collect();
    let hi: Vec<usize> = (0..w).map(|x| (x + r + 1).min(w)).collect();
    // columns whose window is not clamped: x in r..w - r - 1
    let inner = r..w.saturating_sub(r + 1).max(r);
    for (y, row) in img.data.chunks_exact(w.max(1)).take(h).enumerate() {
        let (y0, y1) = (y.saturating_sub(r), (y + r + 1).min(h));
        let top = &integral.sum[y0 * (w + 1)..][..=w];
        let bot = &integral.sum[y1 * (w + 1)..][..=w];
        let rows = (y1 - y0) as f64;
        for x in (0..inner.start.min(w)).chain(inner.end..w) {
            let (a, b) = (lo[x], hi[x]);
            dark[x] = (f64::from(row[x]) + offset) * ((b - a) as f64 * rows) < bot[b] - bot[a] - top[b] + top[a];
        }
        // the unclamped columns in one vectorisable pass: window [x - r, x + r + 1)
        let count = rows * (2 * r + 1) as f64;
        let n = inner.len();
        if n > 0 {
            let (b0, b1, t0, t1) = (&bot[..n], &bot[2 * r + 1..][..n], &top[..n], &top[2 * r + 1..][..n]);
            let src = &row[inner.clone()];
            for (((((d, v), p), q), u), t) in dark[inner.clone()].iter_mut().zip(src).zip(b1).zip(b0).zip(t1).zip(t0) {
                *d = (f64::from(*v) + offset) * count < p - q - u + t;
            }
        }
        push_runs(&dark, y as u32, runs);
    }
}

/// Append the runs of dark pixels of row `y`.
fn push_runs(dark: &[bool], y: u32, runs: &mut Vec<Run>) {
    let mut x = 0;
    while let Some(k) = dark[x..].iter().position(|d| *d) {
        let x0 = x + k;
        let x1 = dark[x0..].iter().position(|d| !*d).map_or(dark.len(), |k| x0 + k);
        runs.push(Run { y, x0: x0 as u32, x1: x1 as u32 });
        x = x1;
    }
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
