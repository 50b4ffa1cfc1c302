//! Sub-pixel marker outline: each side of a candidate quad is located on the full-resolution
//! image by the mid-level crossings of short intensity profiles across it (bilinear samples,
//! from inside the black border to inside the white margin), a total-least-squares line through
//! them (one outlier-trimming pass), and adjacent lines intersected. Two passes, so that the
//! second profiles are centred on the first result.
//!
//! Reference: OpenCV `aruco_detector.cpp` (`_refineCandidateLines`, CORNER_REFINE_CONTOUR: line
//! fits to the contour points of each side, corners as intersections).

use nalgebra::{Point2, Vector2};

use super::quads::Quad;
use super::Samples;

/// Profile sample spacing of the two passes, pixels.
const STEPS: [f64; 2] = [1.0, 0.5];
/// Most profiles per side in the two passes.
const PROFILES: [usize; 2] = [6, 10];
/// Largest reach of the second pass's profiles to either side of the first pass's line, pixels.
const SECOND_REACH_PX: f64 = 2.5;
/// Crossings farther than this from their side's line are dropped before the refit, pixels.
const TRIM_PX: f64 = 0.5;
/// Fewest crossings per side.
const MIN_POINTS: usize = 4;

/// A line through `p` with unit direction `d`.
#[derive(Debug, Clone, Copy)]
struct Line {
    p: Point2<f64>,
    d: Vector2<f64>,
}

/// Refine `q` (border_rate: black border width over marker side; margin_rate: white margin width
/// over marker side), with at least `min_contrast` grey levels across each profile.
pub(super) fn refine<I: Samples + ?Sized>(img: &I, q: &Quad, border_rate: f64, margin_rate: f64, min_contrast: f64) -> Option<Quad> {
    let mut cur = *q;
    for (pass, step) in STEPS.into_iter().enumerate() {
        let side = (0..4).map(|i| (cur[(i + 1) % 4] - cur[i]).norm()).fold(f64::INFINITY, f64::min);
        let cap = if pass == 0 { f64::INFINITY } else { SECOND_REACH_PX };
        let inside = (0.8 * side * border_rate).clamp(1.0, cap);
        let outside = (0.8 * side * margin_rate).clamp(1.0, cap);
        let mut lines = [Line { p: Point2::origin(), d: Vector2::zeros() }; 4];
        for (i, l) in lines.iter_mut().enumerate() {
            *l = side_line(img, cur[i], cur[(i + 1) % 4], (inside, outside, step), (PROFILES[pass], min_contrast))?;
        }
        let next: Vec<Point2<f64>> = (0..4).filter_map(|i| intersect(&lines[(i + 3) % 4], &lines[i])).collect();
        let next: Quad = next.try_into().ok()?;
        let limit = (0.15 * side).max(2.0);
        if next.iter().zip(&cur).any(|(n, c)| !((n - c).norm() <= limit)) {
            return None;
        }
        cur = next;
    }
    Some(cur)
}

/// The fitted line of side `a -> b` (interior on its left in the positive orientation).
fn side_line<I: Samples + ?Sized>(img: &I, a: Point2<f64>, b: Point2<f64>, reach: (f64, f64, f64), (profiles, min_contrast): (usize, f64)) -> Option<Line> {
    let len = (b - a).norm();
    if !(len > 2.0) {
        return None;
    }
    let d = (b - a) / len;
    let out = Vector2::new(d.y, -d.x);
    let n = ((len / 4.0) as usize).clamp(5, profiles.max(5));
    let mut profile = Vec::new();
    let pts: Vec<Point2<f64>> = (0..n)
        .filter_map(|k| {
            let t = 0.12 + 0.76 * (k as f64 + 0.5) / n as f64;
            let s = crossing(img, a + (b - a) * t, out, reach, min_contrast, &mut profile)?;
            Some(a + (b - a) * t + out * s)
        })
        .collect();
    let line = fit_line(&pts)?;
    let kept: Vec<Point2<f64>> = pts.iter().copied().filter(|p| (p - line.p).perp(&line.d).abs() <= TRIM_PX).collect();
    fit_line(&kept)
}

/// Offset along `out` of the dark-to-light mid-level crossing nearest `c` on the profile from
/// `-reach.0` to `reach.1` in steps of `reach.2`.
fn crossing<I: Samples + ?Sized>(
    img: &I,
    c: Point2<f64>,
    out: Vector2<f64>,
    (inside, outside, step): (f64, f64, f64),
    min_contrast: f64,
    v: &mut Vec<f64>,
) -> Option<f64> {
    let (k0, k1) = ((inside / step).ceil() as i64, (outside / step).ceil() as i64);
    v.clear();
    for k in -k0..=k1 {
        v.push(f64::from(img.bilinear(c + out * (k as f64 * step))?));
    }
    let (lo, hi) = v.iter().fold((f64::INFINITY, f64::NEG_INFINITY), |(l, h), x| (l.min(*x), h.max(*x)));
    if !(hi - lo >= min_contrast) {
        return None;
    }
    let mid = 0.5 * (lo + hi);
    (0..v.len() - 1)
        .filter(|&k| v[k] < mid && v[k + 1] >= mid)
        .map(|k| ((k as i64 - k0) as f64 + (mid - v[k]) / (v[k + 1] - v[k])) * step)
        .min_by(|x, y| x.abs().total_cmp(&y.abs()))
}

/// Total-least-squares line through at least [`MIN_POINTS`] points.
fn fit_line(pts: &[Point2<f64>]) -> Option<Line> {
    if pts.len() < MIN_POINTS {
        return None;
    }
    let c = pts.iter().fold(Vector2::zeros(), |s, p| s + p.coords) / pts.len() as f64;
    let (sxx, sxy, syy) = pts.iter().fold((0.0, 0.0, 0.0), |(a, b, e), p| {
        let r = p.coords - c;
        (a + r.x * r.x, b + r.x * r.y, e + r.y * r.y)
    });
    // principal axis of the scatter matrix in closed form
    let t = 0.5 * (2.0 * sxy).atan2(sxx - syy);
    let d = Vector2::new(t.cos(), t.sin());
    d.iter().all(|x| x.is_finite()).then_some(Line { p: Point2::from(c), d })
}

/// Intersection of two lines; `None` when (nearly) parallel.
fn intersect(l1: &Line, l2: &Line) -> Option<Point2<f64>> {
    let den = l1.d.perp(&l2.d);
    if !(den.abs() > 1e-6) {
        return None;
    }
    let t = (l2.p - l1.p).perp(&l2.d) / den;
    let p = l1.p + l1.d * t;
    (p.x.is_finite() && p.y.is_finite()).then_some(p)
}
