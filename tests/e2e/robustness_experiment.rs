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
    assert_eq!(CSV_HEADER, "effect,level,strength,view,detected,rms_px,max_px,n_corners,untrusted");
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

/// Issue 41's scene conditions at a quarter of the experiment's size: each strength rises with
/// its level (the gradient's corner irradiance ratio, the highlight's specular grey at a corner,
/// the clutter's and the shadow's contrast), the weakest level of each is the plain board (found,
/// exact), a column of corners lies in the bar's shadow (truth `in_shadow`), and the
/// highlight's brightest corner is the one nearest the board centre (the lamp sits at the
/// camera's mirror point over it).
#[test]
fn scene_conditions_rise_with_their_levels() {
    let mut setup = RobustnessSetup::chessboard_k1(1, 0).expect("embedded scene");
    let cam = &mut setup.base.camera;
    (cam.size.width, cam.size.height) = (320, 256);
    let k = &mut cam.intrinsics;
    (k.fx, k.fy, k.cx, k.cy) = (0.25 * k.fx, 0.25 * k.fy, 0.25 * (k.cx + 0.5) - 0.5, 0.25 * (k.cy + 0.5) - 0.5);
    let plan: [(Effect, &[f64]); 4] =
        [(Effect::Gradient, &[0.0, 0.05, 0.2]), (Effect::Highlight, &[0.0, 0.5, 1.0]), (Effect::Clutter, &[0.0, 1.0]), (Effect::Shadow, &[1.0, 2.0])];
    let mut shadowed = 0;
    let mut brightest_near_centre = true;
    let runs = run_levels(renderer(), &setup, &plan, &mut |v| {
        if v.run.effect == Effect::Shadow && v.run.level > 1.0 {
            shadowed = v.truth.features.iter().filter(|f| f.in_shadow == Some(true)).count();
        }
        if v.run.effect == Effect::Highlight && v.run.level > 0.0 {
            let spec: Vec<f64> = v.truth.features.iter().map(|f| f.specular.unwrap_or(0.0)).collect();
            let brightest = (0..spec.len()).max_by(|a, b| spec[*a].total_cmp(&spec[*b])).unwrap_or(0);
            let centre = [v.truth_px.iter().map(|p| p[0]).sum::<f64>() / 88.0, v.truth_px.iter().map(|p| p[1]).sum::<f64>() / 88.0];
            let d = |i: usize| (v.truth_px[i][0] - centre[0]).hypot(v.truth_px[i][1] - centre[1]);
            // Within three quarters of a square (75 px at full size, a quarter here) of the nearest.
            brightest_near_centre &= (0..88).all(|i| d(brightest) <= d(i) + 0.75 * 75.0 / 4.0);
        }
        Ok(())
    })
    .expect("run");
    for r in &runs {
        eprintln!("{} {}: strength {:.3}, detected {} RMS {:.4} px, untrusted {}", r.effect.name(), r.level, r.strength, r.detected, r.rms_px, r.untrusted);
    }
    for w in runs.windows(2).filter(|w| w[0].effect == w[1].effect) {
        assert!(w[1].strength > w[0].strength, "{:?} then {:?}", w[0], w[1]);
    }
    // The bar's shadow covers a column of the 8 rows of corners.
    assert!((4..=16).contains(&shadowed), "{shadowed} corners in the bar's shadow");
    for weakest in runs.iter().filter(|r| r.level == 0.0 || (r.effect == Effect::Shadow && r.level == 1.0)) {
        assert!(weakest.detected && weakest.rms_px < 0.05, "{weakest:?}");
    }
    assert!(runs.iter().filter(|r| r.effect == Effect::Gradient).all(|r| r.level > 0.0 || r.strength == 1.0));
    assert!(brightest_near_centre, "the highlight lies over the board centre");
}
