//! `experiment robustness` smoke test: the experiment's scene at a quarter of its size (320 x 256,
//! f = 375 px), one view, blur and JPEG at their weakest and strongest levels.

use synthcam::report::robustness::{csv, plot_png, table, CSV_HEADER};
use synthcam::sim::robustness::{run_levels, Effect, RobustnessSetup};

use crate::common::renderer;

#[test]
fn weakest_levels_are_exact_and_strong_ones_run() {
    let t0 = std::time::Instant::now();
    let mut setup = RobustnessSetup::chessboard_k1(1, 0).expect("embedded scene");
    let cam = &mut setup.base.camera;
    cam.size.width = 320;
    cam.size.height = 256;
    let k = &mut cam.intrinsics;
    (k.fx, k.fy, k.cx, k.cy) = (0.25 * k.fx, 0.25 * k.fy, 0.25 * (k.cx + 0.5) - 0.5, 0.25 * (k.cy + 0.5) - 0.5);
    let plan: [(Effect, &[f64]); 2] = [(Effect::Blur, &[0.0, 3.0]), (Effect::Jpeg, &[100.0, 10.0])];
    let mut images = 0;
    let runs = run_levels(renderer(), &setup, &plan, &mut |v| {
        assert_eq!(v.image.dimensions(), (320, 256));
        assert_eq!((v.grid, v.truth_px.len()), ([11, 8], 88));
        images += 1;
        Ok(())
    })
    .expect("run");
    assert_eq!((runs.len(), images), (4, 4));
    for r in &runs {
        eprintln!("{} {}: detected {} RMS {:.4} px, max {:.4} px", r.effect.name(), r.level, r.detected, r.rms_px, r.max_px);
    }
    for weakest in [&runs[0], &runs[2]] {
        assert!(weakest.detected && weakest.n_corners == 88, "{weakest:?}");
        assert!(weakest.rms_px < 0.05, "{weakest:?}");
    }
    // Blur sigma 3 px on 23 px squares: found or not, but no crash and a finite error when found.
    assert!(!runs[1].detected || runs[1].rms_px.is_finite());
    assert!(csv(&runs).starts_with(&format!("{CSV_HEADER}\n")));
    assert_eq!(CSV_HEADER, "effect,level,strength,view,detected,rms_px,max_px,n_corners");
    assert_eq!(table(&runs).markdown().lines().count(), 2 + 4);
    assert!(plot_png(&runs, Effect::Jpeg).is_ok());
    eprintln!("robustness smoke test: {:.1} s", t0.elapsed().as_secs_f64());
}

#[test]
fn effect_names_round_trip() {
    for e in Effect::ALL {
        assert_eq!(Effect::from_name(e.name()), Some(e));
        assert!(!e.levels().is_empty());
    }
    assert_eq!(Effect::from_name("Rolling_Shutter"), Some(Effect::RollingShutter));
    assert_eq!(Effect::from_name("vignetting"), None);
}
