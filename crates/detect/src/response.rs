//! Saddle-point response: Gaussian smoothing then R = fxy^2 - fxx * fyy (minus the Hessian
//! determinant; positive at X-junctions, ~0 on straight edges, negative on blobs), with
//! non-maximum suppression into a candidate list.
//!
//! Reference: L. Lucchese, S. Mitra, "Using saddle points for subpixel feature detection in camera
//! calibration targets", APCCAS 2002; P. Beaudet, "Rotationally invariant image operators",
//! ICPR 1978 (Hessian determinant).

use nalgebra::Point2;
use rayon::prelude::*;

use super::par::{worth_parallel, PARALLEL_MIN_PIXELS};
use super::ImageF32;

/// Smoothed image and saddle response map of the same size.
#[derive(Debug, Clone)]
pub struct ResponseMap {
    /// Gaussian-smoothed image.
    pub smooth: ImageF32,
    /// Saddle response fxy^2 - fxx*fyy (0 on the 1-pixel border).
    pub response: ImageF32,
}

/// A corner candidate (local maximum of the response).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Candidate {
    /// Sub-pixel position (quadratic peak fit), pixels.
    pub point: Point2<f64>,
    /// Response at the peak pixel.
    pub strength: f32,
}

fn gaussian_kernel(sigma: f64) -> Vec<f32> {
    let r = (3.0 * sigma).ceil().max(1.0) as i64;
    let mut k: Vec<f64> = (-r..=r).map(|i| (-((i * i) as f64) / (2.0 * sigma * sigma)).exp()).collect();
    let s: f64 = k.iter().sum();
    k.iter_mut().for_each(|v| *v /= s);
    k.into_iter().map(|v| v as f32).collect()
}

/// Separable Gaussian blur with clamped borders (rows in parallel for large images).
pub fn gaussian_blur(img: &ImageF32, sigma: f64) -> ImageF32 {
    let (w, h) = (img.width, img.height);
    if w == 0 || h == 0 || !(sigma > 0.0) {
        return img.clone();
    }
    let k = gaussian_kernel(sigma);
    let r = k.len() / 2;
    let par = worth_parallel(w * h, PARALLEL_MIN_PIXELS);
    // horizontal
    let mut tmp = super::pool::zeroed(w * h);
    let hpass = |(y, out): (usize, &mut [f32])| {
        let src = &img.data[y * w..(y + 1) * w];
        if w > 2 * r {
            // interior: one vectorisable axpy per tap
            let n = w - 2 * r;
            let o = &mut out[r..r + n];
            for (t, kv) in k.iter().enumerate() {
                for (a, b) in o.iter_mut().zip(src[t..t + n].iter()) {
                    *a += b * kv;
                }
            }
        }
        for (x, o) in out.iter_mut().enumerate() {
            if x >= r && x + r < w {
                continue;
            }
            let mut acc = 0.0f32;
            for (i, kv) in k.iter().enumerate() {
                let xx = (x as i64 + i as i64 - r as i64).clamp(0, w as i64 - 1) as usize;
                acc += src[xx] * kv;
            }
            *o = acc;
        }
    };
    if par {
        tmp.par_chunks_mut(w).enumerate().for_each(hpass);
    } else {
        tmp.chunks_mut(w).enumerate().for_each(hpass);
    }
    // vertical
    let mut out = super::pool::zeroed(w * h);
    let vpass = |(y, o): (usize, &mut [f32])| {
        for (i, kv) in k.iter().enumerate() {
            let yy = (y as i64 + i as i64 - r as i64).clamp(0, h as i64 - 1) as usize;
            let src = &tmp[yy * w..(yy + 1) * w];
            for (a, b) in o.iter_mut().zip(src.iter()) {
                *a += b * kv;
            }
        }
    };
    if par {
        out.par_chunks_mut(w).enumerate().for_each(vpass);
    } else {
        out.chunks_mut(w).enumerate().for_each(vpass);
    }
    super::pool::recycle(tmp);
    ImageF32 { width: w, height: h, data: out }
}

