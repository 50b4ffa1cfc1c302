//! The surround of a dot that straddles a two-level edge (the S-path sphere's outline against the
//! background), as a model: `S = lo + (hi - lo) * coverage`, with `coverage` the share of the pixel
//! on the bright side of a locally cubic edge curve.
//!
//! A morphological closing does not restore such an edge where the dot hides it (the closing's
//! square pokes into the dot and moves the edge), and it rides on noise peaks. Here the edge is
//! measured away from the dots instead: along every line of pixels across the edge (rows for a
//! mostly vertical edge, columns otherwise) that no dot touches, the sum of the pixels' coverages
//! `(I - lo) / (hi - lo)` over a short span gives the edge's crossing exactly on a box-filtered
//! render of a straight edge. A cubic `e(t) = c0 + c1 t + c2 t^2 + c3 t^3` fitted to the crossings
//! bridges the lines the dots hide (the sphere's outline is a conic; over a dot's window of
//! some 60 px a cubic follows it to a few thousandths of a pixel). Each pixel's coverage is then integrated over 16 sub-lines.

use nalgebra::{Matrix4, Vector4};

use super::filters::median_by;
use super::outline::Outline;
use super::ImageF32;

/// Half-length of the span summed across the edge, pixels.
const SPAN: usize = 4;
/// Sub-lines per pixel when integrating the coverage.
const SUB: usize = 16;
/// Scale of the along-coordinate in the fit (conditioning).
const T_SCALE: f64 = 16.0;
/// Fewest edge lines for a fit.
const MIN_LINES: usize = 8;
/// Largest median distance between a window's clean crossings and the whole-image outline for
/// the outline to be the window's edge, pixels.
const SAME_EDGE_PX: f64 = 0.5;

/// Pixel rectangle `[x0, y0, x1, y1]`, inclusive.
pub type Rect = [usize; 4];

/// A fitted two-level edge near one dot.
#[derive(Debug, Clone, PartialEq)]
pub struct EdgeSurround {
    /// Lines across the edge are rows (edge mostly vertical) or columns.
    rows: bool,
    /// The bright side is towards growing across-coordinate.
    bright_up: bool,
    /// Dark (background) level.
    lo: f64,
    /// Bright (sphere) level.
    hi: f64,
    /// Crossing `e(t) = c0 + c1 s + c2 s^2 + c3 s^3`, `s = (t - t0) / T_SCALE`, `t` the along-coordinate.
    coef: Vector4<f64>,
    /// Origin of the along-coordinate.
    t0: f64,
    /// The clean crossings `(t, e)` the fit kept.
    samples: Vec<(f64, f64)>,
}

impl EdgeSurround {
    /// Fit the edge in `rect` of `img`. `guide` is a dot-free estimate of the surround there (the
    /// closing) that tells the two sides apart; `skip(x, y)` marks pixels of dots. `None` when the
    /// rectangle holds no clean two-level edge of at least `min_contrast`.
    pub fn fit(img: &ImageF32, rect: Rect, guide: &dyn Fn(usize, usize) -> f32, skip: &dyn Fn(usize, usize) -> bool, min_contrast: f64) -> Option<Self> {
        let [x0, y0, x1, y1] = rect;
        let (mut gmin, mut gmax, mut gx, mut gy) = (f32::INFINITY, f32::NEG_INFINITY, 0.0f64, 0.0f64);
        for y in y0..=y1 {
            for x in x0..=x1 {
                let g = guide(x, y);
                gmin = gmin.min(g);
                gmax = gmax.max(g);
                if x < x1 {
                    gx += f64::from((guide(x + 1, y) - g).abs());
                }
                if y < y1 {
                    gy += f64::from((guide(x, y + 1) - g).abs());
                }
            }
        }
        if f64::from(gmax - gmin) <= min_contrast {
            return None;
        }
        let (mid, q) = (0.5 * (gmin + gmax), 0.25 * (gmax - gmin));
        let level = |bright: bool| {
            let mut v: Vec<f32> = (y0..=y1)
                .flat_map(|y| (x0..=x1).map(move |x| (x, y)))
                .filter(|&(x, y)| !skip(x, y) && if bright { guide(x, y) > mid + q } else { guide(x, y) < mid - q })
                .map(|(x, y)| img.at(x, y))
                .collect();
            median_by(&mut v, f32::total_cmp).map(f64::from)
        };
        let (lo, hi) = (level(false)?, level(true)?);
        if hi - lo <= min_contrast {
            return None;
        }
        let rows = gx >= gy;
        // (across, along) -> image value / dot flag.
        let (a0, a1, t0, t1) = if rows { (x0, x1, y0, y1) } else { (y0, y1, x0, x1) };
        let xy = |a: usize, t: usize| if rows { (a, t) } else { (t, a) };
        let cov = |a: usize, t: usize| {
            let (x, y) = xy(a, t);
            (f64::from(img.at(x, y)) - lo) / (hi - lo)
        };
        let mut samples: Vec<(f64, f64, bool)> = Vec::new();
        for t in t0..=t1 {
            let crossings: Vec<usize> = (a0..a1).filter(|&a| (cov(a, t) - 0.5) * (cov(a + 1, t) - 0.5) <= 0.0).collect();
            let [k] = crossings[..] else { continue };
            if k < a0 + SPAN || k + 1 + SPAN > a1 {
                continue;
            }
            let (s0, s1) = (k - SPAN + 1, k + SPAN);
            let clean = (s0..=s1).all(|a| {
                let (x, y) = xy(a, t);
                !skip(x, y) && cov(a, t) > -0.1 && cov(a, t) < 1.1
            });
            let up = cov(s1, t) > 0.5;
            let ends_flat = (cov(s0, t) - if up { 0.0 } else { 1.0 }).abs() < 0.08 && (cov(s1, t) - if up { 1.0 } else { 0.0 }).abs() < 0.08;
            if !clean || !ends_flat {
                continue;
            }
            let sum: f64 = (s0..=s1).map(|a| cov(a, t)).sum();
            let e = if up { s1 as f64 + 0.5 - sum } else { s0 as f64 - 0.5 + sum };
            samples.push((t as f64, e, up));
        }
        let ups = samples.iter().filter(|s| s.2).count();
        let bright_up = 2 * ups >= samples.len();
        samples.retain(|s| s.2 == bright_up);
        let tc = 0.5 * (t0 + t1) as f64;
        let mut coef = Self::fit_cubic(&samples, tc)?;
        // One pass of outlier rejection (a line grazing an undetected speck).
        samples.retain(|&(t, e, _)| (Self::eval(&coef, t - tc) - e).abs() < 0.25);
        coef = Self::fit_cubic(&samples, tc)?;
        Some(Self { rows, bright_up, lo, hi, coef, t0: tc, samples: samples.iter().map(|s| (s.0, s.1)).collect() })
    }

