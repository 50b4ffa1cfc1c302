//! Adaptive mean threshold, as OpenCV's `adaptiveThreshold(ADAPTIVE_THRESH_MEAN_C,
//! THRESH_BINARY_INV)` in the ArUco detector: a pixel is dark when it lies more than an offset
//! below the mean of the square window around it (clamped to the image). The dark pixels come
//! out as horizontal runs, the input of the run-based component labelling.
//!
//! Reference: OpenCV `modules/objdetect/src/aruco/aruco_detector.cpp` (`_threshold`); F. C. Crow,
//! "Summed-area tables for texture mapping", SIGGRAPH 1984.

use crate::detect::ImageF32;

/// Summed-area table of an image, `(w + 1) x (h + 1)`, f64 (exact for 8-bit sums).
pub(super) struct Integral {
    w: usize,
    h: usize,
    sum: Vec<f64>,
}

impl Integral {
    /// The table of `img` (whose samples must be finite).
    pub(super) fn new(img: &ImageF32) -> Self {
        let (w, h) = (img.width, img.height);
        let mut sum = vec![0.0f64; (w + 1) * (h + 1)];
        for (y, src) in img.data.chunks_exact(w.max(1)).take(h).enumerate() {
            let (prev, cur) = sum.split_at_mut((y + 1) * (w + 1));
            let prev = &prev[y * (w + 1)..];
            let mut acc = 0.0;
            for ((o, p), v) in cur[1..=w].iter_mut().zip(&prev[1..]).zip(src) {
                acc += f64::from(*v);
                *o = p + acc;
            }
        }
        Self { w, h, sum }
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
/// `(2 r + 1)^2` window minus `offset`.
pub(super) fn dark_runs(img: &ImageF32, integral: &Integral, r: usize, offset: f32, runs: &mut Vec<Run>) {
    runs.clear();
    let (w, h) = (integral.w, integral.h);
    let mut thr = vec![0.0f32; w];
    let lo: Vec<usize> = (0..w).map(|x| x.saturating_sub(r)).collect();
    let hi: Vec<usize> = (0..w).map(|x| (x + r + 1).min(w)).collect();
    let inv_cols: Vec<f64> = lo.iter().zip(&hi).map(|(a, b)| 1.0 / (b - a) as f64).collect();
    // columns whose window is not clamped: x in r..w - r - 1
    let inner = r..w.saturating_sub(r + 1).max(r);
    for (y, row) in img.data.chunks_exact(w.max(1)).take(h).enumerate() {
        let (y0, y1) = (y.saturating_sub(r), (y + r + 1).min(h));
        let top = &integral.sum[y0 * (w + 1)..][..=w];
        let bot = &integral.sum[y1 * (w + 1)..][..=w];
        let inv_rows = 1.0 / (y1 - y0) as f64;
        for x in (0..inner.start.min(w)).chain(inner.end..w) {
            let (a, b) = (lo[x], hi[x]);
            thr[x] = ((bot[b] - bot[a] - top[b] + top[a]) * inv_cols[x] * inv_rows) as f32 - offset;
        }
        // the unclamped columns in one vectorisable pass: window [x - r, x + r + 1)
        let scale = inv_rows / (2 * r + 1) as f64;
        let n = inner.len();
        if n > 0 {
            let (b0, b1, t0, t1) = (&bot[..n], &bot[2 * r + 1..][..n], &top[..n], &top[2 * r + 1..][..n]);
            for ((((t, p), q), u), v) in thr[inner.clone()].iter_mut().zip(b1).zip(b0).zip(t1).zip(t0) {
                *t = ((p - q - u + v) * scale) as f32 - offset;
            }
        }
        push_runs(row, &thr, y as u32, runs);
    }
}

/// Append the runs of `row[x] < thr[x]` in row `y`.
fn push_runs(row: &[f32], thr: &[f32], y: u32, runs: &mut Vec<Run>) {
    let mut start: Option<usize> = None;
    for (x, (v, t)) in row.iter().zip(thr).enumerate() {
        match (v < t, start) {
            (true, None) => start = Some(x),
            (false, Some(s)) => {
                runs.push(Run { y, x0: s as u32, x1: x as u32 });
                start = None;
            }
            _ => {}
        }
    }
    if let Some(s) = start {
        runs.push(Run { y, x0: s as u32, x1: row.len() as u32 });
    }
}
