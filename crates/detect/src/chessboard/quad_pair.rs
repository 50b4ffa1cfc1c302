//! The over-exposure fallback of structure recovery (module `complete`): OpenCV's classic corner
//! from two dark quads meeting at the prediction, where the light squares bloom over the
//! junction and no saddle is left to fit.
//!
//! Reference: V. Vezhnevets, OpenCV `findChessboardCorners` (quads from an adaptive threshold,
//! corners where the quads of neighbouring dark squares meet).

use nalgebra::{Point2, Vector2};

use super::super::markers::quads::{candidates, Quad};
use super::super::markers::MarkerParams;
use super::super::ImageF32;
use super::CompleteParams;

/// The dark squares of the image as quads (the marker detector's candidate search, 4-connected
/// and eroded so that squares touching at a corner come apart), with adaptive-threshold windows
/// from the grid's step range: twice the longest step (the mean of a window holding light and
/// dark squares), and a window of the shortest step for the compressed squares.
pub(super) fn dark_quads(img: &ImageF32, (short, long): (f64, f64)) -> Vec<Quad> {
    let odd = |x: f64| ((x.clamp(5.0, 401.0) as usize) / 2) * 2 + 1;
    let params = MarkerParams {
        threshold_windows_px: [odd(2.0 * long), odd(short), 0],
        min_marker_perimeter_px: (2.0 * short).max(12.0),
        polygon_accuracy_rate: QUAD_ACCURACY_RATE,
        ..MarkerParams::default()
    };
    candidates(img, 1.0, &params, true)
}

/// Largest distance of a dark square's outline from its quadrilateral, as a fraction of the
/// perimeter: a square under strong distortion has bowed sides (the marker search's 0.03 is for
/// markers, small and nearly straight-sided); the pairing below checks the geometry that matters.
const QUAD_ACCURACY_RATE: f64 = 0.08;

/// OpenCV's classic corner (Vezhnevets; `findChessboardCorners`): two dark quads on the dark
/// diagonal `dark` whose nearest corners lie within the search radius of the prediction `pred`;
/// the corner is the midpoint of those two quad corners. This holds where the light squares
/// bloom over the junction and the dark squares no longer touch (over-exposure), where no
/// saddle is left to fit. The quads must be about the size of a grid cell (`si x sj`) and of
/// the board's dark paint ([`alike`]).
pub(super) fn quad_pair_corner(
    img: &ImageF32,
    quads: &[Quad],
    pred: Point2<f64>,
    step: f64,
    dark: Vector2<f64>,
    (si, sj): (Vector2<f64>, Vector2<f64>),
    p: &CompleteParams,
) -> Option<Point2<f64>> {
    let radius = p.max_shift_frac * step;
    let cell = (si.x * sj.y - si.y * sj.x).abs();
    let light = dark.norm() * Vector2::new(-dark.y, dark.x).normalize();
    // the grid's other diagonal: the light squares' centres lie half of it from the junction
    let light_diagonal = if (dark - (si - sj)).norm_squared() < 1e-12 * dark.norm_squared() { si + sj } else { si - sj };
    let near: Vec<(Point2<f64>, Point2<f64>)> = quads
        .iter()
        .filter(|q| {
            let a = super::super::markers::quads::signed_area(q).abs();
            a >= 0.1 * cell && a <= 4.0 * cell
        })
        .flat_map(|q| {
            let centre = Point2::from((q[0].coords + q[1].coords + q[2].coords + q[3].coords) * 0.25);
            q.iter().filter(move |c| (*c - pred).norm() <= radius).map(move |c| (*c, centre))
        })
        .collect();
    log::trace!("quads: {} in the image, {} corners near ({:.1}, {:.1}): {near:?}", quads.len(), near.len(), pred.x, pred.y);
    let mut best: Option<(f64, Point2<f64>)> = None;
    for (k, &(a, ca)) in near.iter().enumerate() {
        for &(b, cb) in &near[k + 1..] {
            let m = Point2::from((a.coords + b.coords) * 0.5);
            let (da, db) = (ca - m, cb - m);
            // on opposite sides of the junction, both nearer the dark diagonal than the light one
            let on_dark = |d: Vector2<f64>| d.dot(&dark).abs() > d.dot(&light).abs();
            if (ca - cb).norm() < 1e-9
                || da.dot(&db) >= 0.0
                || !on_dark(da)
                || !on_dark(db)
                || (a - b).norm() > 0.5 * step
                || !alike(img, (ca, cb), m, light_diagonal)
            {
                continue;
            }
            let cost = (a - b).norm() + (m - pred).norm();
            if best.is_none_or(|bst| cost < bst.0) {
                best = Some((cost, m));
            }
        }
    }
    best.map(|b| b.1)
}

