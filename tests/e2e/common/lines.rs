//! Straight edges in rendered images against a line of camera rays: per row, the step's crossing
//! of the middle grey (the box filter of a straight step is linear across it) against the row's
//! root of the line's side function on the lens's exact inverse. Backgrounds and shadows use it.

use nalgebra::{Point2, Vector3};
use synthcam::camera::CameraModel;

/// Where the rendered step between `dark` and `light` crosses the middle grey in `row[lo..hi]`:
/// the least-squares line through the pixels strictly inside the ramp (a box filter of a
/// straight step over a footprint is linear in x there), when they are one run of 2 to 12.
fn crossing(row: &[f32], [dark, light]: [f32; 2], lo: usize, hi: usize) -> Option<f64> {
    let mid = 0.5 * f64::from(dark + light);
    let ramp: Vec<(f64, f64)> = (lo..hi).filter(|x| row[*x] > dark + 0.5 && row[*x] < light - 0.5).map(|x| (x as f64, f64::from(row[x]))).collect();
    let contiguous = ramp.windows(2).all(|p| p[1].0 - p[0].0 == 1.0);
    if ramp.len() < 2 || ramp.len() > 12 || !contiguous {
        return None;
    }
    let n = ramp.len() as f64;
    let (mx, mv) = (ramp.iter().map(|p| p.0).sum::<f64>() / n, ramp.iter().map(|p| p.1).sum::<f64>() / n);
    let sxv: f64 = ramp.iter().map(|p| (p.0 - mx) * (p.1 - mv)).sum();
    let sxx: f64 = ramp.iter().map(|p| (p.0 - mx).powi(2)).sum();
    let x = mx + (mid - mv) * sxx / sxv;
    (x >= lo as f64 && x <= hi as f64).then_some(x)
}

/// The root in `[a, b]` of `f` (a sign change), by bisection to 1e-9 px.
fn bisect(f: impl Fn(f64) -> f64, mut a: f64, mut b: f64) -> Option<f64> {
    let fa = f(a);
    if !(fa * f(b) <= 0.0) {
        return None;
    }
    for _ in 0..60 {
        let m = 0.5 * (a + b);
        if (f(m) > 0.0) == (fa > 0.0) {
            a = m;
        } else {
            b = m;
        }
    }
    Some(0.5 * (a + b))
}

/// Distances (px, across the line) between the rendered crossings and the line `side(d) = 0` of
/// camera rays: per row, every root of the side function along it (scanned every 4 px, then
/// bisected on the lens's exact inverse) against the step's crossing within 8 px of it, where
/// the line is steeper than 45 degrees.
pub fn line_errors(cam: &CameraModel, img: &[f32], levels: [f32; 2], side: impl Fn(&Vector3<f64>) -> f64) -> Vec<f64> {
    line_errors_by(cam, img, levels, side, crossing)
}

/// A step's crossing estimator: the row, the two levels, the window `[lo, hi]`.
type Estimator = fn(&[f32], [f32; 2], usize, usize) -> Option<f64>;

/// [`line_errors`] with the crossings found by `estimate`.
pub fn line_errors_by(cam: &CameraModel, img: &[f32], levels: [f32; 2], side: impl Fn(&Vector3<f64>) -> f64, estimate: Estimator) -> Vec<f64> {
    let f = |x: f64, y: f64| cam.unproject_ray(&Point2::new(x, y)).map_or(f64::NAN, |d| side(&d.normalize()));
    let w = cam.size.width as usize;
    let mut errs = Vec::new();
    for (row, pixels) in img.chunks(w).enumerate() {
        let y = row as f64;
        let roots = (2..w - 6).step_by(4).filter_map(|x| bisect(|u| f(u, y), x as f64, x as f64 + 4.0));
        for x in roots {
            let (lo, hi) = ((x - 8.0).max(1.0) as usize, ((x + 8.0) as usize).min(w - 1));
            let Some(x_seen) = estimate(pixels, levels, lo, hi) else { continue };
            let (Some(x_up), Some(x_down)) = (bisect(|u| f(u, y - 1.0), x - 4.0, x + 4.0), bisect(|u| f(u, y + 1.0), x - 4.0, x + 4.0)) else { continue };
            let slope = 0.5 * (x_down - x_up);
            if slope.abs() < 1.0 {
                errs.push((x_seen - x).abs() / slope.hypot(1.0));
            }
        }
    }
    errs
}

/// Root mean square.
pub fn rms(v: &[f64]) -> f64 {
    (v.iter().map(|e| e * e).sum::<f64>() / v.len() as f64).sqrt()
}

/// The crossing of a straight step under the exact pixel box filter (square pixels) in
/// `row[lo..=hi]`, both ends on the step's two levels and nothing else in between: the light
/// side's coverage summed along the row is the distance from the window's end to the edge at the
/// row's centre (exact for any angle of a straight edge).
pub fn box_crossing(row: &[f32], [dark, light]: [f32; 2], lo: usize, hi: usize) -> Option<f64> {
    let at = |v: f32, level: f32| (v - level).abs() <= 0.5;
    let (a, b) = (row[lo], row[hi]);
    if !row[lo..=hi].iter().all(|v| *v >= dark - 0.5 && *v <= light + 0.5) || !((at(a, dark) && at(b, light)) || (at(a, light) && at(b, dark))) {
        return None;
    }
    let lit: f64 = row[lo..=hi].iter().map(|v| f64::from((v - dark) / (light - dark)).clamp(0.0, 1.0)).sum();
    Some(if at(b, light) { hi as f64 + 0.5 - lit } else { lo as f64 - 0.5 + lit })
}
