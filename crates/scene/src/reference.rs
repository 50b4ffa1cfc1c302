//! Brute-force CPU reference renderer (f64, exact distortion inversion per sample).
//!
//! Each pixel is the box-filtered mean of an `n x n` grid of exact samples
//! ([`super::trace::Tracer::trace_px`]) at `x - 0.5 + (i + 0.5) / n` (OpenCV pixel convention).
//! [`render_reference_adaptive`] re-samples with a finer grid every pixel whose coarse samples are
//! not all equal: the refinement decision uses only the reference's own samples, never the GPU's
//! logic, so the two renderers stay independent. It exists to check the GPU renderer, not for speed.

use nalgebra::Point2;
use rayon::prelude::*;

use super::trace::Tracer;
use super::Scene;

/// Mean of the `n x n` exact samples of pixel (x, y), and whether they were all equal.
fn pixel_mean(tracer: &Tracer<'_>, x: u32, y: u32, n: u32) -> (f64, bool) {
    let mut sum = 0.0;
    let mut first = None;
    let mut uniform = true;
    let inv = 1.0 / f64::from(n);
    for j in 0..n {
        for i in 0..n {
            let q = Point2::new(f64::from(x) - 0.5 + (f64::from(i) + 0.5) * inv, f64::from(y) - 0.5 + (f64::from(j) + 0.5) * inv);
            let v = tracer.trace_px(&q).intensity;
            match first {
                None => first = Some(v),
                Some(f) if f != v => uniform = false,
                _ => {}
            }
            sum += v;
        }
    }
    (sum * inv * inv, uniform)
}

/// Render `scene` on the CPU with `n x n` samples per pixel; grey levels, row-major.
pub fn render_reference(scene: &Scene, n: u32) -> Vec<f64> {
    render_reference_adaptive(scene, n, n)
}

/// Render with `n x n` samples per pixel, and `fine x fine` where those samples differ.
pub fn render_reference_adaptive(scene: &Scene, n: u32, fine: u32) -> Vec<f64> {
    let tracer = Tracer::new(scene);
    let (w, h) = (scene.camera.size.width, scene.camera.size.height);
    let mut out = vec![0.0; (w as usize) * (h as usize)];
    out.par_chunks_mut(w as usize).enumerate().for_each(|(y, row)| {
        for (x, px) in row.iter_mut().enumerate() {
            let (v, uniform) = pixel_mean(&tracer, x as u32, y as u32, n.max(1));
            *px = if uniform || fine <= n { v } else { pixel_mean(&tracer, x as u32, y as u32, fine).0 };
        }
    });
    out
}
