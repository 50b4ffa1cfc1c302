//! Tests of `saddle_fit`.

use super::profile::{erf_exp, exp_neg};
use super::*;
use crate::ImageF32;

/// Area-sampled (n x n supersampled) rotated saddle, lines at angles t1, t2 through (cx, cy).
pub(crate) fn saddle(cx: f64, cy: f64, t1: f64, t2: f64) -> ImageF32 {
    let (w, h) = (31, 31);
    let n = 16;
    let (n1, n2) = (Vector2::new(-t1.sin(), t1.cos()), Vector2::new(-t2.sin(), t2.cos()));
    let mut data = vec![0.0f32; w * h];
    for y in 0..h {
        for x in 0..w {
            let mut acc = 0.0;
            for j in 0..n {
                for i in 0..n {
                    let p = Vector2::new(x as f64 - 0.5 + (i as f64 + 0.5) / n as f64 - cx, y as f64 - 0.5 + (j as f64 + 0.5) / n as f64 - cy);
                    acc += if (n1.dot(&p) > 0.0) == (n2.dot(&p) > 0.0) { 200.0 } else { 30.0 };
                }
            }
            data[y * w + x] = (acc / (n * n) as f64) as f32;
        }
    }
    ImageF32::new(w, h, data).unwrap()
}

#[test]
fn exp_and_erf_are_exact_enough() {
    for k in 0..2000 {
        let y = k as f64 * 0.01;
        assert!(((exp_neg(y) - (-y).exp()) / (-y).exp()).abs() < 1e-9, "{y}");
    }
    for (x, e) in [(0.0, 0.0), (0.5, 0.520_499_877_8), (1.0, 0.842_700_792_9), (-2.0, -0.995_322_265_0)] {
        assert!((erf_exp(x, 1.0).0 - e).abs() < 2e-7, "{x}");
    }
}

#[test]
fn unbiased_on_area_sampled_saddles() {
    let mut worst: f64 = 0.0;
    let mut sum2 = 0.0;
    let mut cnt = 0;
    for k in 0..40 {
        let f = k as f64;
        let cx = 15.0 + (f * 0.618_034).fract() - 0.5;
        let cy = 15.0 + (f * 0.414_213).fract() - 0.5;
        let t1 = (f * 0.7).sin() * 0.8;
        let t2 = t1 + std::f64::consts::FRAC_PI_2 + (f * 1.3).cos() * 0.5;
        let img = saddle(cx, cy, t1, t2);
        let d1 = Vector2::new(t1.cos(), t1.sin()) + Vector2::new(0.1, -0.05);
        let d2 = Vector2::new(t2.cos(), t2.sin());
        let r = refine_saddle(&img, Point2::new(cx.round() + 0.3, cy.round() - 0.4), d1, d2, &SaddleFitParams::default()).unwrap();
        let e = ((r.point.x - cx).powi(2) + (r.point.y - cy).powi(2)).sqrt();
        worst = worst.max(e);
        sum2 += e * e;
        cnt += 1;
    }
    let rms = (sum2 / cnt as f64).sqrt();
    eprintln!("saddle fit on exact renders: rms {rms:.5} px, max {worst:.5} px");
    assert!(rms < 0.01 && worst < 0.03, "rms {rms} max {worst}");
}

#[test]
fn bad_seeds_are_errors_not_panics() {
    let img = saddle(15.0, 15.0, 0.0, 1.5);
    let d = (Vector2::new(1.0, 0.0), Vector2::new(0.0, 1.0));
    let p = SaddleFitParams::default();
    assert!(refine_saddle(&img, Point2::new(f64::NAN, 3.0), d.0, d.1, &p).is_err());
    assert!(refine_saddle(&img, Point2::new(1.0, 1.0), d.0, d.1, &p).is_err());
    let flat = ImageF32::new(31, 31, vec![7.0; 961]).unwrap();
    let _ = refine_saddle(&flat, Point2::new(15.0, 15.0), d.0, d.1, &p);
}