/// 5-tap binomial blur [1 4 6 4 1] / 16 (sigma = 1) in both directions, clamped borders; per
/// output row a vertical pass into a row buffer then a horizontal pass (no full-size temporary),
/// written as slice arithmetic so it vectorises.
pub fn binomial_blur(img: &ImageF32) -> ImageF32 {
    let (w, h) = (img.width, img.height);
    if w < 5 || h < 5 {
        return gaussian_blur(img, 1.0);
    }
    let src = &img.data;
    let row_job = |buf: &mut Vec<f32>, (y, o): (usize, &mut [f32])| {
        let row = |k: i64| {
            let yy = (y as i64 + k).clamp(0, h as i64 - 1) as usize;
            &src[yy * w..(yy + 1) * w]
        };
        let (a, b, c, d, e) = (row(-2), row(-1), row(0), row(1), row(2));
        buf.clear();
        buf.resize(w, 0.0);
        for (((((v, a), b), c), d), e) in buf.iter_mut().zip(a).zip(b).zip(c).zip(d).zip(e) {
            *v = (a + e) + 4.0 * (b + d) + 6.0 * c;
        }
        let s = &buf[..];
        let n = w - 4;
        let (a, b, c, d, e) = (&s[0..n], &s[1..n + 1], &s[2..n + 2], &s[3..n + 3], &s[4..n + 4]);
        for (i, out) in o[2..w - 2].iter_mut().enumerate() {
            *out = ((a[i] + e[i]) + 4.0 * (b[i] + d[i]) + 6.0 * c[i]) * (1.0 / 256.0);
        }
        let at = |x: i64| s[x.clamp(0, w as i64 - 1) as usize];
        for x in [0usize, 1, w - 2, w - 1] {
            let xi = x as i64;
            o[x] = ((at(xi - 2) + at(xi + 2)) + 4.0 * (at(xi - 1) + at(xi + 1)) + 6.0 * at(xi)) * (1.0 / 256.0);
        }
    };
    let mut out = super::pool::scratch(w * h);
    if worth_parallel(w * h, PARALLEL_MIN_PIXELS) {
        out.par_chunks_mut(w).enumerate().for_each_init(|| Vec::with_capacity(w), row_job);
    } else {
        let mut buf = Vec::with_capacity(w);
        out.chunks_mut(w).enumerate().for_each(|r| row_job(&mut buf, r));
    }
    ImageF32 { width: w, height: h, data: out }
}

/// Smooth with `sigma` (exactly 1.0 uses the 5-tap binomial kernel) and compute the saddle
/// response.
pub fn saddle_response(img: &ImageF32, sigma: f64) -> ResponseMap {
    let smooth = if sigma == 1.0 { binomial_blur(img) } else { gaussian_blur(img, sigma) };
    let (w, h) = (img.width, img.height);
    let mut resp = super::pool::zeroed(w * h);
    if w >= 3 && h >= 3 {
        let s = &smooth.data;
        let row = |(y, o): (usize, &mut [f32])| {
            if y == 0 || y + 1 >= h {
                return;
            }
            let (a, b, c) = (&s[(y - 1) * w..y * w], &s[y * w..(y + 1) * w], &s[(y + 1) * w..(y + 2) * w]);
            // shifted slices of equal length (x - 1, x, x + 1) so that the loop vectorises
            let n = w - 2;
            let (am, a0, ap) = (&a[..n], &a[1..n + 1], &a[2..]);
            let (bm, b0, bp) = (&b[..n], &b[1..n + 1], &b[2..]);
            let (cm, c0, cp) = (&c[..n], &c[1..n + 1], &c[2..]);
            for (i, o) in o[1..w - 1].iter_mut().enumerate() {
                let fxx = bp[i] - 2.0 * b0[i] + bm[i];
                let fyy = c0[i] - 2.0 * b0[i] + a0[i];
                let fxy = 0.25 * (cp[i] - cm[i] - ap[i] + am[i]);
                *o = fxy * fxy - fxx * fyy;
            }
        };
        if worth_parallel(w * h, PARALLEL_MIN_PIXELS) {
            resp.par_chunks_mut(w).enumerate().for_each(row);
        } else {
            resp.chunks_mut(w).enumerate().for_each(row);
        }
    }
    ResponseMap { smooth, response: ImageF32 { width: w, height: h, data: resp } }
}

