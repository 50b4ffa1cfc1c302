//! Minimal owned grey images (f32 and u8 samples), row-major, OpenCV pixel convention, and the
//! window access the sub-pixel fits share.

use super::DetectError;

/// Grey image with f32 samples.
#[derive(Debug, Clone, PartialEq)]
pub struct ImageF32 {
    /// Width, pixels.
    pub width: usize,
    /// Height, pixels.
    pub height: usize,
    /// Row-major samples.
    pub data: Vec<f32>,
}

/// Large sample buffers go back to the per-thread `pool` for the next image.
impl Drop for ImageF32 {
    fn drop(&mut self) {
        super::pool::recycle(std::mem::take(&mut self.data));
    }
}

impl ImageF32 {
    /// Wrap a buffer.
    ///
    /// # Errors
    /// [`DetectError::BadBuffer`] when `data.len() != width * height`.
    pub fn new(width: usize, height: usize, data: Vec<f32>) -> Result<Self, DetectError> {
        if data.len() != width * height {
            return Err(DetectError::BadBuffer { expected: width * height, actual: data.len() });
        }
        Ok(Self { width, height, data })
    }

    /// The image centre, pixels (OpenCV convention: `((width - 1) / 2, (height - 1) / 2)`).
    pub fn centre_px(&self) -> nalgebra::Point2<f64> {
        nalgebra::Point2::new((self.width as f64 - 1.0) / 2.0, (self.height as f64 - 1.0) / 2.0)
    }

    /// From 8-bit samples.
    ///
    /// # Errors
    /// As [`ImageF32::new`].
    pub fn from_u8(width: usize, height: usize, data: &[u8]) -> Result<Self, DetectError> {
        Self::new(width, height, data.iter().map(|v| f32::from(*v)).collect())
    }

    /// Sample at integer coordinates (no bounds check beyond the slice's own).
    #[inline]
    pub fn at(&self, x: usize, y: usize) -> f32 {
        self.data[y * self.width + x]
    }

    /// True when every sample is finite. Branch-free lane-wise accumulation (x * 0 is NaN exactly
    /// for non-finite x) so that the loop vectorises.
    pub fn all_finite(&self) -> bool {
        const L: usize = 16;
        let mut acc = [0.0f32; L];
        let chunks = self.data.chunks_exact(L);
        let tail = chunks.remainder();
        for c in chunks {
            for (a, v) in acc.iter_mut().zip(c) {
                *a += v * 0.0;
            }
        }
        acc.iter().chain(tail).all(|v| v.is_finite())
    }

    /// 2 x 2 box downsampling to `width / 2` x `height / 2` (odd last row / column dropped); pixel i
    /// of the result covers pixels 2i and 2i + 1 (centre 2i + 0.5 in this image).
    pub fn half(&self) -> ImageF32 {
        self.half_checked().0
    }

    /// [`ImageF32::half`] and [`ImageF32::all_finite`] in one pass over the samples (the check
    /// rides along the memory-bound downsampling: x * 0 is 0 for finite x, NaN otherwise, summed
    /// per output column).
    pub fn half_checked(&self) -> (ImageF32, bool) {
        let (w, h) = (self.width / 2, self.height / 2);
        let mut data = super::pool::scratch(w * h);
        let mut nan = vec![0.0f32; w];
        if w > 0 {
            for (y, o) in data.chunks_exact_mut(w).enumerate() {
                let r0 = &self.data[2 * y * self.width..][..2 * w];
                let r1 = &self.data[(2 * y + 1) * self.width..][..2 * w];
                for (((o, a), b), z) in o.iter_mut().zip(r0.chunks_exact(2)).zip(r1.chunks_exact(2)).zip(nan.iter_mut()) {
                    *o = 0.25 * (a[0] + a[1] + b[0] + b[1]);
                    *z += (a[0] * 0.0 + a[1] * 0.0) + (b[0] * 0.0 + b[1] * 0.0);
                }
            }
        }
        // samples outside the 2w x 2h block: the odd last column and row
        let last_col_ok = self.width.is_multiple_of(2) || self.data.chunks_exact(self.width).all(|r| r[self.width - 1].is_finite());
        let last_row_ok = self.height.is_multiple_of(2) || self.data[(self.height - 1) * self.width..].iter().all(|v| v.is_finite());
        let finite = nan.iter().all(|z| *z == 0.0) && last_col_ok && last_row_ok;
        (ImageF32 { width: w, height: h, data }, finite)
    }
}

/// Grey image with 8-bit samples: the chessboard detector works on it directly (the pyramid is
/// built from it and the sub-pixel fits read their windows from it), so a decoded 8-bit image
/// never has to be converted to f32 as a whole.
#[derive(Debug, Clone, PartialEq)]
pub struct ImageU8 {
    /// Width, pixels.
    pub width: usize,
    /// Height, pixels.
    pub height: usize,
    /// Row-major samples.
    pub data: Vec<u8>,
}

impl ImageU8 {
    /// Wrap a buffer.
    ///
    /// # Errors
    /// [`DetectError::BadBuffer`] when `data.len() != width * height`.
    pub fn new(width: usize, height: usize, data: Vec<u8>) -> Result<Self, DetectError> {
        if data.len() != width * height {
            return Err(DetectError::BadBuffer { expected: width * height, actual: data.len() });
        }
        Ok(Self { width, height, data })
    }

    /// The same image with f32 samples.
    pub fn to_f32(&self) -> ImageF32 {
        let mut data = super::pool::scratch(self.data.len());
        for (o, v) in data.iter_mut().zip(&self.data) {
            *o = f32::from(*v);
        }
        ImageF32 { width: self.width, height: self.height, data }
    }

