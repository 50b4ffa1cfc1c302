//! A two-level outline over the whole image (the S-path sphere's silhouette against the
//! background) as one conic.
//!
//! A dot's local edge model (`edge_surround`) measures the edge on the lines across it
//! that no dot touches. Where dots line the outline for a long stretch, those lines are few and
//! on one side, and a local cubic extrapolates by tenths of a pixel. The silhouette of a sphere
//! through a pinhole lens is a conic, and most of it is free of dots: every clean crossing of the
//! two levels on the image's rows and columns (measured like the local model's, by the sum of the
//! coverages across a short span, exact on a box-filtered render of a straight edge; the levels
//! from the flat ends of each span) goes into one robust conic fit, which then bridges any
//! stretch the dots hide. The fit starts from the longest run of neighbouring crossings, lets
//! the other runs join where they lie on it, then trims to the inliers among all crossings, so
//! that stray edges at the same two levels do not pull it. Lens distortion bends a silhouette
//! away from a conic; a fit whose inliers' RMS exceeds 0.05 px is refused and the local models
//! are kept (the course sphere under k1 = -0.25, centred or shifted by up to 0.3 m, still fits
//! to 0.012-0.017 px RMS).
//!
//! Reference: the conic fit is the algebraic least-squares fit with Sampson (first-order
//! geometric) reweighting, Hartley and Zisserman, *Multiple View Geometry*, 2nd ed., sec. 4.2.6;
//! Fitzgibbon, Pilu, Fisher, "Direct least square fitting of ellipses", PAMI 21(5), 1999.

use std::collections::HashMap;

use nalgebra::{Matrix6, SymmetricEigen, Vector6};

use super::filters::median_by;
use super::ImageF32;

/// Pixels summed on each side of a crossing (the transition pixels in between).
const SIDE: usize = 3;
/// Largest spread of a flat end, as a share of the contrast.
const FLAT: f64 = 0.06;
/// Fewest crossings for a fit.
const MIN_POINTS: usize = 40;
/// Largest RMS distance of the kept crossings from the conic, pixels, for the fit to count.
const MAX_RMS_PX: f64 = 0.05;
/// Smallest inlier gate, pixels (the crossings' noise is about 0.02 px at sigma 1 grey level).
const INLIER_PX: f64 = 0.15;
/// Most fits of the reweighting loop.
const MAX_PASSES: usize = 12;

/// The outline conic `a u^2 + b u v + c v^2 + d u + e v + f = 0` in normalised coordinates
/// `u = (x - cx) / scale`, `v = (y - cy) / scale`.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Outline {
    conic: Vector6<f64>,
    centre: [f64; 2],
    scale: f64,
    /// Sign of the conic's value on the bright side.
    bright_sign: f64,
    /// Dark level (median over the kept crossings).
    pub lo: f64,
    /// Bright level.
    pub hi: f64,
    /// Crossings the fit kept.
    pub points: usize,
    /// Their RMS distance from the conic, pixels.
    pub rms_px: f64,
}

