//! X-junction test: the four squares around a chessboard corner alternate in brightness, which
//! rejects L- and T-junctions at the board border and clutter corners.
//!
//! Reference: A. Geiger et al., "Automatic camera and range sensor calibration using a single
//! shot", ICRA 2012 (corner-prototype test); OpenCV `findChessboardCorners` (quad colour checks).

use nalgebra::{Point2, Vector2};

use super::ImageF32;

/// Bilinear sample with clamped coordinates; `None` outside the image.
pub fn bilinear(img: &ImageF32, p: Point2<f64>) -> Option<f32> {
    let (w, h) = (img.width, img.height);
    if !(p.x >= 0.0 && p.y >= 0.0 && p.x <= (w as f64 - 1.0) && p.y <= (h as f64 - 1.0)) {
        return None;
    }
    // p is inside the image: the casts truncate as floor does (without its libm call)
    let x0 = (p.x as usize).min(w.saturating_sub(2));
    let y0 = (p.y as usize).min(h.saturating_sub(2));
    if w < 2 || h < 2 {
        return Some(img.data[0]);
    }
    let fx = (p.x - x0 as f64) as f32;
    let fy = (p.y - y0 as f64) as f32;
    let i = y0 * w + x0;
    let d = &img.data;
    let top = d[i] + (d[i + 1] - d[i]) * fx;
    let bot = d[i + w] + (d[i + w + 1] - d[i + w]) * fx;
    Some(top + (bot - top) * fy)
}

/// Polarity of an X-junction at `p` whose grid steps are `u` and `v`: +1 when the squares along
/// +-(u + v) are the light ones, -1 when they are the dark ones, `None` when the four squares do
/// not alternate clearly (contrast between the pairs at least `min_contrast` and at least half
/// the spread inside the pairs).
///
/// Tested at two distances along the square diagonals (0.3 of the step, and 0.15 of the step but
/// at least 2.5 px): the near one rejects L-junctions at a thin board margin whose far samples
/// fall on a dark frame beyond it.
pub fn xcorner_polarity(img: &ImageF32, p: Point2<f64>, u: Vector2<f64>, v: Vector2<f64>, min_contrast: f32) -> Option<i8> {
    let m = u.norm().min(v.norm());
    if !(m > 0.0) {
        return None;
    }
    let s_near = (2.5 / m).clamp(0.15, 0.3);
    let a = polarity_at(img, p, u, v, min_contrast, 0.3)?;
    let b = polarity_at(img, p, u, v, min_contrast, s_near)?;
    (a == b).then_some(a)
}

fn polarity_at(img: &ImageF32, p: Point2<f64>, u: Vector2<f64>, v: Vector2<f64>, min_contrast: f32, s: f64) -> Option<i8> {
    let a1 = bilinear(img, p + (u + v) * s)?;
    let a2 = bilinear(img, p - (u + v) * s)?;
    let b1 = bilinear(img, p + (u - v) * s)?;
    let b2 = bilinear(img, p - (u - v) * s)?;
    let (amin, amax) = (a1.min(a2), a1.max(a2));
    let (bmin, bmax) = (b1.min(b2), b1.max(b2));
    let spread = (amax - amin).max(bmax - bmin);
    if amin - bmax > min_contrast && amin - bmax > 0.5 * spread {
        Some(1)
    } else if bmin - amax > min_contrast && bmin - amax > 0.5 * spread {
        Some(-1)
    } else {
        None
    }
}
