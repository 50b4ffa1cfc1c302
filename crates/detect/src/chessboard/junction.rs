//! Whether a saddle fit shows a chessboard's X-junction where structure recovery looks for a
//! corner (module `complete`): the fitted amplitude and residual, the lines along the grid's two
//! directions, the polarity the checkerboard parity demands, and four sectors that alternate
//! light and dark.
//!
//! Reference: A. Geiger, F. Moosmann, O. Car, B. Schuster, "Automatic camera and range sensor
//! calibration using a single shot", ICRA 2012 (the corner likelihood from four quadrant means:
//! both light sectors above both dark ones, which an L-junction cannot satisfy).

use nalgebra::Vector2;

use super::super::saddle_fit::SaddleFit;
use super::super::ImageF32;
use super::CompleteParams;

/// The fit shows an X-junction along the grid directions `si`, `sj` with polarity `expect` (+1:
/// the squares along +-(si + sj) are light).
pub(super) fn fit_is_corner(fit: &SaddleFit, si: Vector2<f64>, sj: Vector2<f64>, expect: i8, p: &CompleteParams) -> bool {
    let a = fit.amplitude;
    if !(a.abs() >= p.min_amplitude && fit.rms_residual <= p.max_residual_frac * a.abs()) {
        return false;
    }
    let line_dir = |t: f64| Vector2::new(t.cos(), t.sin());
    let (l1, l2) = (line_dir(fit.angles[0]), line_dir(fit.angles[1]));
    let cos_max = p.max_angle_deg.to_radians().cos();
    let along = |l: Vector2<f64>, s: Vector2<f64>| (l.dot(&s) / s.norm()).abs() >= cos_max;
    if !((along(l1, si) && along(l2, sj)) || (along(l1, sj) && along(l2, si))) {
        return false;
    }
    // the model is m + a S(d1) S(d2) with d_k the signed distance to line k (normal (-sin, cos));
    // its sign along the diagonal si + sj says whether that square is light
    let d = si + sj;
    let side = |l: Vector2<f64>| (-l.y * d.x + l.x * d.y).signum();
    let light = a * side(l1) * side(l2) > 0.0;
    light == (expect > 0)
}

/// Geiger et al.'s corner test on the fitted junction: the mean grey of each of the four sectors
/// the fitted lines cut from the fit window (pixels within 1 px of a line left out), and the
/// darker light sector's mean minus the lighter dark sector's, over the fitted contrast
/// `2 |amplitude|`: about 1 at an X-junction, at most 0 at an L-junction (one dark square's
/// corner against three light quadrants, as at a board's outer corners). `None` when a sector
/// holds no pixel (a window the image border cuts to a few pixels): no evidence either way.
pub(super) fn quadrant_contrast(full: &ImageF32, fit: &SaddleFit, hw: usize) -> Option<f64> {
    let normal = |t: f64| Vector2::new(-t.sin(), t.cos());
    let (n1, n2) = (normal(fit.angles[0]), normal(fit.angles[1]));
    let (px, py) = (fit.point.x.round() as i64, fit.point.y.round() as i64);
    let hw = hw as i64;
    let (mut sum, mut count) = ([0.0f64; 4], [0usize; 4]);
    for y in (py - hw).max(0)..=(py + hw).min(full.height as i64 - 1) {
        for x in (px - hw).max(0)..=(px + hw).min(full.width as i64 - 1) {
            let d = Vector2::new(x as f64, y as f64) - fit.point.coords;
            let (d1, d2) = (n1.dot(&d), n2.dot(&d));
            if d1.abs() < 1.0 || d2.abs() < 1.0 {
                continue;
            }
            let k = usize::from(d1 > 0.0) * 2 + usize::from(d2 > 0.0);
            sum[k] += f64::from(full.data[y as usize * full.width + x as usize]);
            count[k] += 1;
        }
    }
    if count.contains(&0) {
        return None;
    }
    let mean: Vec<f64> = (0..4).map(|k| sum[k] / count[k] as f64).collect();
    // the model m + a S(d1) S(d2): sectors with d1 d2 > 0 (k = 0, 3) are light where a > 0
    let (same, other) = (mean[0].min(mean[3]) - mean[1].max(mean[2]), mean[1].min(mean[2]) - mean[0].max(mean[3]));
    let contrast = if fit.amplitude > 0.0 { same } else { other };
    Some(contrast / (2.0 * fit.amplitude.abs()).max(1e-9))
}

#[cfg(test)]
mod tests {
    use nalgebra::Point2;

    use super::*;

    /// A junction rendered by 16 x 16 supersampling: grey 200 where `light(x, y)`, 40 elsewhere.
    fn junction(light: impl Fn(f64, f64) -> bool) -> ImageF32 {
        let (w, h) = (21usize, 21usize);
        let data = (0..w * h)
            .map(|k| {
                let (x, y) = ((k % w) as f64, (k / w) as f64);
                let n =
                    (0..256).filter(|s| light(x - 0.5 + (f64::from(s % 16) + 0.5) / 16.0 - 10.0, y - 0.5 + (f64::from(s / 16) + 0.5) / 16.0 - 10.0)).count();
                (40.0 + 160.0 * n as f64 / 256.0) as f32
            })
            .collect();
        ImageF32 { width: w, height: h, data }
    }

    /// The fit of a junction at the window's centre with lines along x and y, amplitude 80.
    fn fit_at_centre(amplitude: f64) -> SaddleFit {
        SaddleFit {
            point: Point2::new(10.0, 10.0),
            angles: [0.0, std::f64::consts::FRAC_PI_2],
            amplitude,
            sigma_px: 0.5,
            rms_residual: 1.0,
            position_sigma_px: 0.01,
            iterations: 3,
        }
    }

    #[test]
    fn an_x_junction_has_full_contrast_and_an_l_junction_none() {
        // X: light where x y > 0. The model m + a S(d1) S(d2) with d1 = y, d2 = -x (normals of
        // lines along x and y) is light where -x y > 0 for a > 0: the fitted amplitude is -80.
        let x = junction(|x, y| x * y > 0.0);
        let c = quadrant_contrast(&x, &fit_at_centre(-80.0), 4).expect("four sectors");
        assert!((c - 1.0).abs() < 1e-3, "X-junction: {c}");
        // the wrong polarity is the negative of it
        let wrong = quadrant_contrast(&x, &fit_at_centre(80.0), 4).expect("four sectors");
        assert!((wrong + 1.0).abs() < 1e-3, "X-junction, other polarity: {wrong}");
        // L: one dark quadrant (a board's outer corner against its white margin)
        let l = junction(|x, y| !(x < 0.0 && y < 0.0));
        for a in [-80.0, 80.0] {
            let c = quadrant_contrast(&l, &fit_at_centre(a), 4).expect("four sectors");
            assert!(c <= 1e-6, "L-junction, amplitude {a}: {c}");
        }
    }

    #[test]
    fn a_window_cut_to_a_line_gives_no_verdict() {
        let x = junction(|x, y| x * y > 0.0);
        assert_eq!(quadrant_contrast(&x, &fit_at_centre(-80.0), 0), None);
    }
}
