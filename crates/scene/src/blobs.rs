//! Dots' rendered blobs: area and centroids, by exact ray casting.
//!
//! Under perspective and distortion the image of a dot's centre is not the
//! centroid of the dot's image (the bias is up to ~0.2 px). The blob is the set of image points
//! whose ray sees this dot first (occlusion by the sphere and by other beads included), clipped to
//! the image. Two centroids are labelled: `centroid_px`, the intensity-weighted centroid of the
//! box-filtered rendered blob (sum over pixels of coverage x pixel centre, / area), which is what an
//! intensity-centroid detector measures on the noise-free image; and `area_centroid_px`, the centroid
//! of the continuous region (they differ by the pixel discretisation of the boundary).
//! Both come from exact ray casting ([`Tracer`]): every pixel of the
//! dot's conservative bounding box is probed at a 3 x 3 grid of points; pixels whose probes all see
//! the dot count as whole pixels (centroid at the pixel centre), pixels whose probes disagree are
//! integrated along `CENTROID_LINES` scan lines with bisected crossings (exact up to features
//! narrower than 1/32 px along a line), and so is every probe-free pixel next to
//! a pixel with coverage, flooding outwards (a sliver thinner than the probes' half-pixel spacing
//! is followed from where it is wider).

use nalgebra::Point2;
use rayon::prelude::*;

use super::scanline::pixel_moments;
use super::trace::{dot_bbox_px, Tracer};
use super::Scene;
use synthcam_core::target::{FeatureKind, Target};

/// Scan lines per boundary pixel of a blob (see [`super::scanline::pixel_moments`]).
pub const CENTROID_LINES: u32 = 16;
/// Samples per scan line, ends included (spacing 1/32 px).
pub const CENTROID_LINE_SAMPLES: u32 = 33;
/// Bisection steps per crossing (2^-21 px).
pub const CENTROID_BISECTIONS: u32 = 16;

/// How finely [`blob_centroid`] integrates a blob's boundary pixels: scan lines per pixel, samples
/// per line (ends included) and bisection steps per crossing.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct CentroidSampling {
    /// Scan lines per boundary pixel.
    pub lines: u32,
    /// Samples per scan line, ends included.
    pub samples: u32,
    /// Bisection steps per crossing.
    pub bisections: u32,
}

impl CentroidSampling {
    /// The truth labels' ([`CENTROID_LINES`], [`CENTROID_LINE_SAMPLES`], [`CENTROID_BISECTIONS`]).
    pub const TRUTH: Self = Self { lines: CENTROID_LINES, samples: CENTROID_LINE_SAMPLES, bisections: CENTROID_BISECTIONS };
}

/// A dot's rendered blob.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Blob {
    /// Area, pixels^2.
    pub area_px: f64,
    /// Centroid of the box-filtered image: sum over pixels of coverage x pixel centre, / area.
    pub centroid_px: [f64; 2],
    /// Centroid of the continuous region.
    pub area_centroid_px: [f64; 2],
}

