//! Tests of `s_path_order`.
use super::*;

fn dot(x: f64, y: f64, area: f64) -> Dot {
    Dot { centre_px: Point2::new(x, y), area_px: area, spread_px: 0.5 * (area / std::f64::consts::PI).sqrt(), core_px: 4, contrast: 200.0, touching: false }
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

#[test]
fn a_chain_spans_no_more_indices_than_the_path_has() {
    use super::steps::fit_span;
    // 40 steps, every other one counted as bridged (foreshortened strays): 60 indices for a
    // 41-point path. All are single steps.
    let len: Vec<f64> = (0..40).map(|k| if k % 2 == 0 { 10.0 } else { 15.0 }).collect();
    let mut inc: Vec<i64> = (0..40).map(|k| if k % 2 == 0 { 1 } else { 2 }).collect();
    fit_span(&len, &mut inc, 40);
    assert_eq!(inc, vec![1; 40]);
    // One real gap (a step twice as long) among bridged steps too many: the gap stays bridged.
    let mut len = vec![10.0; 40];
    len[20] = 20.0;
    len[5] = 12.0;
    len[30] = 11.0;
    let mut inc = vec![1i64; 40];
    (inc[5], inc[20], inc[30]) = (2, 2, 2);
    fit_span(&len, &mut inc, 41);
    assert_eq!(inc.iter().sum::<i64>(), 41);
    assert_eq!(inc[20], 2);
    // A chain within the path's span is left alone.
    let mut same = inc.clone();
    fit_span(&len, &mut same, 100);
    assert_eq!(same, inc);
}
