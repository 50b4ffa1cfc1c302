//! Marker candidates: the convex hull of each dark component (Andrew's monotone chain over the
//! corners of its runs) approximated by a quadrilateral (the hull vertex farthest from the
//! centroid, the vertex farthest from that, and the farthest vertex on either side of their
//! diagonal), kept when the hull lies within a tolerance of it and it is large, convex and not
//! too skewed (OpenCV's `approxPolyDP` test, `polygonalApproxAccuracyRate`,
//! `minCornerDistanceRate`). The tolerance is the rate times the perimeter plus one pixel: the
//! pixels at a small marker's corners, partly covered, often read light, which cuts its hull's
//! corners by about a pixel whatever its size (15 px markers seen at 50 degrees missed a 1.6 px
//! tolerance by 0.1-0.4 px). Quads found again at another threshold window are dropped.
//!
//! The hull is written here rather than taken from `imageproc::geometry::convex_hull`: the
//! outline points of a component's runs come already ordered by row, so the monotone chain
//! needs no sort, which imageproc's always does (the hull was a measured share of the marker
//! search).
//!
//! Reference: A. M. Andrew, "Another efficient algorithm for convex hulls in two dimensions",
//! Information Processing Letters 9(5), 1979; OpenCV `aruco_detector.cpp`
//! (`_findMarkerContours`).

use nalgebra::{Point2, Vector2};
use rayon::prelude::*;

use super::threshold::{dark_runs, erode, Integral};
use super::MarkerParams;
use crate::par::{worth_parallel, PARALLEL_MIN_PIXELS};
use crate::runs::{components, Blob, Run};
use crate::ImageF32;
use synthcam_core::math::polygon;

/// A quadrilateral, corners in image order with a positive shoelace sum (clockwise on screen).
pub(crate) type Quad = [Point2<f64>; 4];

/// Smallest sine of a corner angle of a candidate.
const MIN_CORNER_SINE: f64 = 0.25;
/// Shortest side as a fraction of the perimeter.
const MIN_SIDE_RATE: f64 = 0.08;

/// Candidate quads of `img` (the search image, `scale` times smaller than the full image), in
/// full-resolution pixels. With `split_corners` (dark shapes touch the markers' corners), the
/// components are 4-connected and each window is searched twice: as is, and eroded by one pixel
/// (then each hull is grown back by that pixel).
pub(crate) fn candidates(img: &ImageF32, scale: f64, params: &MarkerParams, split_corners: bool) -> Vec<Quad> {
    let (w, h) = (img.width as u32, img.height as u32);
    if w < 4 || h < 4 {
        return Vec::new();
    }
    let integral = Integral::new(img);
    let min_perimeter = params.min_marker_perimeter_px / scale;
    let max_perimeter = params.max_marker_perimeter_rate * f64::from(w.max(h));
    // a convex shape's perimeter is at most its bounding box's and at least 1/sqrt(2) of it
    let keep = |b: &Blob| {
        let bbox_perimeter = 2.0 * f64::from(b.x1 - b.x0 + b.y1 - b.y0);
        b.x0 > 0 && b.y0 > 0 && b.x1 < w && b.y1 < h && bbox_perimeter >= min_perimeter && bbox_perimeter <= 1.5 * max_perimeter
    };
    let per_window = |win: &usize| -> Vec<Quad> {
        let mut runs = Vec::new();
        dark_runs(img, &integral, win / 2, params.threshold_offset, &mut runs);
        let to_full = |p: Point2<f64>| Point2::new(scale * p.x + 0.5 * (scale - 1.0), scale * p.y + 0.5 * (scale - 1.0));
        let quads = |runs: &[Run], grow: f64| -> Vec<Quad> {
            components(runs, !split_corners, keep)
                .iter()
                .filter_map(|c| fit_quad(c, grow, params.polygon_accuracy_rate, (min_perimeter, max_perimeter)))
                .map(|q| q.map(to_full))
                .collect()
        };
        if !split_corners {
            return quads(&runs, 0.5);
        }
        // the eroded quads first: duplicates of them (which may have a corner square attached)
        // are dropped
        let mut out = quads(&erode(&runs), 1.5);
        out.extend(quads(&runs, 0.5));
        out
    };
    let windows: Vec<usize> = params.threshold_windows_px.iter().copied().filter(|w| *w > 0).collect();
    let found: Vec<Vec<Quad>> = if windows.len() > 1 && worth_parallel(img.data.len(), PARALLEL_MIN_PIXELS / 4) {
        windows.par_iter().map(per_window).collect()
    } else {
        windows.iter().map(per_window).collect()
    };
    let mut out: Vec<Quad> = Vec::new();
    for q in found.into_iter().flatten() {
        if !out.iter().any(|o| same_quad(o, &q)) {
            out.push(q);
        }
    }
    out
}

