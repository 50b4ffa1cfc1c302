//! The grey-level erosion behind the over-exposure retry of [`find_in`](super::find_in).

use super::ImageF32;

/// Radii of the grey erosions tried when no board is found, full-resolution pixels.
pub const EROSION_RADII_PX: [usize; 2] = [2, 4];

/// Grey-level erosion by a `(2 r + 1)`-pixel square (separable running minimum, clamped
/// borders). Written here because imageproc's morphology works on 8-bit images and the detector
/// works on f32.
pub(super) fn min_filter(img: &ImageF32, r: usize) -> ImageF32 {
    let (w, h) = (img.width, img.height);
    let mut rows = vec![0.0f32; w * h];
    for y in 0..h {
        let src = &img.data[y * w..(y + 1) * w];
        for x in 0..w {
            rows[y * w + x] = src[x.saturating_sub(r)..(x + r + 1).min(w)].iter().copied().fold(f32::INFINITY, f32::min);
        }
    }
    let mut out = vec![0.0f32; w * h];
    for y in 0..h {
        let (y0, y1) = (y.saturating_sub(r), (y + r + 1).min(h));
        for x in 0..w {
            out[y * w + x] = (y0..y1).map(|yy| rows[yy * w + x]).fold(f32::INFINITY, f32::min);
        }
    }
    ImageF32 { width: w, height: h, data: out }
}
