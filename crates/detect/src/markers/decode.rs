//! Marker decoding: a candidate whose cell-centre samples (unrefined quad) span less than half
//! the minimum contrast is dropped before the sub-pixel outline (a uniform dark shape); then the
//! perspective map of the unit square onto the refined quad samples the
//! `(n + 2 b) x (n + 2 b)` cells (`b` border bits; the mean of 2 x 2 bilinear samples in the inner
//! part of each), Otsu's threshold splits the cell means, the border cells must read black (up to
//! a share), and the `n x n` bits are matched against the wanted codes in the four rotations by
//! Hamming distance within the dictionary's (scaled) correction capacity. The rotation fixes which
//! corner is the marker's top-left.
//!
//! Reference: S. Garrido-Jurado et al., "Automatic generation and detection of highly reliable
//! fiducial markers under occlusion", Pattern Recognition 47(6), 2014, sec. 3; E. Olson,
//! "AprilTag: A robust and flexible visual fiducial system", ICRA 2011 (sec. III-D, decoding
//! under rotation by Hamming distance); OpenCV `aruco_detector.cpp` (`_extractBits`,
//! `_identifyOneCandidate`); N. Otsu, IEEE SMC 9(1), 1979.

use nalgebra::{Matrix3, Point2};

use super::edges;
use super::quads::{signed_area, Quad};
use super::{MarkerDetection, MarkerParams, MarkerSet, Samples};

/// Most cells of a marker (12 x 12: 8 x 8 bits with a 2-bit border).
const MAX_CELLS: usize = 144;

/// Positions of the samples inside a cell, as fractions of the cell.
const SAMPLES: [f64; 2] = [0.35, 0.65];

/// The wanted codes, packed: bit `y n + x` is cell `(x, y)` of the code, set for white.
pub(super) struct Codes {
    /// Bits per marker side.
    n: usize,
    /// Border bits.
    border: usize,
    /// White margin over marker side.
    margin_rate: f64,
    /// Code of marker `first_id + k`.
    codes: Vec<u64>,
    /// First id.
    first_id: u32,
    /// Largest Hamming distance accepted.
    max_correction: u32,
}

impl Codes {
    /// The codes of `set`.
    pub(super) fn new(set: &MarkerSet, params: &MarkerParams) -> Self {
        let n = set.dictionary.marker_bits();
        let count = (set.count as usize).min(set.dictionary.len().saturating_sub(set.first_id as usize));
        let pack = |bits: Vec<bool>| bits.iter().enumerate().fold(0u64, |acc, (k, b)| acc | (u64::from(*b) << k));
        let codes = (0..count).map_while(|k| set.dictionary.code(set.first_id as usize + k).map(pack)).collect();
        let max_correction = (params.error_correction_rate * f64::from(set.dictionary.max_correction_bits())).floor() as u32;
        Self { n, border: set.border_bits as usize, margin_rate: set.margin_rate, codes, first_id: set.first_id, max_correction }
    }

    /// Cells per marker side, border included.
    fn cells(&self) -> usize {
        self.n + 2 * self.border
    }
}

/// A decoded candidate: the marker, its Hamming distance and its perimeter, pixels.
#[derive(Debug, Clone, Copy)]
pub(super) struct Decoded {
    /// The marker.
    pub marker: MarkerDetection,
    /// Bits corrected.
    pub hamming: u32,
    /// Perimeter, pixels.
    pub perimeter: f64,
}

/// Refine and decode candidate `q`; `None` when it is not one of the wanted markers.
pub(super) fn marker<I: Samples + ?Sized>(img: &I, q: &Quad, codes: &Codes, params: &MarkerParams) -> Option<Decoded> {
    let cells = codes.cells();
    if cells * cells > MAX_CELLS || codes.n * codes.n > 64 || codes.codes.is_empty() {
        return None;
    }
    if !has_contrast(img, q, cells, params.min_contrast) {
        return None;
    }
    let r = edges::refine(img, q, codes.border as f64 / cells as f64, codes.margin_rate, params.min_contrast)?;
    if !(signed_area(&r) > 0.0) {
        return None;
    }
    let h = square_to_quad(&r)?;
    let means = cell_means(img, &h, cells)?;
    let white = classify(&means, cells, codes.border, params)?;
    let (hamming, id, rot) = identify(&white, codes)?;
    let corners_px = [r[rot], r[(rot + 1) % 4], r[(rot + 2) % 4], r[(rot + 3) % 4]];
    let perimeter = (0..4).map(|i| (r[(i + 1) % 4] - r[i]).norm()).sum();
    Some(Decoded { marker: MarkerDetection { id, corners_px }, hamming, perimeter })
}

