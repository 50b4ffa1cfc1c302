//! Square fiducial markers (ArUco, AprilTag codes) with a black border of one or more bits: the
//! candidate search, sub-pixel outline and decoding shared by the ChArUco and AprilGrid
//! detectors, and the X-junction refinement of their target corners.
//!
//! 1. Candidates (`threshold`, `components`, `quads`): an adaptive mean threshold at one or more
//!    window sizes marks the pixels darker than their surroundings; the 8-connected components of
//!    those pixels (a marker's black border and the black bits touching it form one, cut off from
//!    other dark shapes by a white margin) give their convex hulls, and a hull that a convex
//!    quadrilateral fits within a small tolerance is a candidate. Where dark shapes touch the
//!    markers' corners diagonally (an AprilGrid tag and the black squares at its corners), the
//!    components are 4-connected (as AprilTag 3 connects dark pixels) and also taken from the
//!    dark pixels eroded by one pixel, which cuts such contacts. Large images are searched at
//!    half resolution (the ChArUco detector searches again at full resolution where its board
//!    implies markers the first search missed: `find_markers_in`). A hull is a candidate when it
//!    lies within `polygon_accuracy_rate` of the perimeter plus one search-image pixel of its
//!    quadrilateral (the pixel: a small, foreshortened marker's corner pixels read light).
//! 2. Sub-pixel quad (`edges`): candidates whose cell centres show no contrast are dropped
//!    first (`decode`); on the full-resolution image each side is located by the
//!    mid-level crossings of intensity profiles across it; a line fit per side, adjacent lines
//!    intersected.
//! 3. Decoding (`decode`): the perspective map of the unit square onto the quad samples the
//!    `(n + 2 b)^2` cells (`b` border bits); Otsu's threshold on the cell means; every border cell
//!    must be black (up to a share); the `n x n` bits match the wanted codes in the four rotations
//!    within the dictionary's correction capacity; corner 0 becomes the marker's top-left (OpenCV's
//!    convention for the marker image). One candidate per id is kept.
//! 4. Targets (`consistency`, `corners`): markers that disagree with every detected neighbour on
//!    the target are dropped; target corners are X-junctions refined by
//!    [`refine_saddle`](super::refine_saddle) in a window inside the locally uniform area.
//!
//! References: S. Garrido-Jurado, R. Munoz-Salinas, F. J. Madrid-Cuevas, M. J. Marin-Jimenez,
//! "Automatic generation and detection of highly reliable fiducial markers under occlusion",
//! Pattern Recognition 47(6), 2014; E. Olson, "AprilTag: A robust and flexible visual fiducial
//! system", ICRA 2011; J. Wang, E. Olson, "AprilTag 2: Efficient and robust fiducial detection",
//! IROS 2016; OpenCV `modules/objdetect/src/aruco/aruco_detector.cpp` (`detectMarkers`);
//! N. Otsu, "A threshold selection method from gray-level histograms", IEEE SMC 9(1), 1979;
//! A. M. Andrew, "Another efficient algorithm for convex hulls in two dimensions", IPL 9(5), 1979.

use std::borrow::Cow;

use nalgebra::Point2;
use rayon::prelude::*;

use super::par::worth_parallel;
use super::{DetectError, GreyWindow, ImageF32, ImageU8};
use synthcam_core::target::Dictionary;

pub(crate) mod consistency;
pub(crate) mod corners;
pub(crate) mod decode;
mod edges;
pub(crate) mod quads;
mod threshold;
mod window;

#[cfg(test)]
pub(crate) mod test_render;

pub use corners::CornerParams;

/// Candidates are decoded in parallel (rayon) when there are at least this many.
const PARALLEL_MIN_QUADS: usize = 8;

/// Parameters of [`find_markers`]. Grey-level thresholds are on the 0-255 scale of 8-bit images.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct MarkerParams {
    /// Side lengths of the adaptive-threshold windows, pixels of the search image (0 = unused);
    /// each non-zero size adds one candidate search (OpenCV's `adaptiveThreshWinSize*`).
    pub threshold_windows_px: [usize; 3],
    /// A pixel is dark when it lies this far below its window's mean, grey levels (OpenCV's
    /// `adaptiveThreshConstant`).
    pub threshold_offset: f32,
    /// Images with at least this many pixels are searched for candidates at half resolution
    /// (decoding and all fits stay at full resolution); markers then need sides of about 16
    /// full-resolution pixels (5x5 dictionary, 1280 x 1024: all 44 ChArUco markers found at 20 px,
    /// 43 at 16 px, 25 at 14 px), less foreshortened; the ChArUco detector retries at full
    /// resolution where its board implies markers that were missed. `usize::MAX` never
    /// downsamples.
    pub downsample_min_pixels: usize,
    /// Smallest marker perimeter, full-resolution pixels.
    pub min_marker_perimeter_px: f64,
    /// Largest marker perimeter as a multiple of the image's larger side.
    pub max_marker_perimeter_rate: f64,
    /// Largest distance of the candidate's outline from its quadrilateral, as a fraction of the
    /// perimeter (OpenCV's `polygonalApproxAccuracyRate`).
    pub polygon_accuracy_rate: f64,
    /// Smallest contrast between a marker's white and black cells, grey levels.
    pub min_contrast: f64,
    /// Largest share of the marker's border cells that may read white.
    pub max_border_error_rate: f64,
    /// Share of the dictionary's correction capacity used (OpenCV's `errorCorrectionRate`).
    pub error_correction_rate: f64,
}

