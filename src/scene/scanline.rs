//! Converged box-filter reference for any target by scan-line integration (f64).
//!
//! Pixels that may hold an edge (their probes disagree, or a neighbour's do; S-path pixels that a
//! dot's bounding box reaches) are integrated along `rows` horizontal lines: each line is
//! sampled at `samples` points (ends included) with the exact ray caster
//! ([`super::trace::Tracer`]), and every change of grey between two samples is located by
//! bisection, so each line's integral is exact up to features narrower than the sample spacing
//! (1/32 px by default). The row count doubles from `min_rows` until two counts agree within
//! `tolerance` grey levels (or `max_rows` is reached: the pixel is then counted as unconverged).
//! Other pixels take their centre sample.
//!
//! This is written apart from the GPU renderer's coverage code (`shaders/render.wgsl`): it shares
//! only the geometry's ray caster. It checks what [`super::exact`] cannot: the S-path's sphere,
//! beads and painted caps. It is slow (seconds per 320 x 256 S-path image) and meant for tests.

use nalgebra::Point2;
use rayon::prelude::*;

use super::trace::{dot_bbox_px, Tracer};
use super::{Scene, SceneError};
use crate::target::Target;

/// Parameters of [`render_scanline_reference`].
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct ScanlineParams {
    /// Lines per pixel to start with.
    pub min_rows: u32,
    /// Most lines per pixel.
    pub max_rows: u32,
    /// Samples per line, ends included (at least 2).
    pub samples: u32,
    /// Bisection steps per change of grey along a line.
    pub bisections: u32,
    /// Two row counts agreeing within this many grey levels end the refinement.
    pub tolerance: f64,
}

impl Default for ScanlineParams {
    fn default() -> Self {
        Self { min_rows: 32, max_rows: 256, samples: 33, bisections: 24, tolerance: 0.01 }
    }
}

/// A rendered reference.
#[derive(Debug, Clone, PartialEq)]
pub struct ScanlineImage {
    /// Grey levels, row-major.
    pub values: Vec<f64>,
    /// Which pixels were integrated (the others are flat: one sample).
    pub integrated: Vec<bool>,
    /// Integrated pixels whose last two row counts still differed by more than the tolerance.
    pub unconverged: usize,
}

/// Render `scene` with converged scan-line integration (see the module docs).
///
/// # Errors
/// The scene's validation errors, or [`SceneError::InvalidField`] for parameters out of range.
pub fn render_scanline_reference(scene: &Scene, params: &ScanlineParams) -> Result<ScanlineImage, SceneError> {
    scene.validate()?;
    let p = params;
    if p.samples < 2 || p.min_rows == 0 || p.max_rows < p.min_rows || p.max_rows > 4096 || !(p.tolerance > 0.0) {
        return Err(SceneError::InvalidField { field: "scanline params".into(), reason: format!("{p:?}") });
    }
    let tracer = Tracer::new(scene);
    let (w, h) = (scene.camera.size.width as usize, scene.camera.size.height as usize);
    let candidates = dot_candidates(scene, w, h);
    let mixed = mixed_pixels(&tracer, &candidates, w, h);
    let mut values = vec![0.0; w * h];
    let mut integrated = vec![false; w * h];
    let unconverged: usize = values
        .par_chunks_mut(w)
        .zip(integrated.par_chunks_mut(w))
        .enumerate()
        .map(|(y, (row, flags))| {
            let mut bad = 0;
            for x in 0..w {
                let i = y * w + x;
                let near = (y.saturating_sub(1)..(y + 2).min(h)).any(|yy| (x.saturating_sub(1)..(x + 2).min(w)).any(|xx| mixed[yy * w + xx]));
                let cands = &candidates[i];
                if near || !cands.is_empty() {
                    let (v, ok) = integrate_pixel(&tracer, x as f64, y as f64, cands, p);
                    row[x] = v;
                    flags[x] = true;
                    bad += usize::from(!ok);
                } else {
                    row[x] = tracer.trace_px_among(&Point2::new(x as f64, y as f64), cands).intensity;
                }
            }
            bad
        })
        .sum();
    Ok(ScanlineImage { values, integrated, unconverged })
}