/// Sub-pixel peak of `r` at integer (x, y) by a separable quadratic fit (offset clamped to +-0.5).
pub fn peak_subpixel(r: &ImageF32, x: usize, y: usize) -> Point2<f64> {
    let w = r.width;
    if x == 0 || y == 0 || x + 1 >= w || y + 1 >= r.height {
        return Point2::new(x as f64, y as f64);
    }
    let c = f64::from(r.data[y * w + x]);
    let off = |m: f64, p: f64| {
        let den = m - 2.0 * c + p;
        if den < -1e-12 {
            (0.5 * (m - p) / den).clamp(-0.5, 0.5)
        } else {
            0.0
        }
    };
    let dx = off(f64::from(r.data[y * w + x - 1]), f64::from(r.data[y * w + x + 1]));
    let dy = off(f64::from(r.data[(y - 1) * w + x]), f64::from(r.data[(y + 1) * w + x]));
    Point2::new(x as f64 + dx, y as f64 + dy)
}

/// Reach of the smoothing of [`saddle_response`] with `sigma`, pixels (kernel radius).
fn blur_reach(sigma: f64) -> usize {
    if sigma == 1.0 {
        2
    } else {
        (3.0 * sigma).ceil().max(1.0) as usize
    }
}

/// The saddle-response peak near `p` in `img`, with the response recomputed on a small patch only:
/// the strongest response within `radius` px of `p`, hill-climbed to a local maximum and located
/// to sub-pixel by [`peak_subpixel`]. Away from the patch border (blur reach + 2 px) the patch
/// response equals that of [`saddle_response`] on the whole image, so the peak is the one a
/// full-image search finds there. `None` near the image border, for a non-positive peak, or when
/// the climb reaches the patch margin.
pub fn local_peak(img: &ImageF32, p: Point2<f64>, radius: usize, sigma: f64) -> Option<Point2<f64>> {
    const CLIMB: usize = 2;
    if !p.x.is_finite() || !p.y.is_finite() {
        return None;
    }
    let margin = blur_reach(sigma) + 2;
    let half = (radius + CLIMB + margin) as i64;
    let (cx, cy) = (p.x.round() as i64, p.y.round() as i64);
    if cx - half < 1 || cy - half < 1 || cx + half + 1 >= img.width as i64 || cy + half + 1 >= img.height as i64 {
        return None;
    }
    let n = (2 * half + 1) as usize;
    let (x0, y0) = ((cx - half) as usize, (cy - half) as usize);
    let mut data = Vec::with_capacity(n * n);
    for y in y0..y0 + n {
        data.extend_from_slice(&img.data[y * img.width + x0..][..n]);
    }
    let resp = saddle_response(&ImageF32 { width: n, height: n, data }, sigma).response;
    let at = |x: usize, y: usize| resp.data[y * n + x];
    // strongest pixel in the disc, then climb to a local maximum inside the valid region
    let (px, py) = (p.x - x0 as f64, p.y - y0 as f64);
    let r2 = (radius * radius) as f64;
    let mut best: Option<(usize, usize, f32)> = None;
    for y in margin..n - margin {
        for x in margin..n - margin {
            let d2 = (x as f64 - px).powi(2) + (y as f64 - py).powi(2);
            if d2 <= r2 && best.is_none_or(|b| at(x, y) > b.2) {
                best = Some((x, y, at(x, y)));
            }
        }
    }
    let (mut x, mut y, mut v) = best?;
    loop {
        if x <= margin || y <= margin || x + margin + 1 >= n || y + margin + 1 >= n {
            return None;
        }
        let mut moved = false;
        for (dx, dy) in [(-1i64, -1i64), (0, -1), (1, -1), (-1, 0), (1, 0), (-1, 1), (0, 1), (1, 1)] {
            let (xx, yy) = ((x as i64 + dx) as usize, (y as i64 + dy) as usize);
            if at(xx, yy) > v {
                (x, y, v, moved) = (xx, yy, at(xx, yy), true);
            }
        }
        if !moved {
            break;
        }
    }
    if !(v > 0.0) {
        return None;
    }
    let q = peak_subpixel(&resp, x, y);
    Some(Point2::new(q.x + x0 as f64, q.y + y0 as f64))
}

/// Samples per block of the candidate scan's threshold pre-check.
const BLOCK: usize = 16;