/// Signed area of a quad ([`polygon::signed_area`]; positive in [`Quad`]'s order).
pub(crate) fn signed_area(q: &Quad) -> f64 {
    polygon::signed_area(&q.map(|p| p.coords))
}

/// Whether two quads outline the same marker (close centres, similar areas).
fn same_quad(a: &Quad, b: &Quad) -> bool {
    let (aa, ab) = (signed_area(a), signed_area(b));
    let centre = |q: &Quad| q.iter().fold(Vector2::zeros(), |s, p| s + p.coords) / 4.0;
    (centre(a) - centre(b)).norm() < 0.15 * ab.sqrt() && aa < 1.4 * ab && ab < 1.4 * aa
}

/// (b - a) x (c - a).
fn cross(a: Point2<f64>, b: Point2<f64>, c: Point2<f64>) -> f64 {
    (b - a).perp(&(c - a))
}

/// Convex hull (Andrew), positive orientation, no collinear vertices, of points sorted
/// lexicographically (by x then y, or by y then x: the chains only need a monotone order),
/// without duplicates.
fn hull_of_sorted(pts: &[Point2<f64>]) -> Vec<Point2<f64>> {
    if pts.len() < 3 {
        return pts.to_vec();
    }
    let mut h: Vec<Point2<f64>> = Vec::with_capacity(2 * pts.len());
    for pass in 0..2 {
        let start = h.len();
        let iter: Box<dyn Iterator<Item = &Point2<f64>>> = if pass == 0 { Box::new(pts.iter()) } else { Box::new(pts.iter().rev()) };
        for &p in iter {
            while h.len() >= start + 2 && cross(h[h.len() - 2], h[h.len() - 1], p) <= 0.0 {
                h.pop();
            }
            h.push(p);
        }
        h.pop();
    }
    h
}

/// Each row's extent `(y, x0, x1)` of a component's runs (row order).
fn row_extents(runs: &[Run]) -> Vec<(u32, u32, u32)> {
    let mut rows: Vec<(u32, u32, u32)> = Vec::with_capacity(runs.len());
    for r in runs {
        match rows.last_mut() {
            Some(cur) if cur.0 == r.y => (cur.1, cur.2) = (cur.1.min(r.x0), cur.2.max(r.x1)),
            _ => rows.push((r.y, r.x0, r.x1)),
        }
    }
    rows
}

/// The outline's extreme points of pixel squares of half-size `grow` around the row extents, in
/// an order [`hull_of_sorted`] accepts: with `grow` 0.5 and consecutive rows (a connected
/// component) the extreme points of each pixel boundary line, already sorted by y then x; else
/// the four corners of each row, sorted by x then y.
fn outline_points(rows: &[(u32, u32, u32)], grow: f64) -> Vec<Point2<f64>> {
    let consecutive = rows.windows(2).all(|p| p[1].0 == p[0].0 + 1);
    if grow == 0.5 && consecutive {
        let y0 = rows.first().map_or(0.0, |r| f64::from(r.0) - 0.5);
        let mut pts = Vec::with_capacity(2 * rows.len() + 2);
        for k in 0..=rows.len() {
            let (x0, x1) = match (k.checked_sub(1).and_then(|i| rows.get(i)), rows.get(k)) {
                (Some(p), Some(n)) => (p.1.min(n.1), p.2.max(n.2)),
                (Some(e), None) | (None, Some(e)) => (e.1, e.2),
                (None, None) => continue,
            };
            let y = y0 + k as f64;
            pts.extend([Point2::new(f64::from(x0) - 0.5, y), Point2::new(f64::from(x1) - 0.5, y)]);
        }
        return pts;
    }
    let mut pts: Vec<Point2<f64>> = Vec::with_capacity(4 * rows.len());
    for &(y, x0, x1) in rows {
        let (x0, x1, y) = (f64::from(x0) - grow, f64::from(x1) - 1.0 + grow, f64::from(y));
        pts.extend([Point2::new(x0, y - grow), Point2::new(x0, y + grow), Point2::new(x1, y - grow), Point2::new(x1, y + grow)]);
    }
    pts.sort_by(|a, b| a.x.total_cmp(&b.x).then(a.y.total_cmp(&b.y)));
    pts.dedup();
    pts
}

