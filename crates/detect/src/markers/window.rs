//! The fit window of a target corner ([`refine_junction`](super::corners::refine_junction)):
//! how far it may reach around the corner in the locally uniform area ([`Area`]), and, for
//! ChArUco's inset markers, the window's pixels that reach into a marker set to the light level
//! (see the module docs of `markers::corners`).

use nalgebra::{Matrix2, Point2, Vector2};

use super::Samples;
use crate::GreyWindow;

/// The uniform area around a junction (target plane, relative to the corner), where the fit
/// window must stay.
#[derive(Debug, Clone, Copy, PartialEq)]
pub(crate) enum Area {
    /// The square of half-size `margin_m`.
    Square,
    /// The four squares of side `square_m` around the corner less, in the two light quadrants
    /// (signs `light` and `-light` of the target axes), the area beyond `margin_m` along both
    /// axes (a ChArUco marker inset by the white margin).
    Inset {
        /// Signs of one light quadrant along the target's x and y (the other is opposite).
        light: [f64; 2],
        /// Side of the squares, metres.
        square_m: f64,
    },
}

/// Bisection steps of [`reach_px`] (relative precision 2^-30).
const REACH_STEPS: usize = 30;

/// Half-size `h_max`, pixels, of the largest axis-aligned image square centred on the corner
/// whose target footprint (`inv`: image offset to target offset, the inverse Jacobian) stays in
/// `area`; 0 when `inv` is not finite.
pub(super) fn reach_px(inv: &Matrix2<f64>, margin_m: f64, area: Area) -> f64 {
    if !inv.iter().all(|v| v.is_finite()) {
        return 0.0;
    }
    // the square meets the half-plane row . w >= a first at a / |row|_1
    let half_planes = |a: f64| (0..2).map(|r| a / (inv[(r, 0)].abs() + inv[(r, 1)].abs())).fold(f64::INFINITY, f64::min);
    match area {
        Area::Square => half_planes(margin_m),
        Area::Inset { light, square_m } => {
            let outer = half_planes(square_m);
            [1.0, -1.0].into_iter().fold(outer, |r, s| {
                let g1 = Vector2::new(inv[(0, 0)], inv[(0, 1)]) * (s * light[0]);
                let g2 = Vector2::new(inv[(1, 0)], inv[(1, 1)]) * (s * light[1]);
                r.min(quarter_plane_reach(g1, g2, margin_m, r))
            })
        }
    }
}

/// Smallest half-size `r <= limit` at which the square `[-r, r]^2` meets the quarter-plane
/// `g1 . w >= a, g2 . w >= a` (`a > 0`; `limit` when it does not meet it at `limit`).
fn quarter_plane_reach(g1: Vector2<f64>, g2: Vector2<f64>, a: f64, limit: f64) -> f64 {
    if !(limit.is_finite() && limit > 0.0) {
        return limit.max(0.0);
    }
    if !square_meets(limit, g1, g2, a) {
        return limit;
    }
    let (mut lo, mut hi) = (0.0, limit);
    for _ in 0..REACH_STEPS {
        let mid = 0.5 * (lo + hi);
        if square_meets(mid, g1, g2, a) {
            hi = mid;
        } else {
            lo = mid;
        }
    }
    lo
}

/// Whether the square `[-r, r]^2` holds a point with `g1 . w >= a` and `g2 . w >= a`.
fn square_meets(r: f64, g1: Vector2<f64>, g2: Vector2<f64>, a: f64) -> bool {
    box_meets(Vector2::zeros(), r, g1, g2, a)
}

/// Whether the square of half-size `r` around `c` holds a point with `g1 . w >= a` and
/// `g2 . w >= a`: the maximum of the concave `min(g1 . w - a, g2 . w - a)` over the square lies at
/// a vertex or where the ridge `g1 . w = g2 . w` crosses a side.
fn box_meets(c: Vector2<f64>, r: f64, g1: Vector2<f64>, g2: Vector2<f64>, a: f64) -> bool {
    let f = |w: Vector2<f64>| g1.dot(&w).min(g2.dot(&w));
    let vertices = [c + Vector2::new(r, r), c + Vector2::new(-r, r), c + Vector2::new(-r, -r), c + Vector2::new(r, -r)];
    let d = g1 - g2;
    let ridge = (0..4).filter_map(|k| {
        let (p, q) = (vertices[k], vertices[(k + 1) % 4]);
        let (dp, dq) = (d.dot(&p), d.dot(&q));
        (dp * dq <= 0.0 && dp != dq).then(|| p + (q - p) * (dp / (dp - dq)))
    });
    vertices.into_iter().chain(ridge).any(|w| f(w) >= a)
}