    /// This edge with its crossings on every line of `rect` taken from the whole-image
    /// `outline` (which holds thousands of clean crossings to a few hundredths of a pixel), if
    /// the outline is this edge: its crossings lie within `SAME_EDGE_PX` (0.5 px) of the window's clean
    /// ones (median). The window's own crossings next to the dots can be off by tenths of a
    /// pixel (the faint ends of slivers along the edge), and where the dots hide most lines a
    /// cubic extrapolates from a few lines on one side; the conic bridges both.
    pub fn along(&self, outline: &Outline, rect: Rect) -> Option<Self> {
        let mut diffs: Vec<f64> = self.samples.iter().filter_map(|&(t, e)| outline.crossing(self.rows, t, e).map(|c| (c - e).abs())).collect();
        if diffs.len() < self.samples.len() || median_by(&mut diffs, f64::total_cmp)? > SAME_EDGE_PX {
            return None;
        }
        let samples = outline_crossings(outline, self.rows, rect, -0.5, &|t| Self::eval(&self.coef, t - self.t0));
        let coef = Self::fit_cubic(&samples, self.t0)?;
        Some(Self { coef, samples: samples.iter().map(|s| (s.0, s.1)).collect(), ..self.clone() })
    }

    /// The edge in `rect` from the whole-image `outline` alone (where the dots hide every line
    /// across it in the window): crossings on rows or on columns, whichever has more lines
    /// whose crossing falls inside the window; `None` where the outline does not pass `rect`.
    pub fn from_outline(outline: &Outline, rect: Rect) -> Option<Self> {
        let [x0, y0, x1, y1] = rect;
        let candidates = [true, false].map(|rows| {
            let (a0, a1, t0, t1) = if rows { (x0, x1, y0, y1) } else { (y0, y1, x0, x1) };
            let mid = 0.5 * (a0 + a1) as f64;
            (rows, outline_crossings(outline, rows, rect, 0.5, &|_| mid), 0.5 * (t0 + t1) as f64)
        });
        let (rows, samples, tc) = candidates.into_iter().max_by_key(|c| c.1.len())?;
        let coef = Self::fit_cubic(&samples, tc)?;
        let (t, e) = (samples[0].0, samples[0].1);
        let bright_up = if rows { outline.is_bright(e + 1.0, t) } else { outline.is_bright(t, e + 1.0) };
        Some(Self { rows, bright_up, lo: outline.lo, hi: outline.hi, coef, t0: tc, samples: samples.iter().map(|s| (s.0, s.1)).collect() })
    }

    /// Dark and bright levels.
    pub fn levels(&self) -> (f64, f64) {
        (self.lo, self.hi)
    }