/// Area and centroids of the rendered blob of dot `id` (see module docs). `candidates` (ascending,
/// including `id`) are the dots that can cover any of `bbox`'s pixels.
pub fn blob_centroid(tracer: &Tracer<'_>, id: usize, bbox: [f64; 4], candidates: &[usize], sampling: &CentroidSampling) -> Option<Blob> {
    let size = tracer.scene().camera.size;
    let x0 = bbox[0].floor().max(0.0) as i64;
    let y0 = bbox[1].floor().max(0.0) as i64;
    let x1 = (bbox[2].ceil() as i64).min(i64::from(size.width) - 1);
    let y1 = (bbox[3].ceil() as i64).min(i64::from(size.height) - 1);
    if x1 < x0 || y1 < y0 {
        return None;
    }
    let (bw, bh) = ((x1 - x0 + 1) as usize, (y1 - y0 + 1) as usize);
    let sees = |u: f64, v: f64| tracer.trace_px_among(&Point2::new(u, v), candidates).feature == Some(id);
    // Probe hits per pixel of the box, then exact integration where the probes disagree and,
    // flooding outwards, in every probe-free pixel next to a pixel with coverage (thin slivers
    // between the probes).
    let mut hits = vec![0u8; bw * bh];
    for (k, h) in hits.iter_mut().enumerate() {
        let (xf, yf) = ((x0 + (k % bw) as i64) as f64, (y0 + (k / bw) as i64) as f64);
        for j in [-0.5, 0.0, 0.5] {
            for i in [-0.5, 0.0, 0.5] {
                *h += u8::from(sees(xf + i, yf + j));
            }
        }
    }
    let mut queued = vec![false; bw * bh];
    let mut queue: Vec<usize> = (0..bw * bh).filter(|&k| hits[k] > 0).collect();
    queue.iter().for_each(|&k| queued[k] = true);
    let (mut area, mut su, mut sv) = (0.0, 0.0, 0.0);
    let (mut pu, mut pv) = (0.0, 0.0);
    while let Some(k) = queue.pop() {
        let (bx, by) = (k % bw, k / bw);
        let (xf, yf) = ((x0 + bx as i64) as f64, (y0 + by as i64) as f64);
        let covered = if hits[k] == 9 {
            su += xf;
            sv += yf;
            1.0
        } else {
            let inside = |u: f64, v: f64| f64::from(u8::from(sees(u, v)));
            let [c, mu, mv] = pixel_moments(&inside, xf, yf, sampling.lines, sampling.samples, sampling.bisections);
            su += mu;
            sv += mv;
            c
        };
        area += covered;
        pu += covered * xf;
        pv += covered * yf;
        if covered > 0.0 && hits[k] < 9 {
            for (dx, dy) in [(-1i64, -1i64), (0, -1), (1, -1), (-1, 0), (1, 0), (-1, 1), (0, 1), (1, 1)] {
                let (nx, ny) = (bx as i64 + dx, by as i64 + dy);
                if (0..bw as i64).contains(&nx) && (0..bh as i64).contains(&ny) {
                    let n = ny as usize * bw + nx as usize;
                    if !queued[n] {
                        queued[n] = true;
                        queue.push(n);
                    }
                }
            }
        }
    }
    (area > 0.0).then(|| Blob { area_px: area, centroid_px: [pu / area, pv / area], area_centroid_px: [su / area, sv / area] })
}

/// The rendered blob of every dot of `scene` (per feature; empty for targets without dots), its
/// boundary pixels integrated as `sampling` says.
pub fn dot_blobs(scene: &Scene, tracer: &Tracer<'_>, sampling: &CentroidSampling) -> Vec<Option<Blob>> {
    if scene.target.feature_kind() != FeatureKind::Dot {
        return Vec::new();
    }
    let pts = scene.target.feature_points_m();
    let radius = |i: usize| match &scene.target {
        Target::DotGrid(g) => g.dot_radius_m,
        Target::SPath(s) => s.dot_radius(i),
        Target::Chessboard(_) | Target::Charuco(_) | Target::AprilGrid(_) => 0.0,
    };
    // Each blob only needs the dots whose boxes overlap its own (conservative: a dot without a
    // box, partly behind the camera, is always a candidate).
    let boxes: Vec<Option<[f64; 4]>> = pts.iter().enumerate().map(|(i, p)| dot_bbox_px(scene, p, radius(i), 1.5)).collect();
    let overlapping = |id: usize, bb: &[f64; 4]| -> Vec<usize> {
        boxes
            .iter()
            .enumerate()
            .filter(|(j, b)| *j == id || b.is_none_or(|b| b[0] <= bb[2] && bb[0] <= b[2] && b[1] <= bb[3] && bb[1] <= b[3]))
            .map(|(j, _)| j)
            .collect()
    };
    (0..pts.len()).into_par_iter().map(|id| boxes[id].and_then(|bb| blob_centroid(tracer, id, bb, &overlapping(id, &bb), sampling))).collect()
}
