//! Separable running minimum and maximum filters (square window), O(1) per pixel with a monotonic
//! deque, borders clamped to the image.
//!
//! Reference: M. van Herk, "A fast algorithm for local minimum and maximum filters on rectangular
//! and octagonal kernels", Pattern Recognition Letters 13 (1992); the deque form is Lemire's
//! "Streaming maximum-minimum filter using no more than three comparisons per element" (2006).

use std::collections::VecDeque;

use super::ImageF32;

/// Running extreme of `src` over windows `[i - r, i + r]` (clamped), `max = true` for maximum.
fn running_1d(src: &[f32], r: usize, max: bool, out: &mut [f32]) {
    let n = src.len();
    let better = |a: f32, b: f32| if max { a >= b } else { a <= b };
    let mut dq: VecDeque<usize> = VecDeque::new();
    let mut next = 0;
    for (i, o) in out.iter_mut().enumerate().take(n) {
        let hi = (i + r).min(n - 1);
        while next <= hi {
            while dq.back().is_some_and(|&b| better(src[next], src[b])) {
                dq.pop_back();
            }
            dq.push_back(next);
            next += 1;
        }
        let lo = i.saturating_sub(r);
        while dq.front().is_some_and(|&f| f < lo) {
            dq.pop_front();
        }
        *o = dq.front().map_or(src[i], |&f| src[f]);
    }
}

/// Minimum (`max = false`) or maximum over the (2r+1) x (2r+1) window around every pixel.
pub fn extreme_filter(img: &ImageF32, r: usize, max: bool) -> ImageF32 {
    let (w, h) = (img.width, img.height);
    if w == 0 || h == 0 {
        return img.clone();
    }
    let mut tmp = vec![0.0f32; w * h];
    for (src, dst) in img.data.chunks(w).zip(tmp.chunks_mut(w)) {
        running_1d(src, r, max, dst);
    }
    let mut out = vec![0.0f32; w * h];
    let mut col = vec![0.0f32; h];
    let mut res = vec![0.0f32; h];
    for x in 0..w {
        for y in 0..h {
            col[y] = tmp[y * w + x];
        }
        running_1d(&col, r, max, &mut res);
        for y in 0..h {
            out[y * w + x] = res[y];
        }
    }
    ImageF32 { width: w, height: h, data: out }
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