    fn eval(c: &Vector4<f64>, t: f64) -> f64 {
        let t = t / T_SCALE;
        c[0] + t * (c[1] + t * (c[2] + t * c[3]))
    }

    fn fit_cubic(samples: &[(f64, f64, bool)], tc: f64) -> Option<Vector4<f64>> {
        if samples.len() < MIN_LINES {
            return None;
        }
        let (mut m, mut r) = (Matrix4::zeros(), Vector4::zeros());
        for &(t, e, _) in samples {
            let t = (t - tc) / T_SCALE;
            let v = Vector4::new(1.0, t, t * t, t * t * t);
            m += v * v.transpose();
            r += v * e;
        }
        let c = m.lu().solve(&r)?;
        // A slope well beyond 1 means the lines run along the edge: no fit.
        (c[1].abs() <= 1.5 * T_SCALE).then_some(c)
    }

    /// Modelled surround level at pixel `(x, y)`.
    pub fn level_at(&self, x: usize, y: usize) -> f64 {
        let (a, t) = if self.rows { (x as f64, y as f64) } else { (y as f64, x as f64) };
        let mut frac = 0.0;
        for j in 0..SUB {
            let tt = t - 0.5 + (j as f64 + 0.5) / SUB as f64 - self.t0;
            let e = Self::eval(&self.coef, tt);
            frac += if self.bright_up { a + 0.5 - e } else { e - (a - 0.5) }.clamp(0.0, 1.0);
        }
        self.lo + (self.hi - self.lo) * frac / SUB as f64
    }

    /// Share of a pixel on the bright side of the edge, from its modelled level
    /// ([`Self::level_at`]).
    pub fn bright_fraction(&self, level: f64) -> f64 {
        (level - self.lo) / (self.hi - self.lo)
    }

    /// Whether the point `(x, y)` (pixel coordinates) is on the bright side.
    fn is_bright(&self, x: f64, y: f64) -> bool {
        let (a, t) = if self.rows { (x, y) } else { (y, x) };
        let e = Self::eval(&self.coef, t - self.t0);
        if self.bright_up {
            a > e
        } else {
            a < e
        }
    }

    /// Coverage of pixel `(x, y)` by a dark occluder of level `dark` in front of the edge, whose
    /// boundary crosses the pixel as a straight line with the occluder towards the unit vector
    /// `inward`: the line is moved until the modelled mean level of the pixel (occluder, bright
    /// and dark sides sub-sampled 16 x 16) equals `observed`. Where an occluder's rim crosses the
    /// edge, the plain darkness `(S - I) / (S - dark)` is wrong: covering the dark side darkens
    /// the pixel less than covering the bright side.
    pub fn occluder_coverage(&self, x: usize, y: usize, observed: f64, dark: f64, inward: [f64; 2]) -> f64 {
        const N: usize = 16;
        let mut samples: Vec<(f64, f64)> = Vec::with_capacity(N * N);
        for j in 0..N {
            for i in 0..N {
                let (dx, dy) = ((i as f64 + 0.5) / N as f64 - 0.5, (j as f64 + 0.5) / N as f64 - 0.5);
                let level = if self.is_bright(x as f64 + dx, y as f64 + dy) { self.hi } else { self.lo };
                samples.push((inward[0] * dx + inward[1] * dy, level));
            }
        }
        // Most inward first: the occluder covers a prefix.
        samples.sort_by(|a, b| b.0.total_cmp(&a.0));
        let n = samples.len() as f64;
        let mut mean = samples.iter().map(|s| s.1).sum::<f64>() / n;
        if observed >= mean {
            return 0.0;
        }
        for (m, s) in samples.iter().enumerate() {
            let next = mean - (s.1 - dark) / n;
            if next <= observed {
                let frac = if mean - next > 1e-12 { (mean - observed) / (mean - next) } else { 1.0 };
                return (m as f64 + frac) / n;
            }
            mean = next;
        }
        1.0
    }
}

/// The outline's crossings `(t, e, _)` with every line of `rect` (rows if `rows`, else columns),
/// each the root nearest to `near(t)`, kept where `e` lies at least `inset` pixels inside the
/// rectangle's across-range (a negative `inset` lets it lie that far outside).
fn outline_crossings(outline: &Outline, rows: bool, rect: Rect, inset: f64, near: &dyn Fn(f64) -> f64) -> Vec<(f64, f64, bool)> {
    let [x0, y0, x1, y1] = rect;
    let (a0, a1, t0, t1) = if rows { (x0, x1, y0, y1) } else { (y0, y1, x0, x1) };
    (t0..=t1)
        .filter_map(|t| {
            let t = t as f64;
            let e = outline.crossing(rows, t, near(t))?;
            (e >= a0 as f64 + inset && e <= a1 as f64 - inset).then_some((t, e, true))
        })
        .collect()
}