/// Cheap test before the sub-pixel outline: the samples at the cell centres of the unrefined
/// quad `q` must span at least half of `min_contrast` (a marker has black and white cells; a
/// uniform dark shape, such as a ChArUco board's black square, does not, and [`classify`] would
/// refuse it after the costlier refinement anyway). Samples outside the image are skipped.
fn has_contrast<I: Samples + ?Sized>(img: &I, q: &Quad, cells: usize, min_contrast: f64) -> bool {
    let Some(h) = square_to_quad(q) else { return false };
    let k = cells as f64;
    let (mut lo, mut hi) = (f64::INFINITY, f64::NEG_INFINITY);
    for i in 0..cells * cells {
        let (u, v) = (((i % cells) as f64 + 0.5) / k, ((i / cells) as f64 + 0.5) / k);
        let p = h * nalgebra::Vector3::new(u, v, 1.0);
        if let Some(s) = img.bilinear(Point2::new(p.x / p.z, p.y / p.z)) {
            let s = f64::from(s);
            (lo, hi) = (lo.min(s), hi.max(s));
        }
    }
    // NaN samples never raise `hi - lo`; the refinement then decides
    hi - lo >= 0.5 * min_contrast || !(hi >= lo)
}

/// The homography of the unit square (corners (0, 0), (1, 0), (1, 1), (0, 1)) onto `q`, in
/// closed form (P. Heckbert, "Fundamentals of texture mapping and image warping", 1989, sec.
/// 2.2.3): the exact four-point case of [`synthcam_core::math::homography::homography`], without its SVD.
pub(crate) fn square_to_quad(q: &Quad) -> Option<Matrix3<f64>> {
    let [p0, p1, p2, p3] = *q;
    let s = p0.coords - p1.coords + p2.coords - p3.coords;
    let (d1, d2) = (p1 - p2, p3 - p2);
    let den = d1.perp(&d2);
    if !(den.abs() > 1e-12) {
        return None;
    }
    let (g, h) = (s.perp(&d2) / den, d1.perp(&s) / den);
    let m = Matrix3::new(p1.x - p0.x + g * p1.x, p3.x - p0.x + h * p3.x, p0.x, p1.y - p0.y + g * p1.y, p3.y - p0.y + h * p3.y, p0.y, g, h, 1.0);
    m.iter().all(|v| v.is_finite()).then_some(m)
}

/// Mean grey of each cell, row-major; `None` when a sample leaves the image or is not finite.
fn cell_means<I: Samples + ?Sized>(img: &I, h: &Matrix3<f64>, cells: usize) -> Option<[f64; MAX_CELLS]> {
    let mut means = [0.0f64; MAX_CELLS];
    let k = cells as f64;
    for (i, m) in means.iter_mut().take(cells * cells).enumerate() {
        let (cx, cy) = ((i % cells) as f64, (i / cells) as f64);
        let mut sum = 0.0;
        for fy in SAMPLES {
            for fx in SAMPLES {
                let p = h * nalgebra::Vector3::new((cx + fx) / k, (cy + fy) / k, 1.0);
                sum += f64::from(img.bilinear(Point2::new(p.x / p.z, p.y / p.z))?);
            }
        }
        *m = sum / (SAMPLES.len() * SAMPLES.len()) as f64;
    }
    means[..cells * cells].iter().all(|v| v.is_finite()).then_some(means)
}

/// White cells by Otsu's threshold on the cell means; `None` when the contrast is too low or
/// too many of the border cells (`border` deep) read white.
fn classify(means: &[f64; MAX_CELLS], cells: usize, border: usize, params: &MarkerParams) -> Option<[bool; MAX_CELLS]> {
    let m = cells * cells;
    let mut sorted: Vec<f64> = means[..m].to_vec();
    sorted.sort_by(f64::total_cmp);
    let total: f64 = sorted.iter().sum();
    let (mut best, mut split, mut acc) = (-1.0, 0, 0.0);
    for i in 1..m {
        acc += sorted[i - 1];
        let (m0, m1) = (acc / i as f64, (total - acc) / (m - i) as f64);
        let between = (i * (m - i)) as f64 * (m1 - m0) * (m1 - m0);
        if between > best {
            (best, split) = (between, i);
        }
    }
    let (m0, m1) = (sorted[..split].iter().sum::<f64>() / split as f64, sorted[split..].iter().sum::<f64>() / (m - split) as f64);
    if !(m1 - m0 >= params.min_contrast) {
        return None;
    }
    let t = 0.5 * (sorted[split - 1] + sorted[split]);
    let mut white = [false; MAX_CELLS];
    for (w, v) in white.iter_mut().zip(&means[..m]) {
        *w = *v > t;
    }
    let inner = border..cells - border;
    let is_border = |i: usize| !(inner.contains(&(i % cells)) && inner.contains(&(i / cells)));
    let errors = (0..m).filter(|&i| is_border(i) && white[i]).count();
    let border_cells = m - (cells - 2 * border) * (cells - 2 * border);
    (errors as f64 <= params.max_border_error_rate * border_cells as f64).then_some(white)
}

