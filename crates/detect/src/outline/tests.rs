//! Tests of `outline`.

use super::super::image::area_sampled;
use super::*;

/// Box-filtered image of a bright ellipse (levels 90 / 225) with centre, semi-axes and angle.
fn ellipse(w: usize, h: usize, c: [f64; 2], ab: [f64; 2], angle: f64) -> ImageF32 {
    let (s, co) = angle.sin_cos();
    area_sampled(w, h, 16, |x, y| {
        let (dx, dy) = (x - c[0], y - c[1]);
        let (u, v) = (co * dx + s * dy, -s * dx + co * dy);
        if (u / ab[0]).powi(2) + (v / ab[1]).powi(2) <= 1.0 {
            225.0
        } else {
            90.0
        }
    })
}

#[test]
fn recovers_an_ellipse_and_bridges_a_hidden_stretch() {
    let (c, ab, angle) = ([101.3, 97.6], [70.2, 55.7], 0.4);
    let img = ellipse(200, 200, c, ab, angle);
    // Hide the left quarter of the outline.
    let o = Outline::fit(&img, 90.0, 225.0, &|x, _| x < 60).expect("outline");
    assert!(o.rms_px < 0.01, "rms {}", o.rms_px);
    // Distance of true outline points from the fit, including the hidden stretch.
    let (s, co) = angle.sin_cos();
    for k in 0..72 {
        let th = k as f64 * std::f64::consts::TAU / 72.0;
        let (u, v) = (ab[0] * th.cos(), ab[1] * th.sin());
        let (x, y) = (c[0] + co * u - s * v, c[1] + s * u + co * v);
        assert!(o.distance_px(x, y).abs() < 0.02, "point {k}: {}", o.distance_px(x, y));
    }
    // Row crossing: the right-hand point of the row through the centre.
    let x = o.crossing(true, c[1], c[0] + 80.0).expect("crossing");
    assert!(o.distance_px(x, c[1]).abs() < 1e-9 && x > c[0]);
}

#[test]
fn a_partial_arc_with_stray_edges_is_fitted() {
    // The left part of a 170 x 160 px ellipse (its centre off the image), and a bright
    // square whose edges give about 80 crossings at the same levels off the conic.
    let (c, ab, angle) = ([250.4, 96.3], [170.0, 160.0], 0.2);
    let outline = ellipse(200, 200, c, ab, angle);
    let img = area_sampled(200, 200, 4, |x, y| if (20.0..40.0).contains(&x) && (150.0..170.0).contains(&y) { 225.0 } else { 90.0 });
    let img = ImageF32 { width: 200, height: 200, data: outline.data.iter().zip(&img.data).map(|(a, b)| a.max(*b)).collect() };
    let o = Outline::fit(&img, 90.0, 225.0, &|_, _| false).expect("outline");
    let (s, co) = angle.sin_cos();
    for k in 0..72 {
        let th = k as f64 * std::f64::consts::TAU / 72.0;
        let (u, v) = (ab[0] * th.cos(), ab[1] * th.sin());
        let (x, y) = (c[0] + co * u - s * v, c[1] + s * u + co * v);
        if (5.0..195.0).contains(&x) && (5.0..195.0).contains(&y) {
            assert!(o.distance_px(x, y).abs() < 0.02, "point {k} ({x:.1}, {y:.1}): {}", o.distance_px(x, y));
        }
    }
}

#[test]
fn no_outline_in_flat_or_noise_images() {
    let flat = ImageF32 { width: 64, height: 64, data: vec![128.0; 64 * 64] };
    assert!(Outline::fit(&flat, 90.0, 225.0, &|_, _| false).is_none());
    let mut state = 12345u64;
    let noise: Vec<f32> = (0..64 * 64)
        .map(|_| {
            state = state.wrapping_mul(6364136223846793005).wrapping_add(1442695040888963407);
            ((state >> 33) % 256) as f32
        })
        .collect();
    assert!(Outline::fit(&ImageF32 { width: 64, height: 64, data: noise }, 90.0, 225.0, &|_, _| false).is_none());
}