/// The fit window's pixels (half-size `hw` around the rounded `p`) whose footprint reaches into
/// an inset marker of `Area::Inset { light, .. }` (`inv`: image offset from `p` to target
/// offset), each with the light level (median of the pixels within one pixel of the window that
/// lie wholly in a light quadrant and outside the markers), which is what a saddle shows there.
/// `None` when a pixel reaching into a marker also crosses its quadrant's edge (a margin under
/// a pixel: no level to put there) or no light pixel is found; empty when the window stays
/// outside the markers.
pub(super) fn marker_patch<I: Samples + ?Sized>(
    img: &I,
    p: Point2<f64>,
    hw: usize,
    inv: &Matrix2<f64>,
    margin_m: f64,
    light: [f64; 2],
) -> Option<Vec<(usize, usize, f64)>> {
    let rows = [Vector2::new(inv[(0, 0)], inv[(0, 1)]), Vector2::new(inv[(1, 0)], inv[(1, 1)])];
    // the two light quadrants (signs along the target axes) as pairs of gradients
    let quadrants = [1.0, -1.0].map(|s| (rows[0] * (s * light[0]), rows[1] * (s * light[1])));
    let (cx, cy) = (p.x.round() as i64, p.y.round() as i64);
    let reach = hw as i64 + 1;
    let (mut patch, mut levels) = (Vec::new(), Vec::new());
    for y in cy - reach..=cy + reach {
        for x in cx - reach..=cx + reach {
            let Some(v) = (x >= 0 && y >= 0 && (x as usize) < img.width() && (y as usize) < img.height()).then(|| img.sample(x as usize, y as usize)) else {
                continue;
            };
            let c = Vector2::new(x as f64 - p.x, y as f64 - p.y);
            let in_window = (x - cx).abs() < reach && (y - cy).abs() < reach;
            for (g1, g2) in quadrants {
                // wholly inside the quadrant: both target coordinates positive over the pixel
                let inside = g1.dot(&c) - 0.5 * g1.abs().sum() >= 0.0 && g2.dot(&c) - 0.5 * g2.abs().sum() >= 0.0;
                let marker = box_meets(c, 0.5, g1, g2, margin_m);
                match (marker, inside) {
                    (true, false) if in_window => return None,
                    (true, true) if in_window => patch.push((x as usize, y as usize)),
                    (false, true) if v.is_finite() => levels.push(f64::from(v)),
                    _ => {}
                }
            }
        }
    }
    if patch.is_empty() {
        return Some(Vec::new());
    }
    levels.sort_by(f64::total_cmp);
    let level = *levels.get(levels.len() / 2)?;
    Some(patch.into_iter().map(|(x, y)| (x, y, level)).collect())
}

/// An image whose samples at a few pixels are replaced (the fit window of [`refine_junction`](super::corners::refine_junction)
/// with the inset markers' pixels set to the light level).
pub(super) struct Patched<'a, I: ?Sized> {
    /// The image.
    pub img: &'a I,
    /// `(x, y, value)` of each replaced pixel.
    pub patch: Vec<(usize, usize, f64)>,
}