/// Per pixel, the S-path dots whose bounding box (plus 1 px) reaches it (empty for planar targets).
fn dot_candidates(scene: &Scene, w: usize, h: usize) -> Vec<Vec<usize>> {
    let mut out = vec![Vec::new(); w * h];
    if let Target::SPath(s) = &scene.target {
        for (k, c) in s.path.points_m.iter().enumerate() {
            let Some(bb) = dot_bbox_px(scene, c, s.dot_radius(k), 1.0) else { continue };
            let (x0, y0) = (bb[0].floor().max(0.0) as usize, bb[1].floor().max(0.0) as usize);
            let (x1, y1) = ((bb[2].ceil().max(0.0) as usize).min(w.saturating_sub(1)), (bb[3].ceil().max(0.0) as usize).min(h.saturating_sub(1)));
            for y in y0..=y1.min(h.saturating_sub(1)) {
                for x in x0..=x1 {
                    out[y * w + x].push(k);
                }
            }
        }
    }
    out
}

/// Pixels whose 5 x 5 probes (edges included) do not all see the same grey.
fn mixed_pixels(tracer: &Tracer<'_>, candidates: &[Vec<usize>], w: usize, h: usize) -> Vec<bool> {
    let mut out = vec![false; w * h];
    out.par_chunks_mut(w).enumerate().for_each(|(y, row)| {
        for (x, m) in row.iter_mut().enumerate() {
            let cands = &candidates[y * w + x];
            let first = tracer.trace_px_among(&Point2::new(x as f64 - 0.5, y as f64 - 0.5), cands).intensity;
            *m = (1..25).any(|k| {
                let q = Point2::new(x as f64 - 0.5 + f64::from(k % 5) * 0.25, y as f64 - 0.5 + f64::from(k / 5) * 0.25);
                tracer.trace_px_among(&q, cands).intensity != first
            });
        }
    });
    out
}

/// Mean grey of pixel (x, y), refined until converged: (value, converged).
fn integrate_pixel(tracer: &Tracer<'_>, x: f64, y: f64, cands: &[usize], p: &ScanlineParams) -> (f64, bool) {
    let mut rows = p.min_rows;
    let mut last = integrate_rows(tracer, x, y, cands, rows, p);
    while rows < p.max_rows {
        rows *= 2;
        let next = integrate_rows(tracer, x, y, cands, rows, p);
        let done = (next - last).abs() <= p.tolerance;
        last = next;
        if done {
            return (last, true);
        }
    }
    (last, false)
}

/// Mean over `rows` lines of each line's exact integral (see the module docs).
fn integrate_rows(tracer: &Tracer<'_>, x: f64, y: f64, cands: &[usize], rows: u32, p: &ScanlineParams) -> f64 {
    let grey = |u: f64, v: f64| tracer.trace_px_among(&Point2::new(u, v), cands).intensity;
    pixel_moments(&grey, x, y, rows, p.samples, p.bisections)[0]
}

/// Integrals over the pixel square centred at (x, y) (area 1) of a piecewise-constant `f`, of
/// `f u` and of `f v`, by `rows` scan lines: each line is sampled at `samples` points (ends
/// included) and every change of `f` between two samples is located by `bisections` halvings.
/// Exact up to features narrower than the sample spacing and the midpoint rule across lines.
pub fn pixel_moments(f: &dyn Fn(f64, f64) -> f64, x: f64, y: f64, rows: u32, samples: u32, bisections: u32) -> [f64; 3] {
    let samples = samples.max(2);
    let step = 1.0 / f64::from(samples - 1);
    let rows = rows.max(1);
    let mut m = [0.0; 3];
    // A stretch [a, b] of line v with value g.
    let mut add = |g: f64, a: f64, b: f64, v: f64| {
        m[0] += g * (b - a);
        m[1] += g * 0.5 * (b * b - a * a);
        m[2] += g * v * (b - a);
    };
    for r in 0..rows {
        let v = y - 0.5 + (f64::from(r) + 0.5) / f64::from(rows);
        let mut u0 = x - 0.5;
        let mut g0 = f(u0, v);
        for k in 1..samples {
            let u1 = x - 0.5 + f64::from(k) * step;
            let g1 = f(u1, v);
            if g1 == g0 {
                add(g0, u0, u1, v);
            } else {
                // Bisect the change: g0 up to the crossing, g1 after it.
                let (mut a, mut b) = (u0, u1);
                for _ in 0..bisections {
                    let mid = 0.5 * (a + b);
                    if f(mid, v) == g0 {
                        a = mid;
                    } else {
                        b = mid;
                    }
                }
                let c = 0.5 * (a + b);
                add(g0, u0, c, v);
                add(g1, c, u1, v);
            }
            u0 = u1;
            g0 = g1;
        }
    }
    m.map(|v| v / f64::from(rows))
}
