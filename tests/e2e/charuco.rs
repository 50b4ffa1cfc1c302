//! ChArUco boards (issue 17): every pixel of the GPU render against the exact box filter, and
//! the truth labels against OpenCV's board numbering.

use nalgebra::Vector3;
use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;
use synthcam::scene::exact::render_exact_planar;
use synthcam::scene::{RenderSettings, Scene};
use synthcam::target::{BoardLook, Charuco, CharucoTarget, Dictionary, Target};

use crate::common::renderer;
use crate::coverage_exact::{random_camera, random_pose};

/// The same gate as the chessboard's and dot grid's exact coverage (`coverage_exact`).
const GATE: f64 = 0.25;

fn random_charuco_scene(rng: &mut ChaCha8Rng) -> Scene {
    let (w, h) = (320, 256);
    let camera = random_camera(rng, w, h);
    let dicts = [Dictionary::Dict4x4_50, Dictionary::Dict5x5_100, Dictionary::Dict6x6_250, Dictionary::Dict7x7_1000, Dictionary::AprilTag36h11];
    let dictionary = dicts[rng.random_range(0..dicts.len())];
    let s = rng.random_range(0.01..0.06);
    let squares = [rng.random_range(3..9), rng.random_range(3..8)];
    let board = Charuco { squares, square_m: s, marker_m: s * rng.random_range(0.55..0.85), dictionary, legacy: rng.random_bool(0.5), first_id: 0 };
    let look = BoardLook {
        margin_m: s * rng.random_range(0.0..0.8),
        dark: rng.random_range(0.0..80.0),
        light: rng.random_range(170.0..255.0),
        margin: rng.random_range(100.0..255.0),
        background: rng.random_range(0.0..255.0),
    };
    // Marker cells from about 2 to 40 px.
    let cell_px = (rng.random_range(2f64.ln()..40f64.ln())).exp();
    let cell_m = board.marker_m / (dictionary.marker_bits() as f64 + 2.0);
    let centre = Vector3::new(0.5 * s * f64::from(squares[0]), 0.5 * s * f64::from(squares[1]), 0.0);
    let pose = random_pose(rng, &camera, cell_m, cell_px, centre);
    Scene { camera, target: Target::Charuco(CharucoTarget { board, look }), cam_from_target: pose, render: RenderSettings::default() }
}

#[test]
fn charuco_pixels_match_the_exact_box_filter() {
    let mut rng = ChaCha8Rng::seed_from_u64(17);
    let (mut worst, mut pixels, mut edge_pixels) = ((0.0, String::new()), 0usize, 0usize);
    for k in 0..12 {
        let scene = random_charuco_scene(&mut rng);
        let gpu = renderer().render_linear(&scene).expect("render");
        let exact = render_exact_planar(&scene, 8).expect("exact");
        let w = scene.camera.size.width as usize;
        let Target::Charuco(c) = &scene.target else { unreachable!() };
        let greys = [c.look.dark, c.look.light, c.look.margin, c.look.background];
        let mut scene_max = 0.0f64;
        for (i, (g, e)) in gpu.iter().zip(&exact).enumerate() {
            let Some(e) = e else { continue };
            let d = (f64::from(*g) - e).abs();
            pixels += 1;
            let row = i / w;
            // A pixel that no single grey level fills: an edge crosses it.
            if greys.iter().all(|v| (v - e).abs() > 0.5) {
                edge_pixels += 1;
            }
            scene_max = scene_max.max(d);
            if d > worst.0 {
                worst = (d, format!("scene {k} pixel ({}, {row}): gpu {g:.3} exact {e:.3}", i % w));
            }
        }
        eprintln!("scene {k:2} charuco max |diff| {scene_max:.4}");
    }
    eprintln!("{pixels} pixels ({edge_pixels} at edges); worst {:.4} grey levels at {}", worst.0, worst.1);
    assert!(edge_pixels > 2000, "too few edge pixels to test the coverage: {edge_pixels}");
    assert!(worst.0 <= GATE, "max |diff| {:.4} > {GATE}: {}", worst.0, worst.1);
}

#[test]
fn charuco_truth_numbers_corners_and_markers_as_opencv() {
    let mut rng = ChaCha8Rng::seed_from_u64(3);
    let scene = random_charuco_scene(&mut rng);
    let Target::Charuco(c) = &scene.target else { unreachable!() };
    let truth = synthcam::scene::truth_labels(&scene);
    let [nx, ny] = c.board.squares;
    assert_eq!(truth.target_kind, "charuco");
    assert_eq!(truth.grid, [nx - 1, ny - 1]);
    assert_eq!(truth.features.len(), ((nx - 1) * (ny - 1)) as usize);
    // OpenCV: corner id k sits at ((k % (nx - 1) + 1) s, (k / (nx - 1) + 1) s).
    for f in &truth.features {
        let k = f.id as u32;
        let s = c.board.square_m;
        assert!((f.point_target_m[0] - f64::from(k % (nx - 1) + 1) * s).abs() < 1e-12);
        assert!((f.point_target_m[1] - f64::from(k / (nx - 1) + 1) * s).abs() < 1e-12);
    }
    // Markers: ids 0.. over the marker squares row by row, half the squares.
    assert_eq!(truth.markers.len(), c.board.markers().len());
    assert!(truth.markers.iter().enumerate().all(|(k, m)| m.id == k as u32));
    assert!(truth.markers.len() as u32 >= nx * ny / 2);
}