impl Outline {
    /// Fit the outline between levels near `lo` and `hi` in `img`, skipping lines whose span
    /// touches a pixel with `skip(x, y)` (the dots). `None` when too few clean crossings exist or
    /// they do not lie on one conic.
    pub fn fit(img: &ImageF32, lo: f64, hi: f64, skip: &dyn Fn(usize, usize) -> bool) -> Option<Self> {
        let found = crossings(img, lo, hi, skip);
        if found.len() < MIN_POINTS {
            return None;
        }
        let points: Vec<[f64; 2]> = found.iter().map(|c| c.at).collect();
        let n = points.len() as f64;
        let centre = [points.iter().map(|p| p[0]).sum::<f64>() / n, points.iter().map(|p| p[1]).sum::<f64>() / n];
        let scale = (points.iter().map(|p| (p[0] - centre[0]).powi(2) + (p[1] - centre[1]).powi(2)).sum::<f64>() / n).sqrt().max(1.0);
        let uv: Vec<[f64; 2]> = points.iter().map(|p| [(p[0] - centre[0]) / scale, (p[1] - centre[1]) / scale]).collect();
        let dist_px = |conic: &Vector6<f64>, p: &[f64; 2]| {
            let (value, grad) = eval(conic, p);
            (value / grad.max(1e-12)).abs() * scale
        };
        // Seed: the longest run of neighbouring crossings (a stretch of the outline; stray edges
        // elsewhere form runs of their own). Then every run whose median distance from the fit
        // is within JOIN_PX joins, and the fit is repeated, until none joins.
        let (run_of, runs) = runs(&points);
        let mut joined = vec![false; runs];
        let mut run_size = vec![0usize; runs];
        run_of.iter().for_each(|&r| run_size[r] += 1);
        let seed = (0..runs).max_by_key(|&r| run_size[r])?;
        joined[seed] = true;
        let mut weights = vec![1.0; uv.len()];
        let mut keep: Vec<bool> = run_of.iter().map(|&r| joined[r]).collect();
        let mut conic = fit_weighted(&uv, &weights, &keep)?;
        for _ in 0..MAX_PASSES {
            update_weights(&conic, &uv, &mut weights);
            conic = fit_weighted(&uv, &weights, &keep)?;
            let mut per_run: Vec<Vec<f64>> = vec![Vec::new(); runs];
            for (p, &r) in uv.iter().zip(&run_of) {
                if !joined[r] {
                    per_run[r].push(dist_px(&conic, p));
                }
            }
            let mut grew = false;
            for (r, d) in per_run.iter_mut().enumerate() {
                if !d.is_empty() && median_by(d, f64::total_cmp).is_some_and(|m| m <= JOIN_PX) {
                    joined[r] = true;
                    grew = true;
                }
            }
            keep = run_of.iter().map(|&r| joined[r]).collect();
            if !grew {
                break;
            }
        }
        // Then the inliers among all crossings: within 4 median distances of the kept ones
        // (about 2.7 sigma of Gaussian noise), at least INLIER_PX, until they stop changing.
        for _ in 0..MAX_PASSES {
            update_weights(&conic, &uv, &mut weights);
            conic = fit_weighted(&uv, &weights, &keep)?;
            let dists: Vec<f64> = uv.iter().map(|p| dist_px(&conic, p)).collect();
            let mut kept_d: Vec<f64> = dists.iter().zip(&keep).filter(|(_, k)| **k).map(|(d, _)| *d).collect();
            let gate = (4.0 * median_by(&mut kept_d, f64::total_cmp)?).max(INLIER_PX);
            let next: Vec<bool> = dists.iter().map(|d| *d <= gate).collect();
            if next == keep {
                break;
            }
            keep = next;
        }
        let dist: Vec<f64> = uv.iter().zip(&keep).filter(|(_, k)| **k).map(|(p, _)| dist_px(&conic, p)).collect();
        if dist.len() < MIN_POINTS {
            return None;
        }
        let rms_px = (dist.iter().map(|d| d * d).sum::<f64>() / dist.len() as f64).sqrt();
        // Levels and the conic's sign on the bright side, from the kept crossings.
        let kept: Vec<&Crossing> = found.iter().zip(&keep).filter(|(_, k)| **k).map(|(c, _)| c).collect();
        let mut darks: Vec<f64> = kept.iter().map(|c| c.dark).collect();
        let mut brights: Vec<f64> = kept.iter().map(|c| c.bright).collect();
        let bright_votes: f64 = kept
            .iter()
            .map(|c| {
                let p = [(c.at[0] + c.to_bright[0] - centre[0]) / scale, (c.at[1] + c.to_bright[1] - centre[1]) / scale];
                eval(&conic, &p).0.signum()
            })
            .sum();
        let (lo, hi) = (median_by(&mut darks, f64::total_cmp)?, median_by(&mut brights, f64::total_cmp)?);
        (rms_px <= MAX_RMS_PX).then_some(Self { conic, centre, scale, bright_sign: bright_votes.signum(), lo, hi, points: dist.len(), rms_px })
    }

    /// Where the outline crosses the row `y = t` (`rows`) or the column `x = t`: the crossing's
    /// other coordinate nearest to `near`, if any.
    pub fn crossing(&self, rows: bool, t: f64, near: f64) -> Option<f64> {
        let [a, b, c, d, e, f] = [self.conic[0], self.conic[1], self.conic[2], self.conic[3], self.conic[4], self.conic[5]];
        let (cx, cy) = (self.centre[0], self.centre[1]);
        // The quadratic in the free coordinate s (normalised) at the fixed one w.
        let (qa, qb, qc, origin) = if rows {
            let w = (t - cy) / self.scale;
            (a, b * w + d, c * w * w + e * w + f, cx)
        } else {
            let w = (t - cx) / self.scale;
            (c, b * w + e, a * w * w + d * w + f, cy)
        };
        let roots: Vec<f64> = if qa.abs() < 1e-12 {
            if qb.abs() < 1e-12 {
                return None;
            }
            vec![-qc / qb]
        } else {
            let disc = qb * qb - 4.0 * qa * qc;
            if disc < 0.0 {
                return None;
            }
            // The stable form of the two roots.
            let q = -0.5 * (qb + qb.signum() * disc.sqrt());
            let mut r = vec![q / qa];
            if q.abs() > 1e-15 {
                r.push(qc / q);
            }
            r
        };
        roots.into_iter().map(|s| origin + s * self.scale).min_by(|x, y| (x - near).abs().total_cmp(&(y - near).abs()))
    }