impl Default for MarkerParams {
    fn default() -> Self {
        Self {
            threshold_windows_px: [9, 27, 0],
            threshold_offset: 7.0,
            downsample_min_pixels: 300_000,
            min_marker_perimeter_px: 40.0,
            max_marker_perimeter_rate: 4.0,
            polygon_accuracy_rate: 0.03,
            min_contrast: 20.0,
            max_border_error_rate: 0.1,
            error_correction_rate: 0.6,
        }
    }
}

impl MarkerParams {
    /// Typed check of every field.
    pub(crate) fn validate(&self) -> Result<(), DetectError> {
        let bad = |reason| Err(DetectError::BadParams { reason });
        if self.threshold_windows_px.iter().all(|&w| w == 0) || self.threshold_windows_px.iter().any(|&w| w > 10_000) {
            return bad("threshold_windows_px needs a non-zero size, each at most 10000");
        }
        if !(self.threshold_offset.is_finite()) {
            return bad("threshold_offset must be finite");
        }
        if !(self.min_marker_perimeter_px >= 4.0 && self.min_marker_perimeter_px.is_finite()) {
            return bad("min_marker_perimeter_px must be finite and at least 4");
        }
        if !(self.max_marker_perimeter_rate > 0.0 && self.max_marker_perimeter_rate.is_finite()) {
            return bad("max_marker_perimeter_rate must be positive");
        }
        let rates = [self.polygon_accuracy_rate, self.max_border_error_rate, self.error_correction_rate];
        if !rates.iter().all(|r| (0.0..=1.0).contains(r)) {
            return bad("rates (polygon accuracy, border error, error correction) must be in [0, 1]");
        }
        if !(self.min_contrast >= 0.0 && self.min_contrast.is_finite()) {
            return bad("min_contrast must be finite and non-negative");
        }
        Ok(())
    }
}

/// The markers searched for: a dictionary, its printed border and a range of ids.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct MarkerSet {
    /// Code family.
    pub dictionary: Dictionary,
    /// Black border width, bits (ArUco and ChArUco: 1; Kalibr's AprilGrid: 2).
    pub border_bits: u32,
    /// First id wanted.
    pub first_id: u32,
    /// Number of consecutive ids wanted from `first_id` (clipped to the dictionary).
    pub count: u32,
    /// Width of the white margin around each marker as a fraction of the marker's side (at
    /// least the reach of the outline's intensity profiles; 0.25 when unknown).
    pub margin_rate: f64,
    /// Other dark shapes touch the markers' corners diagonally (AprilGrid's gap squares): the
    /// search then uses 4-connected components, also of the dark pixels eroded by one pixel, so
    /// that the contacts are cut (markers need black borders of at least about 3 search-image
    /// pixels for the eroded search).
    pub touching_corners: bool,
}

/// One decoded marker.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct MarkerDetection {
    /// Marker id in the dictionary.
    pub id: u32,
    /// Corners, pixels: by default top-left, top-right, bottom-right, bottom-left of the marker
    /// image (OpenCV's `generateImageMarker`); a target detector may reorder them (it says so).
    pub corners_px: [Point2<f64>; 4],
}

/// Find the markers of `set` in `img` (see the module docs), sorted by id, one per id. Non-finite
/// samples are read as black by the search and make the fits near them fail.
///
/// # Errors
/// [`DetectError::EmptyImage`], [`DetectError::BadBuffer`] (buffer and size disagree) and
/// [`DetectError::BadParams`] (invalid parameters, a border of 0 or more than 4 bits, a
/// non-positive margin).
pub fn find_markers(img: &ImageF32, set: &MarkerSet, params: &MarkerParams) -> Result<Vec<MarkerDetection>, DetectError> {
    check_image(img)?;
    check_set(set, params)?;
    let (search, scale) = search_image(img, params);
    Ok(search_and_decode(img, &search, scale, set, params))
}

