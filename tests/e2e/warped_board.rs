//! Boards that are not flat (issue 39 item 4): a warped chessboard, ChArUco board and AprilGrid render where
//! their truth says (the detector finds the corners as close to the truth as on a flat board,
//! although the warp moves them by pixels), a warp of zero renders byte-identical to a
//! flat board, and a warp the renderer cannot yet combine with an effect is a typed error.

use nalgebra::Point2;
use synthcam::detect::target::{detect, TargetSpec};
use synthcam::detect::ImageF32;
use synthcam::prelude::*;
use synthcam::scene::truth::truth_labels;
use synthcam::target::{AprilGrid, AprilGridTarget, BoardLook, CharucoTarget};

use crate::common::{camera, chessboard_scene, renderer};

/// The detector's corners against the truth (each to its nearest true corner): (RMS, max) px and
/// the number found.
fn corner_errors(scene: &Scene) -> (f64, f64, usize) {
    let img = renderer().render_linear(scene).expect("render");
    let (w, h) = (scene.camera.size.width as usize, scene.camera.size.height as usize);
    let img = ImageF32::new(w, h, img).expect("size");
    let det = detect(&img, &TargetSpec::for_target(&scene.target)).expect("detect");
    let truth: Vec<Point2<f64>> = truth_labels(scene).features.iter().map(|f| Point2::new(f.pixel_px[0], f.pixel_px[1])).collect();
    let errs: Vec<f64> = det.points_px.iter().map(|p| truth.iter().map(|t| (t - p).norm()).fold(f64::INFINITY, f64::min)).collect();
    let rms = (errs.iter().map(|e| e * e).sum::<f64>() / errs.len().max(1) as f64).sqrt();
    (rms, errs.iter().copied().fold(0.0, f64::max), errs.len())
}

fn with_warp(scene: &Scene, warp_m: [f64; 2]) -> Scene {
    let mut s = scene.clone();
    match &mut s.target {
        Target::Chessboard(b) => b.warp_m = warp_m,
        Target::Charuco(c) => c.look.warp_m = warp_m,
        Target::AprilGrid(g) => g.look.warp_m = warp_m,
        _ => unreachable!("a board"),
    }
    s
}

/// The largest move of a true corner between two scenes, px.
fn truth_shift(a: &Scene, b: &Scene) -> f64 {
    let (ta, tb) = (truth_labels(a), truth_labels(b));
    ta.features
        .iter()
        .zip(&tb.features)
        .map(|(p, q)| (Point2::new(p.pixel_px[0], p.pixel_px[1]) - Point2::new(q.pixel_px[0], q.pixel_px[1])).norm())
        .fold(0.0, f64::max)
}

#[test]
fn warped_boards_render_where_their_truth_is() {
    let cam = camera(1280, 1024, 1500.0, [-0.25, 0.12, 0.0, 0.0, 0.0]);
    let chess = chessboard_scene(cam, [12, 9], 0.045, 35.0, 0.8, [0.0, 0.0]);
    let mut charuco = chess.clone();
    charuco.target = Target::Charuco(CharucoTarget {
        board: Charuco { squares: [12, 9], square_m: 0.045, marker_m: 0.033, dictionary: Dictionary::Dict5x5_100, legacy: false, first_id: 0 },
        look: BoardLook { margin_m: 0.02, ..Default::default() },
    });
    // An AprilGrid posed as assets/scenes/aprilgrid_k1.toml poses one (turned about 145 degrees
    // about x; the chessboard scene's pose shows it with its tags mirrored, which the AprilGrid
    // detector does not read), its centre on the axis.
    let grid = AprilGrid { tags: [6, 4], tag_m: 0.045, ..Default::default() };
    let [_, _, x1, y1] = grid.extent_m();
    let rot = nalgebra::UnitQuaternion::from_axis_angle(&nalgebra::Vector3::x_axis(), 2.53);
    let t = nalgebra::Vector3::new(0.0, 0.0, 0.8) - rot * nalgebra::Vector3::new(0.5 * x1, 0.5 * y1, 0.0);
    let aprilgrid = Scene {
        target: Target::AprilGrid(AprilGridTarget { grid, look: BoardLook { margin_m: 0.02, ..Default::default() } }),
        cam_from_target: nalgebra::Isometry3::from_parts(t.into(), rot),
        ..chess.clone()
    };
    for (name, flat) in [("chessboard", chess), ("charuco", charuco), ("aprilgrid", aprilgrid)] {
        let (frms, fmax, _) = corner_errors(&flat);
        eprintln!("{name} flat: detected against the truth RMS {frms:.4} px, max {fmax:.4} px");
        for warp in [[0.003, -0.002], [-0.004, 0.001]] {
            let warped = with_warp(&flat, warp);
            let shift = truth_shift(&flat, &warped);
            let (rms, max, n) = corner_errors(&warped);
            eprintln!("{name} warp {warp:?}: corners move {shift:.2} px; detected against the truth: RMS {rms:.4} px, max {max:.4} px over {n}");
            assert!(shift > 2.0, "{name}: the warp moves the corners by {shift} px only");
            assert!(n >= 70 && rms <= 0.01 && max <= 0.04 && rms <= 1.5 * frms.max(0.004), "{name} {warp:?}: RMS {rms}, max {max}, {n} corners");
        }
    }
}

#[test]
fn a_zero_warp_is_the_flat_board_and_effects_on_a_warp_are_refused() {
    let cam = camera(640, 480, 500.0, [-0.1, 0.0, 0.0, 0.0, 0.0]);
    let flat = chessboard_scene(cam, [8, 6], 0.03, 20.0, 0.5, [0.0, 0.0]);
    let zero = with_warp(&flat, [0.0, 0.0]);
    assert_eq!(renderer().render_linear(&flat).expect("flat"), renderer().render_linear(&zero).expect("zero"));
    let mut blurred = with_warp(&flat, [0.002, 0.0]);
    blurred.render.effects.motion.twist = [0.0, 0.0, 0.0, 0.1, 0.0, 0.0];
    blurred.render.effects.motion.exposure_s = 0.01;
    let e = blurred.validate().expect_err("motion on a warped board");
    assert!(e.to_string().contains("warp"), "{e}");
    let too_big = with_warp(&flat, [0.05, 0.0]);
    assert!(too_big.validate().is_err());
}