    /// 2 x 2 box downsampling into f32, bit-identical to `self.to_f32().half()` (the sum of four
    /// 8-bit samples is exact in f32) at a quarter of the memory traffic.
    pub fn half(&self) -> ImageF32 {
        let (w, h) = (self.width / 2, self.height / 2);
        let mut data = super::pool::scratch(w * h);
        if w > 0 {
            for (y, o) in data.chunks_exact_mut(w).enumerate() {
                let r0 = &self.data[2 * y * self.width..][..2 * w];
                let r1 = &self.data[(2 * y + 1) * self.width..][..2 * w];
                half_row_u8(r0, r1, o);
            }
        }
        ImageF32 { width: w, height: h, data }
    }
}

/// One output row of [`ImageU8::half`] from input rows `r0`, `r1` (each `2 * o.len()` long), in
/// fixed blocks that the compiler vectorises: vertical u16 sums, then each lane pair
/// (read as one u32) added.
fn half_row_u8(r0: &[u8], r1: &[u8], o: &mut [f32]) {
    const B: usize = 16;
    let blocks = o.len() / B;
    for ((ob, a), b) in o.chunks_exact_mut(B).zip(r0.chunks_exact(2 * B)).zip(r1.chunks_exact(2 * B)) {
        let mut v = [0u32; B];
        for (k, v) in v.iter_mut().enumerate() {
            let lo = u32::from(a[2 * k]) + u32::from(b[2 * k]);
            let hi = u32::from(a[2 * k + 1]) + u32::from(b[2 * k + 1]);
            *v = lo + hi;
        }
        for (o, v) in ob.iter_mut().zip(v) {
            *o = 0.25 * v as f32;
        }
    }
    for (x, o) in o.iter_mut().enumerate().skip(blocks * B) {
        *o = 0.25 * (u32::from(r0[2 * x]) + u32::from(r0[2 * x + 1]) + u32::from(r1[2 * x]) + u32::from(r1[2 * x + 1])) as f32;
    }
}

/// Read access to a grey image's samples as f64, for fits that copy a small window.
pub trait GreyWindow: Sync {
    /// Width, pixels.
    fn width(&self) -> usize;
    /// Height, pixels.
    fn height(&self) -> usize;
    /// Append the `n` samples of row `y` starting at column `x0` (all inside the image) to `out`.
    fn push_row(&self, y: usize, x0: usize, n: usize, out: &mut Vec<f64>);
}

/// The same row access for both sample types (row-major `data`, `width` samples per row).
macro_rules! grey_window {
    ($($t:ty),*) => {$(
        impl GreyWindow for $t {
            fn width(&self) -> usize {
                self.width
            }
            fn height(&self) -> usize {
                self.height
            }
            fn push_row(&self, y: usize, x0: usize, n: usize, out: &mut Vec<f64>) {
                out.extend(self.data[y * self.width + x0..][..n].iter().map(|v| f64::from(*v)));
            }
        }
    )*};
}
grey_window!(ImageF32, ImageU8);

/// A `w` x `h` image whose pixel (x, y) is the mean of `grey(u, v)` over `n` x `n` sub-samples
/// of its square (a box-filtered render), for the detectors' unit tests.
#[cfg(test)]
pub(crate) fn area_sampled(w: usize, h: usize, n: usize, grey: impl Fn(f64, f64) -> f64) -> ImageF32 {
    let data = (0..w * h)
        .map(|k| {
            let (x, y) = ((k % w) as f64, (k / w) as f64);
            let mut sum = 0.0;
            for j in 0..n {
                for i in 0..n {
                    sum += grey(x - 0.5 + (i as f64 + 0.5) / n as f64, y - 0.5 + (j as f64 + 0.5) / n as f64);
                }
            }
            (sum / (n * n) as f64) as f32
        })
        .collect();
    ImageF32 { width: w, height: h, data }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn half_averages_2x2_blocks_and_finite_check_sees_every_sample() {
        let (w, h) = (37, 5);
        let data: Vec<f32> = (0..w * h).map(|i| ((i * 13) % 17) as f32).collect();
        let img = ImageF32::new(w, h, data).unwrap();
        let half = img.half();
        assert_eq!((half.width, half.height), (18, 2));
        for y in 0..2 {
            for x in 0..18 {
                let e = 0.25 * (img.at(2 * x, 2 * y) + img.at(2 * x + 1, 2 * y) + img.at(2 * x, 2 * y + 1) + img.at(2 * x + 1, 2 * y + 1));
                assert_eq!(half.at(x, y), e);
            }
        }
        assert!(img.all_finite() && img.half_checked().1);
        for (k, bad) in [(0, f32::NAN), (w * h - 1, f32::INFINITY), (40, f32::NEG_INFINITY), (w - 1, f32::NAN), (3 * w + 5, f32::INFINITY)] {
            let mut b = img.clone();
            b.data[k] = bad;
            assert!(!b.all_finite(), "{k}");
            assert!(!b.half_checked().1, "{k}");
        }
    }

    #[test]
    fn u8_half_and_windows_match_the_f32_image() {
        let (w, h) = (37, 6);
        let data: Vec<u8> = (0..w * h).map(|i| ((i * 97) % 256) as u8).collect();
        let u = ImageU8::new(w, h, data).unwrap();
        let f = u.to_f32();
        assert_eq!(u.half(), f.half());
        let (mut a, mut b) = (Vec::new(), Vec::new());
        u.push_row(4, 3, 7, &mut a);
        f.push_row(4, 3, 7, &mut b);
        assert_eq!(a, b);
        assert!(ImageU8::new(3, 3, vec![0; 8]).is_err());
    }
}