impl<I: Samples + ?Sized> GreyWindow for Patched<'_, I> {
    fn width(&self) -> usize {
        self.img.width()
    }
    fn height(&self) -> usize {
        self.img.height()
    }
    fn push_row(&self, y: usize, x0: usize, n: usize, out: &mut Vec<f64>) {
        let start = out.len();
        self.img.push_row(y, x0, n, out);
        for &(px, py, v) in &self.patch {
            if py == y && px >= x0 && px < x0 + n {
                out[start + px - x0] = v;
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Image offsets to target offsets of a board seen at `px_per_m` pixels per metre, rolled by
    /// `roll` and foreshortened by `squash` along the target's y.
    fn inverse_jacobian(px_per_m: f64, roll: f64, squash: f64) -> Matrix2<f64> {
        let (s, c) = roll.sin_cos();
        let jac = Matrix2::new(c, -s, s, c) * Matrix2::new(px_per_m, 0.0, 0.0, px_per_m * squash);
        jac.try_inverse().unwrap_or_else(Matrix2::zeros)
    }

    #[test]
    fn reach_of_the_square_and_of_the_inset_markers() {
        let m = 0.004;
        // a square margin of 4 mm at 1000 px/m: 4 px head-on, 4 / sqrt(2) rolled by 45 degrees
        let head_on = inverse_jacobian(1000.0, 0.0, 1.0);
        assert!((reach_px(&head_on, m, Area::Square) - 4.0).abs() < 1e-9);
        let rolled = inverse_jacobian(1000.0, std::f64::consts::FRAC_PI_4, 1.0);
        assert!((reach_px(&rolled, m, Area::Square) - 4.0 / 2f64.sqrt()).abs() < 1e-9);
        // inset markers in the light quadrants (+, +) and (-, -): head-on, the window's corner
        // (r, r) meets the marker's corner (4, 4); rolled by 45 degrees the marker corner lies on
        // an image axis, 4 sqrt(2) px away; the dark quadrants do not limit it (squares of 30 mm)
        let inset = Area::Inset { light: [1.0, 1.0], square_m: 0.03 };
        assert!((reach_px(&head_on, m, inset) - 4.0).abs() < 1e-6);
        assert!((reach_px(&rolled, m, inset) - 4.0 * 2f64.sqrt()).abs() < 1e-6);
        // the other pair of light quadrants: rolled by 45 degrees, their marker corners (4, -4)
        // and (-4, 4) lie on the other image axis, as far
        let other = Area::Inset { light: [-1.0, 1.0], square_m: 0.03 };
        assert!((reach_px(&rolled, m, other) - 4.0 * 2f64.sqrt()).abs() < 1e-6);
        // foreshortened to half along y: the square margin shrinks to 2 px, the inset markers
        // still stop the window at the marker corner (4, 2): r = 2 meets the quarter-plane
        // x >= 4, y >= 2 only at x = 4
        let squashed = inverse_jacobian(1000.0, 0.0, 0.5);
        assert!((reach_px(&squashed, m, Area::Square) - 2.0).abs() < 1e-9);
        assert!((reach_px(&squashed, m, inset) - 4.0).abs() < 1e-6);
        // the squares' extent bounds it: 2 mm squares at 1000 px/m
        assert!((reach_px(&head_on, m, Area::Inset { light: [1.0, 1.0], square_m: 0.002 }) - 2.0).abs() < 1e-9);
        // degenerate Jacobians reach nothing
        assert_eq!(reach_px(&Matrix2::new(f64::NAN, 0.0, 0.0, 1.0), m, inset), 0.0);
    }

    #[test]
    fn squares_meet_quarter_planes_through_their_sides() {
        let (g1, g2) = (Vector2::new(1.0, 0.0), Vector2::new(0.0, 1.0));
        // x >= 1, y >= 1: the square [-1, 1]^2 touches it at its corner, [-0.9, 0.9]^2 does not
        assert!(square_meets(1.0, g1, g2, 1.0));
        assert!(!square_meets(0.9, g1, g2, 1.0));
        // rotated by 45 degrees, the quarter-plane's apex lies on the x axis at sqrt(2): only the
        // ridge point on the square's right side reaches it
        let (g1, g2) = (Vector2::new(1.0, 1.0) / 2f64.sqrt(), Vector2::new(1.0, -1.0) / 2f64.sqrt());
        assert!(square_meets(1.0001 * 2f64.sqrt(), g1, g2, 1.0));
        assert!(!square_meets(0.9999 * 2f64.sqrt(), g1, g2, 1.0));
        // a square off the origin
        assert!(box_meets(Vector2::new(3.0, 0.0), 0.5, g1, g2, 1.0));
        assert!(!box_meets(Vector2::new(-3.0, 0.0), 0.5, g1, g2, 1.0));
    }
}