    /// Whether the pixel point `(x, y)` is on the bright side.
    pub fn is_bright(&self, x: f64, y: f64) -> bool {
        self.distance_px(x, y) * self.bright_sign > 0.0
    }

    /// Signed distance of the pixel point `(x, y)` from the conic, pixels (first order).
    pub fn distance_px(&self, x: f64, y: f64) -> f64 {
        let p = [(x - self.centre[0]) / self.scale, (y - self.centre[1]) / self.scale];
        let (value, grad) = eval(&self.conic, &p);
        value / grad.max(1e-12) * self.scale
    }
}

/// Crossings closer than this are neighbours on one curve, pixels.
const LINK_PX: f64 = 2.0;
/// A run joins the fit when its crossings' median distance from it is at most this, pixels.
const JOIN_PX: f64 = 1.0;

/// Runs of crossings linked by neighbours closer than [`LINK_PX`]: the run of each crossing, and
/// the number of runs.
fn runs(points: &[[f64; 2]]) -> (Vec<usize>, usize) {
    let cell = |p: &[f64; 2]| ((p[0] / LINK_PX).floor() as i64, (p[1] / LINK_PX).floor() as i64);
    let mut grid: HashMap<(i64, i64), Vec<usize>> = HashMap::new();
    for (k, p) in points.iter().enumerate() {
        grid.entry(cell(p)).or_default().push(k);
    }
    let mut run_of = vec![usize::MAX; points.len()];
    let mut runs = 0;
    for start in 0..points.len() {
        if run_of[start] != usize::MAX {
            continue;
        }
        run_of[start] = runs;
        let mut stack = vec![start];
        while let Some(k) = stack.pop() {
            let (cx, cy) = cell(&points[k]);
            for dy in -1..=1 {
                for dx in -1..=1 {
                    for &j in grid.get(&(cx + dx, cy + dy)).into_iter().flatten() {
                        let d2 = (points[j][0] - points[k][0]).powi(2) + (points[j][1] - points[k][1]).powi(2);
                        if run_of[j] == usize::MAX && d2 <= LINK_PX * LINK_PX {
                            run_of[j] = runs;
                            stack.push(j);
                        }
                    }
                }
            }
        }
        runs += 1;
    }
    (run_of, runs)
}

/// The algebraic conic fit (unit coefficient vector minimising the weighted squared conic values)
/// over the points with `keep`.
fn fit_weighted(uv: &[[f64; 2]], weights: &[f64], keep: &[bool]) -> Option<Vector6<f64>> {
    let mut m = Matrix6::zeros();
    for ((p, w), k) in uv.iter().zip(weights).zip(keep) {
        if *k {
            let z = design(p);
            m += *w * z * z.transpose();
        }
    }
    let eig = SymmetricEigen::new(m);
    let (imin, _) = eig.eigenvalues.iter().enumerate().min_by(|a, b| a.1.total_cmp(b.1))?;
    let c = eig.eigenvectors.column(imin).into_owned();
    c.iter().all(|v| v.is_finite()).then_some(c)
}

/// Sampson weights `1 / |grad|^2` at `conic`: the weighted algebraic fit then minimises the
/// first-order geometric distances.
fn update_weights(conic: &Vector6<f64>, uv: &[[f64; 2]], weights: &mut [f64]) {
    for (w, p) in weights.iter_mut().zip(uv) {
        *w = 1.0 / eval(conic, p).1.max(1e-12).powi(2);
    }
}

fn design(p: &[f64; 2]) -> Vector6<f64> {
    let [u, v] = *p;
    Vector6::new(u * u, u * v, v * v, u, v, 1.0)
}

/// Conic value and gradient norm at `p` (normalised coordinates).
fn eval(c: &Vector6<f64>, p: &[f64; 2]) -> (f64, f64) {
    let [u, v] = *p;
    let value = c.dot(&design(p));
    let gu = 2.0 * c[0] * u + c[1] * v + c[3];
    let gv = c[1] * u + 2.0 * c[2] * v + c[4];
    (value, gu.hypot(gv))
}