/// The inner bits (inside a border `border` deep) read with corner `rot` of the quad as the
/// top-left, packed as the codes.
fn read_bits(white: &[bool; MAX_CELLS], cells: usize, border: usize, rot: usize) -> u64 {
    let n = cells - 2 * border;
    let mut bits = 0u64;
    for y in 0..n {
        for x in 0..n {
            // frame rot -> frame 0: (x, y) -> (cells - 1 - y, x), rot times
            let (mut u, mut v) = (x + border, y + border);
            for _ in 0..rot {
                (u, v) = (cells - 1 - v, u);
            }
            bits |= u64::from(white[v * cells + u]) << (y * n + x);
        }
    }
    bits
}

/// Best (Hamming distance, id, rotation) over the wanted codes; `None` when it exceeds the
/// correction capacity or two matches tie.
fn identify(white: &[bool; MAX_CELLS], codes: &Codes) -> Option<(u32, u32, usize)> {
    let cells = codes.cells();
    let mut best: Option<(u32, u32, usize)> = None;
    let mut tie = false;
    for rot in 0..4 {
        let bits = read_bits(white, cells, codes.border, rot);
        for (k, c) in codes.codes.iter().enumerate() {
            let d = (bits ^ c).count_ones();
            match best {
                Some((bd, ..)) if d > bd => {}
                Some((bd, ..)) if d == bd => tie = true,
                _ => {
                    best = Some((d, codes.first_id + k as u32, rot));
                    tie = false;
                }
            }
        }
    }
    best.filter(|b| b.0 <= codes.max_correction && !tie)
}

/// One candidate per id (fewest corrected bits, then the largest), sorted by id.
pub(super) fn best_per_id(mut found: Vec<Decoded>) -> Vec<MarkerDetection> {
    found.sort_by(|a, b| a.marker.id.cmp(&b.marker.id).then(a.hamming.cmp(&b.hamming)).then(b.perimeter.total_cmp(&a.perimeter)));
    found.dedup_by_key(|d| d.marker.id);
    found.into_iter().map(|d| d.marker).collect()
}

#[cfg(test)]
mod tests {
    use super::*;
    use synthcam_core::math::homography::homography;

    #[test]
    fn closed_form_square_to_quad_matches_the_dlt() {
        let unit = [Point2::new(0.0, 0.0), Point2::new(1.0, 0.0), Point2::new(1.0, 1.0), Point2::new(0.0, 1.0)];
        for q in [
            [Point2::new(10.0, 20.0), Point2::new(50.0, 22.0), Point2::new(47.0, 70.0), Point2::new(12.0, 60.0)],
            [Point2::new(0.0, 0.0), Point2::new(2.0, 0.0), Point2::new(2.0, 2.0), Point2::new(0.0, 2.0)],
        ] {
            let (a, b) = (square_to_quad(&q).unwrap(), homography(&unit, &q).unwrap());
            assert!((a - b).norm() < 1e-9 * b.norm(), "{a} vs {b}");
        }
        let flat = [Point2::new(0.0, 0.0), Point2::new(1.0, 0.0), Point2::new(2.0, 0.0), Point2::new(3.0, 0.0)];
        assert!(square_to_quad(&flat).is_none());
    }

    #[test]
    fn rotations_read_the_code_from_each_corner() {
        // a 4x4 code whose cells are all distinct under rotation: bit k set for k in {0, 1, 5}
        let cells = 6;
        let mut white = [false; MAX_CELLS];
        for (x, y) in [(0, 0), (1, 0), (1, 1)] {
            white[(y + 1) * cells + x + 1] = true;
        }
        assert_eq!(read_bits(&white, cells, 1, 0), 0b10_0011);
        // rotation 1 reads from quad corner 1 (the grid's top-right) with x down the right edge
        // and y towards corner 0: frame bit (x, y) is grid bit (3 - y, x), so grid bits (0, 0),
        // (1, 0), (1, 1) are frame bits (0, 3), (0, 2), (1, 2): 12, 8, 9
        assert_eq!(read_bits(&white, cells, 1, 1), 0b1_0011_0000_0000);
        // rotation 2: frame bit (x, y) is grid bit (3 - x, 3 - y): bits 15, 14, 10
        assert_eq!(read_bits(&white, cells, 1, 2), 0b1100_0100_0000_0000);
    }
}