/// The quad of a component's runs, search-image pixels, each pixel taken as the square of
/// half-size `grow` around its centre (0.5: the pixel itself); `None` when the outline is not one.
fn fit_quad(runs: &[Run], grow: f64, accuracy_rate: f64, (min_perimeter, max_perimeter): (f64, f64)) -> Option<Quad> {
    let h = hull_of_sorted(&outline_points(&row_extents(runs), grow));
    if h.len() < 4 {
        return None;
    }
    let idx = quad_corners(&h)?;
    let q = idx.map(|i| h[i]);
    let perimeter: f64 = (0..4).map(|i| (q[(i + 1) % 4] - q[i]).norm()).sum();
    if !(perimeter >= min_perimeter && perimeter <= max_perimeter && well_shaped(&q, perimeter)) {
        return None;
    }
    let tol = accuracy_rate * perimeter + 1.0;
    h.iter().all(|p| distance_to_outline(&q, *p) <= tol).then_some(q)
}

/// Indices of four hull vertices in hull order: the vertex farthest from the centroid, the one
/// farthest from it, and the farthest on each side of the line through those two.
fn quad_corners(h: &[Point2<f64>]) -> Option<[usize; 4]> {
    let c = h.iter().fold(Vector2::zeros(), |s, p| s + p.coords) / h.len() as f64;
    let farthest = |f: &dyn Fn(&Point2<f64>) -> f64| (0..h.len()).max_by(|&i, &j| f(&h[i]).total_cmp(&f(&h[j])));
    let a = farthest(&|p| (p.coords - c).norm_squared())?;
    let b = farthest(&|p| (p - h[a]).norm_squared())?;
    let l = farthest(&|p| cross(h[a], h[b], *p))?;
    let r = farthest(&|p| -cross(h[a], h[b], *p))?;
    let (dl, dr) = (cross(h[a], h[b], h[l]), -cross(h[a], h[b], h[r]));
    let side = (h[b] - h[a]).norm();
    if !(dl > 0.1 * side && dr > 0.1 * side) {
        return None;
    }
    let mut idx = [a, b, l, r];
    idx.sort_unstable();
    Some(idx)
}

/// Convex, positively oriented, no short side, no sharp corner.
fn well_shaped(q: &Quad, perimeter: f64) -> bool {
    (0..4).all(|i| {
        let (p, c, n) = (q[(i + 3) % 4], q[i], q[(i + 1) % 4]);
        let (u, v) = (n - c, p - c);
        let (lu, lv) = (u.norm(), v.norm());
        lu >= MIN_SIDE_RATE * perimeter && u.perp(&v) >= MIN_CORNER_SINE * lu * lv
    })
}

/// Distance of `p` from the quad's outline (nearest side segment).
fn distance_to_outline(q: &Quad, p: Point2<f64>) -> f64 {
    (0..4)
        .map(|i| {
            let (a, b) = (q[i], q[(i + 1) % 4]);
            let d = b - a;
            let t = ((p - a).dot(&d) / d.norm_squared().max(1e-12)).clamp(0.0, 1.0);
            (p - (a + d * t)).norm()
        })
        .fold(f64::INFINITY, f64::min)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn hull_and_quad_of_a_rotated_square() {
        // pixel runs of a square rotated by 30 degrees, side 40
        let (c, s) = (30f64.to_radians().cos(), 30f64.to_radians().sin());
        let inside = |x: f64, y: f64| {
            let (u, v) = (c * (x - 50.0) + s * (y - 50.0), -s * (x - 50.0) + c * (y - 50.0));
            u.abs() < 20.0 && v.abs() < 20.0
        };
        let mut runs = Vec::new();
        for y in 0..100u32 {
            let xs: Vec<u32> = (0..100).filter(|&x| inside(f64::from(x), f64::from(y))).collect();
            if let (Some(a), Some(b)) = (xs.first(), xs.last()) {
                runs.push(Run { y, x0: *a, x1: b + 1 });
            }
        }
        let q = fit_quad(&runs, 0.5, 0.03, (40.0, 1000.0)).unwrap();
        assert!(signed_area(&q) > 0.0);
        for (u, v) in [(-20.0, -20.0), (20.0, -20.0), (20.0, 20.0), (-20.0, 20.0)] {
            let p = Point2::new(50.0 + c * u - s * v, 50.0 + s * u + c * v);
            assert!(q.iter().any(|k| (k - p).norm() < 1.2), "{p} not in {q:?}");
        }
        // an L shape is no quad
        let l: Vec<Run> = (0..40).map(|y| Run { y, x0: 0, x1: if y < 30 { 10 } else { 40 } }).collect();
        assert!(fit_quad(&l, 0.5, 0.03, (40.0, 1000.0)).is_none());
    }
}