/// The two dark quads' centres differ in grey by at most this fraction of their contrast to the
/// light squares beside the junction ([`alike`]).
const MAX_DARK_MISMATCH: f64 = 0.5;

/// Whether the quads centred at `ca`, `cb` are two of the board's dark squares at the junction
/// `m`: both darker than the light squares' centres `m +- light / 2` (`light` the grid's light
/// diagonal), and alike (the same paint, [`MAX_DARK_MISMATCH`]). At a board's edge the grey
/// background beyond the white margin also forms a dark quad beside an edge square's outer
/// corner; it is far lighter than the paint.
fn alike(img: &ImageF32, (ca, cb): (Point2<f64>, Point2<f64>), m: Point2<f64>, light: Vector2<f64>) -> bool {
    let grey = |q: Point2<f64>| box_mean(img, q);
    let (Some(a), Some(b), Some(l1), Some(l2)) = (grey(ca), grey(cb), grey(m + light * 0.5), grey(m - light * 0.5)) else { return false };
    let contrast = l1.min(l2) - a.max(b);
    contrast > 0.0 && (a - b).abs() <= MAX_DARK_MISMATCH * contrast
}

/// Mean grey of the 3 x 3 pixels around `q`; `None` where they leave the image.
fn box_mean(img: &ImageF32, q: Point2<f64>) -> Option<f64> {
    let (x, y) = (q.x.round(), q.y.round());
    if !(x >= 1.0 && y >= 1.0 && x + 1.0 < img.width as f64 && y + 1.0 < img.height as f64) {
        return None;
    }
    let (x, y) = (x as usize, y as usize);
    Some((y - 1..=y + 1).flat_map(|yy| (x - 1..=x + 1).map(move |xx| f64::from(img.data[yy * img.width + xx]))).sum::<f64>() / 9.0)
}

#[cfg(test)]
mod tests {
    use super::*;

    /// 40 x 40 pixels: grey `tl` in the top-left quadrant, `br` in the bottom-right, 230 elsewhere
    /// (the junction at (20, 20), the dark diagonal from top-left to bottom-right).
    fn quadrants(tl: f32, br: f32) -> ImageF32 {
        let data = (0..1600)
            .map(|k| (k % 40, k / 40))
            .map(|(x, y)| {
                if x < 20 && y < 20 {
                    tl
                } else if x >= 20 && y >= 20 {
                    br
                } else {
                    230.0
                }
            })
            .collect();
        ImageF32 { width: 40, height: 40, data }
    }

    #[test]
    fn two_squares_of_paint_are_alike_and_paint_beside_background_is_not() {
        let (m, light) = (Point2::new(19.5, 19.5), Vector2::new(20.0, -20.0));
        let (ca, cb) = (Point2::new(10.0, 10.0), Point2::new(29.0, 29.0));
        assert!(alike(&quadrants(35.0, 45.0), (ca, cb), m, light), "two dark squares");
        assert!(!alike(&quadrants(35.0, 160.0), (ca, cb), m, light), "a square and the grey background");
        assert!(!alike(&quadrants(35.0, 230.0), (ca, cb), m, light), "an L-junction");
    }
}