/// Maximum of a short slice with plain comparisons (vectorises; NaN samples ignored).
fn max_or_neg_inf(v: &[f32]) -> f32 {
    v.iter().fold(f32::NEG_INFINITY, |m, &x| if x > m { x } else { m })
}

/// Maximum of `v` and 0 (NaN samples ignored), lane-wise with plain comparisons so that it
/// vectorises.
fn max_or_zero(v: &[f32]) -> f32 {
    const L: usize = 16;
    let mut acc = [0.0f32; L];
    let chunks = v.chunks_exact(L);
    let tail = chunks.remainder();
    for c in chunks {
        for (a, &x) in acc.iter_mut().zip(c) {
            *a = if x > *a { x } else { *a };
        }
    }
    acc.iter().chain(tail).copied().fold(0.0f32, f32::max)
}

/// Local maxima of the response over a (2 `nms_radius` + 1)^2 window above
/// `rel_threshold` x the global maximum, strongest first, at most `max_count`.
pub fn find_candidates(r: &ImageF32, nms_radius: usize, rel_threshold: f32, max_count: usize) -> Vec<Candidate> {
    let (w, h) = (r.width, r.height);
    let maxv =
        if worth_parallel(w * h, PARALLEL_MIN_PIXELS) { r.data.par_chunks(w.max(1)).map(max_or_zero).reduce(|| 0.0, f32::max) } else { max_or_zero(&r.data) };
    if !(maxv > 0.0) || w < 3 || h < 3 {
        return Vec::new();
    }
    let thr = maxv * rel_threshold;
    let nr = nms_radius.max(1);
    let scan_row = |y: usize| -> Vec<Candidate> {
        let mut found = Vec::new();
        let row = &r.data[y * w..(y + 1) * w];
        let up = &r.data[(y - 1) * w..y * w];
        let dn = &r.data[(y + 1) * w..(y + 2) * w];
        let mut x = 1;
        while x < w - 1 {
            // skip runs of BLOCK samples at or below the threshold (most of the image) at once
            if let Some(block) = row.get(x..x + BLOCK) {
                if max_or_neg_inf(block) <= thr {
                    x += BLOCK;
                    continue;
                }
            }
            let v = row[x];
            x += 1;
            if v <= thr {
                continue;
            }
            let x = x - 1;
            if row[x - 1] > v || row[x + 1] > v || up[x] > v || dn[x] > v || up[x - 1] > v || up[x + 1] > v || dn[x - 1] > v || dn[x + 1] > v {
                continue;
            }
            let mut is_max = true;
            'scan: for yy in y.saturating_sub(nr)..=(y + nr).min(h - 1) {
                let rr = &r.data[yy * w..(yy + 1) * w];
                let x0 = x.saturating_sub(nr);
                for (xx, &u) in rr.iter().enumerate().take((x + nr).min(w - 1) + 1).skip(x0) {
                    // strict on one side to break plateaus deterministically
                    if u > v || (u == v && (yy, xx) < (y, x)) {
                        is_max = false;
                        break 'scan;
                    }
                }
            }
            if is_max {
                found.push(Candidate { point: peak_subpixel(r, x, y), strength: v });
            }
        }
        found
    };
    let mut out: Vec<Candidate> = if worth_parallel(w * h, PARALLEL_MIN_PIXELS) {
        (1..h - 1).into_par_iter().flat_map_iter(scan_row).collect()
    } else {
        (1..h - 1).flat_map(scan_row).collect()
    };
    out.sort_by(|a, b| b.strength.total_cmp(&a.strength));
    out.truncate(max_count);
    out
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn local_peak_equals_the_full_image_peak() {
        let img = crate::saddle_fit::tests::saddle(15.3, 14.6, 0.3, 1.9);
        let full = saddle_response(&img, 1.0);
        let c = find_candidates(&full.response, 3, 0.5, 1)[0];
        for seed in [Point2::new(15.0, 15.0), Point2::new(13.6, 16.2), Point2::new(16.9, 13.4)] {
            let q = local_peak(&img, seed, 2, 1.0).expect("peak");
            assert_eq!((q.x, q.y), (c.point.x, c.point.y), "seed {seed}");
        }
        assert!(local_peak(&img, Point2::new(2.0, 15.0), 2, 1.0).is_none());
    }
}