/// [`find_markers`] on 8-bit samples, with identical results: the search image is made from them
/// ([`ImageU8::half`]: a quarter of the memory traffic of halving an f32 copy, and no check for
/// non-finite samples) and the outlines and codes are sampled from them, so the image is never
/// converted to f32 as a whole.
pub(crate) fn find_markers_u8(img: &ImageU8, set: &MarkerSet, params: &MarkerParams) -> Result<Vec<MarkerDetection>, DetectError> {
    check_image_u8(img)?;
    check_set(set, params)?;
    let (search, scale) = if searched_at_half(img.width, img.height, params) { (img.half(), 2.0) } else { (img.to_f32(), 1.0) };
    Ok(search_and_decode(img, &search, scale, set, params))
}

/// Typed check of the parameters and the marker set.
fn check_set(set: &MarkerSet, params: &MarkerParams) -> Result<(), DetectError> {
    params.validate()?;
    if !((1..=4).contains(&set.border_bits) && set.margin_rate > 0.0 && set.margin_rate.is_finite()) {
        return Err(DetectError::BadParams { reason: "the marker set needs 1..=4 border bits and a positive margin rate" });
    }
    Ok(())
}

/// Candidates of `search` (`scale` times smaller than `img`, all samples finite), decoded on
/// `img`.
fn search_and_decode<I: Samples + ?Sized>(img: &I, search: &ImageF32, scale: f64, set: &MarkerSet, params: &MarkerParams) -> Vec<MarkerDetection> {
    let quads = quads::candidates(search, scale, params, set.touching_corners);
    decode_all(img, &quads, set, params)
}

/// A grey image the marker pipeline samples at full resolution: f32, or 8-bit samples read
/// directly (identical values: bilinear interpolation in f32 either way).
pub(crate) trait Samples: GreyWindow {
    /// Bilinear sample with clamped coordinates ([`crate::xcorner::bilinear`]); `None`
    /// outside the image.
    fn bilinear(&self, p: Point2<f64>) -> Option<f32>;
    /// Sample `(x, y)` (inside the image).
    fn sample(&self, x: usize, y: usize) -> f32;
    /// The samples of `win` (inside the image) as an f32 image, non-finite ones as 0.
    fn crop(&self, win: Window) -> ImageF32;
}

impl Samples for ImageF32 {
    fn bilinear(&self, p: Point2<f64>) -> Option<f32> {
        super::xcorner::bilinear(self, p)
    }
    fn sample(&self, x: usize, y: usize) -> f32 {
        self.at(x, y)
    }
    fn crop(&self, win: Window) -> ImageF32 {
        crop_rows(self.width, win, &self.data, |v: &f32| if v.is_finite() { *v } else { 0.0 })
    }
}

impl Samples for ImageU8 {
    fn bilinear(&self, p: Point2<f64>) -> Option<f32> {
        let (w, h) = (self.width, self.height);
        if !(p.x >= 0.0 && p.y >= 0.0 && p.x <= (w as f64 - 1.0) && p.y <= (h as f64 - 1.0)) {
            return None;
        }
        let d = &self.data;
        if w < 2 || h < 2 {
            return d.first().map(|v| f32::from(*v));
        }
        let (x0, y0) = ((p.x as usize).min(w - 2), (p.y as usize).min(h - 2));
        let (fx, fy) = ((p.x - x0 as f64) as f32, (p.y - y0 as f64) as f32);
        let i = y0 * w + x0;
        let v = |k: usize| f32::from(d[k]);
        let top = v(i) + (v(i + 1) - v(i)) * fx;
        let bot = v(i + w) + (v(i + w + 1) - v(i + w)) * fx;
        Some(top + (bot - top) * fy)
    }
    fn sample(&self, x: usize, y: usize) -> f32 {
        f32::from(self.data[y * self.width + x])
    }
    fn crop(&self, win: Window) -> ImageF32 {
        crop_rows(self.width, win, &self.data, |v: &u8| f32::from(*v))
    }
}

/// The rows `win.y0..win.y1`, columns `win.x0..win.x1` of a row-major image `width` wide, each
/// sample through `f`.
fn crop_rows<T>(width: usize, win: Window, data: &[T], f: impl Fn(&T) -> f32) -> ImageF32 {
    let (w, h) = (win.x1.saturating_sub(win.x0), win.y1.saturating_sub(win.y0));
    let mut out = super::pool::scratch(w * h);
    for (o, row) in out.chunks_exact_mut(w.max(1)).zip(data.chunks_exact(width.max(1)).skip(win.y0)) {
        for (o, v) in o.iter_mut().zip(&row[win.x0..win.x1]) {
            *o = f(v);
        }
    }
    ImageF32 { width: w, height: h, data: out }
}