/// A clean crossing: the point on the edge, its two levels and the unit step towards the bright side.
struct Crossing {
    at: [f64; 2],
    dark: f64,
    bright: f64,
    to_bright: [f64; 2],
}

/// Clean crossings of the two levels on every row and column.
fn crossings(img: &ImageF32, lo: f64, hi: f64, skip: &dyn Fn(usize, usize) -> bool) -> Vec<Crossing> {
    let (w, h) = (img.width, img.height);
    let mid = (0.5 * (lo + hi)) as f32;
    // Candidates in one raster pass over masks of the pixels above the mid level: pixel pairs on
    // either side of it, to the right (a row crossing) and below (a column crossing).
    let mut candidates: Vec<(bool, usize, usize)> = Vec::new();
    let mask = |y: usize, m: &mut [u8]| {
        for (m, v) in m.iter_mut().zip(&img.data[y * w..(y + 1) * w]) {
            *m = u8::from(*v > mid);
        }
    };
    let (mut cur, mut next) = (vec![0u8; w], vec![0u8; w]);
    if h > 0 {
        mask(0, &mut cur);
    }
    for y in 0..h {
        if w > 1 {
            differ_at(&cur[..w - 1], &cur[1..], |x| candidates.push((true, y, x)));
        }
        if y + 1 < h {
            mask(y + 1, &mut next);
            differ_at(&cur, &next, |x| candidates.push((false, x, y)));
            std::mem::swap(&mut cur, &mut next);
        }
    }
    candidates.into_iter().filter_map(|(rows, line, k)| crossing_at(img, rows, line, k, lo, hi, skip)).collect()
}

/// Call `f(i)` for every index where `a` and `b` (equal lengths) differ, comparing eight bytes at
/// a time (crossings are rare).
fn differ_at(a: &[u8], b: &[u8], mut f: impl FnMut(usize)) {
    let blocks = a.len() / 8;
    for (k, (p, q)) in a.chunks_exact(8).zip(b.chunks_exact(8)).enumerate() {
        if p != q {
            (0..8).filter(|&i| p[i] != q[i]).for_each(|i| f(8 * k + i));
        }
    }
    (8 * blocks..a.len()).filter(|&i| a[i] != b[i]).for_each(f);
}

/// The crossing between pixels `k` and `k + 1` of row (`rows`) or column `line`, if the span of
/// [`SIDE`] pixels on either side is clean: flat ends near the two levels, no skipped pixel.
fn crossing_at(img: &ImageF32, rows: bool, line: usize, k: usize, lo: f64, hi: f64, skip: &dyn Fn(usize, usize) -> bool) -> Option<Crossing> {
    let len = if rows { img.width } else { img.height };
    if k < SIDE || k + 1 + SIDE >= len {
        return None;
    }
    let xy = |j: usize| if rows { (j, line) } else { (line, j) };
    let at = |j: usize| {
        let (x, y) = xy(j);
        f64::from(img.data[y * img.width + x])
    };
    let contrast = hi - lo;
    // Span: SIDE flat pixels, the two transition pixels k and k + 1, SIDE flat pixels.
    let (s0, s1) = (k - SIDE, k + 1 + SIDE);
    let side = |a: usize| {
        let mean = (a..a + SIDE).map(at).sum::<f64>() / SIDE as f64;
        let spread = (a..a + SIDE).map(|j| (at(j) - mean).abs()).fold(0.0, f64::max);
        (mean, spread)
    };
    let (l, ls) = side(s0);
    let (r, rs) = side(s1 + 1 - SIDE);
    let (dark, bright) = if l < r { (l, r) } else { (r, l) };
    if ls > FLAT * contrast || rs > FLAT * contrast || (dark - lo).abs() > 0.15 * contrast || (bright - hi).abs() > 0.15 * contrast {
        return None;
    }
    if (s0..=s1).any(|j| {
        let (x, y) = xy(j);
        skip(x, y)
    }) {
        return None;
    }
    let cov_sum: f64 = (s0..=s1).map(|j| (at(j) - dark) / (bright - dark)).sum();
    let e = if r > l { s1 as f64 + 0.5 - cov_sum } else { s0 as f64 - 0.5 + cov_sum };
    let step = if r > l { 1.0 } else { -1.0 };
    Some(Crossing { at: if rows { [e, line as f64] } else { [line as f64, e] }, dark, bright, to_bright: if rows { [step, 0.0] } else { [0.0, step] } })
}

#[cfg(test)]
mod tests;