#[cfg(test)]
mod tests {
    use super::super::image::area_sampled;
    use super::*;

    /// Box-filtered image of a bright disc of radius `r` centred at (cx, cy) on a dark background.
    fn disc_edge(w: usize, h: usize, cx: f64, cy: f64, r: f64) -> ImageF32 {
        area_sampled(w, h, 32, |u, v| if (u - cx).hypot(v - cy) < r { 225.0 } else { 90.0 })
    }

    #[test]
    fn reproduces_a_curved_edge() {
        // A 300-px disc's outline crossing a 41 x 41 window diagonally.
        for th in [0.3f64, 1.2, 2.5, 4.0] {
            let (cx, cy) = (20.3 - 300.0 * th.cos(), 19.8 - 300.0 * th.sin());
            let img = disc_edge(41, 41, cx, cy, 300.0);
            let all = |x: usize, y: usize| img.at(x, y);
            let e = EdgeSurround::fit(&img, [0, 0, 40, 40], &all, &|_, _| false, 40.0).expect("edge");
            let mut worst: f64 = 0.0;
            for y in 5..36 {
                for x in 5..36 {
                    worst = worst.max((e.level_at(x, y) - f64::from(img.at(x, y))).abs());
                }
            }
            // 1 grey level of 135: under 0.01 px of edge position.
            assert!(worst < 1.0, "({cx}, {cy}): worst {worst}");
        }
    }

    #[test]
    fn the_whole_outline_bridges_lines_the_dots_hide() {
        // A 450-px disc (the S-path sphere's size); in the window on its left, dots hide every
        // row but the first twelve (skip): the local cubic extrapolates over 89 rows.
        let img = disc_edge(200, 200, 470.3, 99.6, 450.0);
        let rect = [2, 50, 50, 150];
        let hidden = |x: usize, y: usize| (62..=150).contains(&y) && (12..=35).contains(&x);
        let all = |x: usize, y: usize| img.at(x, y);
        let local = EdgeSurround::fit(&img, rect, &all, &hidden, 40.0).expect("local edge");
        let outline = Outline::fit(&img, 90.0, 225.0, &hidden).expect("outline");
        let bridged = local.along(&outline, rect).expect("same edge");
        let worst = |e: &EdgeSurround| {
            (62..=150).flat_map(|y| (12..=35).map(move |x| (x, y))).map(|(x, y)| (e.level_at(x, y) - f64::from(img.at(x, y))).abs()).fold(0.0, f64::max)
        };
        // The test image's own 32 x 32 sampling is off by up to 135 / 64 = 2.1 grey levels.
        assert!(worst(&bridged) < 2.5, "bridged: {}", worst(&bridged));
        assert!(worst(&local) > 10.0, "the local cubic alone: {}", worst(&local));
        // Every line hidden: the outline alone.
        let alone = EdgeSurround::from_outline(&outline, rect).expect("from the outline");
        assert!(worst(&alone) < 2.5, "alone: {}", worst(&alone));
    }

    #[test]
    fn occluder_coverage_inverts_the_two_level_pixel() {
        // A vertical edge through the middle of pixel (10, 5): bright (225) right of x = 10.
        let e = EdgeSurround { rows: true, bright_up: true, lo: 90.0, hi: 225.0, coef: Vector4::new(10.0, 0.0, 0.0, 0.0), t0: 0.0, samples: Vec::new() };
        assert!((e.bright_fraction(e.level_at(10, 5)) - 0.5).abs() < 1e-12);
        // A dark (20) occluder over the right quarter (bright side) and over the left quarter
        // (dark side): the same coverage from different pixel levels.
        let right = 0.25 * 20.0 + 0.25 * 225.0 + 0.5 * 90.0;
        let left = 0.25 * 20.0 + 0.25 * 90.0 + 0.5 * 225.0;
        assert!((e.occluder_coverage(10, 5, right, 20.0, [1.0, 0.0]) - 0.25).abs() < 1e-9);
        assert!((e.occluder_coverage(10, 5, left, 20.0, [-1.0, 0.0]) - 0.25).abs() < 1e-9);
        // (The plain darkness (S - I) / (S - dark) says 0.37 and 0.13.)
        assert!(e.occluder_coverage(10, 5, 157.5, 20.0, [1.0, 0.0]) == 0.0);
        assert!((e.occluder_coverage(10, 5, 20.0, 20.0, [1.0, 0.0]) - 1.0).abs() < 1e-9);
    }

    #[test]
    fn flat_surround_has_no_edge() {
        let img = ImageF32::new(20, 20, vec![200.0; 400]).unwrap();
        let all = |x: usize, y: usize| img.at(x, y);
        assert!(EdgeSurround::fit(&img, [0, 0, 19, 19], &all, &|_, _| false, 40.0).is_none());
    }
}