/// A rectangle of an image: columns `x0..x1`, rows `y0..y1`, pixels.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub(crate) struct Window {
    /// First column.
    pub x0: usize,
    /// First row.
    pub y0: usize,
    /// One past the last column.
    pub x1: usize,
    /// One past the last row.
    pub y1: usize,
}

/// Whether [`find_markers`] searches an image of `width x height` at half resolution.
pub(crate) fn searched_at_half(width: usize, height: usize, params: &MarkerParams) -> bool {
    width.saturating_mul(height) >= params.downsample_min_pixels && width >= 16 && height >= 16
}

/// [`find_markers`] with the candidate search at full resolution inside `win` (clipped to the
/// image), skipping candidates whose centre lies inside one of `known` (markers already found;
/// their outlines, positively oriented or not). `img` and `params` must have passed
/// [`check_image`] and [`MarkerParams::validate`].
pub(crate) fn find_markers_in<I: Samples + ?Sized>(
    img: &I,
    set: &MarkerSet,
    params: &MarkerParams,
    win: Window,
    known: &[[Point2<f64>; 4]],
) -> Vec<MarkerDetection> {
    let (x1, y1) = (win.x1.min(img.width()), win.y1.min(img.height()));
    let win = Window { x0: win.x0.min(x1), y0: win.y0.min(y1), x1, y1 };
    let crop = img.crop(win);
    let shift = nalgebra::Vector2::new(win.x0 as f64, win.y0 as f64);
    let inside = |q: &quads::Quad| {
        let c = Point2::from(q.iter().fold(nalgebra::Vector2::zeros(), |s, p| s + p.coords) / 4.0 + shift);
        known.iter().any(|k| in_convex_quad(k, c))
    };
    let quads: Vec<quads::Quad> =
        quads::candidates(&crop, 1.0, params, set.touching_corners).into_iter().filter(|q| !inside(q)).map(|q| q.map(|p| p + shift)).collect();
    decode_all(img, &quads, set, params)
}

/// Whether `p` lies inside the convex quadrilateral `q` (either orientation).
fn in_convex_quad(q: &[Point2<f64>; 4], p: Point2<f64>) -> bool {
    let sides = (0..4).map(|k| (q[(k + 1) % 4] - q[k]).perp(&(p - q[k])));
    let (mut pos, mut neg) = (false, false);
    for s in sides {
        pos |= s > 0.0;
        neg |= s < 0.0;
    }
    !(pos && neg)
}

/// The candidates `quads` decoded on `img`, one per id, sorted by id.
fn decode_all<I: Samples + ?Sized>(img: &I, quads: &[quads::Quad], set: &MarkerSet, params: &MarkerParams) -> Vec<MarkerDetection> {
    let codes = decode::Codes::new(set, params);
    let decode = |q: &quads::Quad| decode::marker(img, q, &codes, params);
    let found: Vec<decode::Decoded> =
        if worth_parallel(quads.len(), PARALLEL_MIN_QUADS) { quads.par_iter().filter_map(decode).collect() } else { quads.iter().filter_map(decode).collect() };
    decode::best_per_id(found)
}

/// [`DetectError::EmptyImage`] or [`DetectError::BadBuffer`] for an unusable image.
pub(crate) fn check_image(img: &ImageF32) -> Result<(), DetectError> {
    check_buffer(img.width, img.height, img.data.len())
}

/// [`check_image`] of 8-bit samples.
pub(crate) fn check_image_u8(img: &ImageU8) -> Result<(), DetectError> {
    check_buffer(img.width, img.height, img.data.len())
}

/// A `width x height` image held in `len` samples: not empty, and one sample per pixel.
fn check_buffer(width: usize, height: usize, len: usize) -> Result<(), DetectError> {
    if width == 0 || height == 0 {
        return Err(DetectError::EmptyImage { width, height });
    }
    let expected = width.saturating_mul(height);
    if len != expected {
        return Err(DetectError::BadBuffer { expected, actual: len });
    }
    Ok(())
}

/// The image the candidate search runs on and its scale to full resolution (1 or 2); non-finite
/// samples are replaced by 0.
fn search_image<'a>(img: &'a ImageF32, params: &MarkerParams) -> (Cow<'a, ImageF32>, f64) {
    let (search, finite, scale) = if searched_at_half(img.width, img.height, params) {
        let (half, finite) = img.half_checked();
        (Cow::Owned(half), finite, 2.0)
    } else {
        (Cow::Borrowed(img), img.all_finite(), 1.0)
    };
    if finite {
        return (search, scale);
    }
    let mut clean = search.into_owned();
    clean.data.iter_mut().filter(|v| !v.is_finite()).for_each(|v| *v = 0.0);
    (Cow::Owned(clean), scale)
}
