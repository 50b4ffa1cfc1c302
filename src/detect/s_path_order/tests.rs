//! Tests of `s_path_order`.
use super::*;

fn dot(x: f64, y: f64, area: f64) -> Dot {
    Dot { centre_px: Point2::new(x, y), area_px: area, core_px: 4, contrast: 200.0 }
}

#[test]
fn orders_a_curve_and_bridges_a_gap() {
    // A quarter circle of 20 dots, the first larger, dot 7 missing, input shuffled.
    let mut dots: Vec<Dot> = (0..20)
        .filter(|i| *i != 7)
        .map(|i| {
            let a = f64::from(i) * 0.08;
            dot(100.0 + 200.0 * a.cos(), 100.0 + 200.0 * a.sin(), if i == 0 { 90.0 } else { 30.0 })
        })
        .collect();
    dots.reverse();
    dots.swap(3, 11);
    let params = SPathOrderParams { points: 20, min_chain: 5, ..Default::default() };
    let out = order_s_path(&dots, &params).unwrap();
    assert_eq!(out.len(), 19);
    let idx: Vec<usize> = out.iter().map(|d| d.index).collect();
    assert_eq!(idx, (0..20).filter(|i| *i != 7).collect::<Vec<_>>());
}

/// 40 dots 20 px apart on a circle, each moved by up to 0.19 of the spacing (a 5 mm stray on
/// the course's 25.7 mm spacing) in a fixed pseudo-random direction; the first larger.
fn stray_circle() -> Vec<Dot> {
    (0..40)
        .map(|i| {
            let a = f64::from(i) * 0.05;
            let (r, phi) = (3.8 * (f64::from(i) * 0.618_034).fract(), f64::from(i) * 2.399_963);
            dot(100.0 + 400.0 * a.cos() + r * phi.cos(), 100.0 + 400.0 * a.sin() + r * phi.sin(), if i == 0 { 90.0 } else { 30.0 })
        })
        .collect()
}

#[test]
fn orders_dots_that_stray_from_the_curve() {
    let dots: Vec<Dot> = stray_circle().into_iter().rev().collect();
    let params = SPathOrderParams { points: 40, min_chain: 5, growth: ChainGrowth::Strays, ..Default::default() };
    let out = order_s_path(&dots, &params).unwrap();
    let idx: Vec<usize> = out.iter().map(|d| d.index).collect();
    assert_eq!(idx, (0..40).collect::<Vec<_>>());
    // Every dot carries its own index (the input is reversed: dot k is path index 39 - k).
    for d in &out {
        assert_eq!(d.centre_px, dots[39 - d.index].centre_px);
    }
}

#[test]
fn strict_growth_loses_dots_that_stray() {
    // The strays of stray_circle: the strict chain, predicting from single steps, stops early.
    let dots = stray_circle();
    let params = SPathOrderParams { points: 40, min_chain: 5, ..Default::default() };
    let strict = start_dot_chain(&dots, &params).unwrap();
    let strays = start_dot_chain(&dots, &SPathOrderParams { growth: ChainGrowth::Strays, ..params }).unwrap();
    assert_eq!(strays.len(), 40);
    assert!(strict.len() < 40 || strict.iter().enumerate().any(|(k, &(i, _))| i != k as i64), "strict chain: {strict:?}");
}

#[test]
fn no_start_dot_is_an_error() {
    let dots: Vec<Dot> = (0..10).map(|i| dot(f64::from(i) * 10.0, 0.0, 30.0)).collect();
    assert!(matches!(order_s_path(&dots, &SPathOrderParams::default()), Err(DetectError::NotFound { .. })));
    assert!(order_s_path(&dots[..2], &SPathOrderParams::default()).is_err());
}
