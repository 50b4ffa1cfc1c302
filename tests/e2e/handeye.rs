//! Hand-eye calibration on rendered and detected pixels (course variant A, M = 5 views).
//! Issue targets: tool_from_cam and base translation errors <= 1 mm, rotation (AX = XB solver)
//! <= 0.05 degrees; median and worst over seeds.

use synthcam::course::handeye_run::{run_handeye, HandEyeRunError};
use synthcam::robot::Cell;
use synthcam::sim::sensor::ObservationKind;

use crate::common::renderer;

fn summary(name: &str, obs: ObservationKind, seeds: u64) -> Vec<[f64; 7]> {
    let mut rows = Vec::new();
    for seed in 0..seeds {
        let r = run_handeye(Some(renderer()), obs, &Cell::default(), 5, seed).expect("hand-eye run");
        rows.push([r.errors[0].mm, r.errors[1].mm, r.errors[2].mm, r.errors[2].deg, r.errors[4].mm, r.errors[4].deg, r.errors[5].mm]);
    }
    let col = |k: usize| {
        let mut v: Vec<f64> = rows.iter().map(|r| r[k]).collect();
        v.sort_by(f64::total_cmp);
        (v[v.len() / 2], v[v.len() - 1])
    };
    let (a, b, c, d) = (col(0), col(1), col(2), col(3));
    let (e, f, g) = (col(4), col(5), col(6));
    eprintln!("{name}: refined tool_from_cam {:.3}/{:.3} mm and {:.4}/{:.4} deg, refined base {:.3}/{:.3} mm (median/worst)", e.0, e.1, f.0, f.1, g.0, g.1);
    eprintln!(
        "{name}, {seeds} seeds: linear tool_from_cam {:.3}/{:.3} mm, linear base {:.3}/{:.3} mm, Park-Martin tool_from_cam {:.3}/{:.3} mm and {:.4}/{:.4} deg (median/worst)",
        a.0, a.1, b.0, b.1, c.0, c.1, d.0, d.1
    );
    rows
}

#[test]
fn hand_eye_on_rendered_and_detected_dots() {
    let ideal = summary("ideal + 0.1 px", ObservationKind::Ideal, 20);
    let rows = summary("rendered + detected", ObservationKind::Rendered, 20);
    let worst = |k: usize| rows.iter().map(|r| r[k]).fold(0.0, f64::max);
    let median = |rows: &[[f64; 7]], k: usize| {
        let mut v: Vec<f64> = rows.iter().map(|r| r[k]).collect();
        v.sort_by(f64::total_cmp);
        v[v.len() / 2]
    };
    // Ideal projections with 0.1 px noise (measured 2026-12-02: refined worst 1.26 mm / 0.030 deg,
    // base 1.04 mm over 20 seeds): bounds at twice that, and the rendered run must beat the ideal
    // one's median (its detected dots are far better than 0.1 px).
    let ideal_worst = |k: usize| ideal.iter().map(|r| r[k]).fold(0.0, f64::max);
    assert!(
        ideal_worst(4) <= 2.5 && ideal_worst(5) <= 0.06 && ideal_worst(6) <= 2.5,
        "ideal refined {} mm, {} deg, base {} mm",
        ideal_worst(4),
        ideal_worst(5),
        ideal_worst(6)
    );
    assert!(median(&rows, 4) < median(&ideal, 4), "rendered {} mm vs ideal {} mm", median(&rows, 4), median(&ideal, 4));
    assert!(worst(0) <= 1.0 && worst(1) <= 1.0, "linear {} / {} mm", worst(0), worst(1));
    assert!(worst(2) <= 1.0 && worst(3) <= 0.05, "Park-Martin {} mm, {} deg", worst(2), worst(3));
    assert!(worst(4) <= 1.0 && worst(5) <= 0.05 && worst(6) <= 1.0, "refined {} mm, {} deg, base {} mm", worst(4), worst(5), worst(6));
}

#[test]
fn unreachable_scenario_is_a_typed_error() {
    // The robot folded at q = 0 never sees the S from behind its base.
    let s = Cell { q0_rad: [3.1, 0.0, 0.0, 0.0, 0.0, 0.0], spread_rad: 0.01, ..Default::default() };
    let e = run_handeye(None, ObservationKind::Ideal, &s, 5, 0).expect_err("unreachable");
    assert!(matches!(e, HandEyeRunError::Unreachable(_)), "{e}");
}

#[test]
fn course_scenario_file_parses_to_the_default() {
    let text = include_str!("../../assets/scenarios/course.toml");
    let s: Cell = toml::from_str(text).expect("scenario");
    assert_eq!(s, Cell::default());
}
