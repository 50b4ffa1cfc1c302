//! Tests of the ChArUco detector on boards rendered by the test renderer in `render`.

use std::time::Instant;

use nalgebra::{Point2, Point3};

use super::*;
use crate::markers::test_render::{render, render_two, Camera};
use synthcam_core::target::Dictionary;

/// 11 x 8 squares, 5x5 markers at 0.733 of the square.
fn board() -> Charuco {
    Charuco { squares: [11, 8], square_m: 0.03, marker_m: 0.022, dictionary: Dictionary::Dict5x5_100, legacy: false, first_id: 0 }
}

/// Comparison of a detection with the truth of `cam`.
struct Score {
    /// Corners found.
    found: usize,
    /// Corners farther than 0.25 px from their id's truth (wrong ids or failed fits).
    wrong: usize,
    /// Markers whose corners are farther than 1 px from their id's truth.
    wrong_markers: usize,
    rms: f64,
    max: f64,
    /// RMS error of the marker corners, pixels.
    marker_rms: f64,
}

fn score(det: &CharucoDetection, board: &Charuco, cam: &Camera) -> Score {
    let truth: Vec<Point2<f64>> = board.chessboard_corners_m().iter().map(|p| cam.project(*p)).collect();
    let layout = board.markers();
    let errs: Vec<f64> = det.ids.iter().zip(&det.corners_px).map(|(id, p)| truth.get(*id as usize).map_or(f64::INFINITY, |t| (p - t).norm())).collect();
    let wrong_markers = det
        .markers
        .iter()
        .filter(|m| {
            let Some(e) = m.id.checked_sub(board.first_id).and_then(|k| layout.get(k as usize)) else { return true };
            e.corners_m.iter().zip(&m.corners_px).any(|(b, p)| (cam.project(*b) - p).norm() > 1.0)
        })
        .count();
    let marker_errs: Vec<f64> = det
        .markers
        .iter()
        .filter_map(|m| m.id.checked_sub(board.first_id).and_then(|k| layout.get(k as usize)).map(|e| (e, m)))
        .flat_map(|(e, m)| e.corners_m.iter().zip(&m.corners_px).map(|(b, p)| (cam.project(*b) - p).norm_squared()).collect::<Vec<_>>())
        .collect();
    let marker_rms = (marker_errs.iter().sum::<f64>() / marker_errs.len().max(1) as f64).sqrt();
    let good: Vec<f64> = errs.iter().copied().filter(|e| *e <= 0.25).collect();
    let rms = (good.iter().map(|e| e * e).sum::<f64>() / good.len().max(1) as f64).sqrt();
    Score { found: det.ids.len(), wrong: errs.len() - good.len(), wrong_markers, rms, max: good.iter().fold(0.0, |a, b| a.max(*b)), marker_rms }
}

fn assert_sorted(det: &CharucoDetection) {
    assert!(det.ids.windows(2).all(|w| w[0] < w[1]), "ids not ascending");
    assert!(det.markers.windows(2).all(|w| w[0].id < w[1].id), "markers not sorted");
    assert_eq!(det.ids.len(), det.corners_px.len());
}

/// Corners whose fit window (6 px) and both adjacent markers lie inside the image.
fn measurable(b: &Charuco, cam: &Camera, (w, h): (usize, usize)) -> usize {
    let inside = |p: Point2<f64>, m: f64| p.x >= m && p.y >= m && p.x <= w as f64 - 1.0 - m && p.y <= h as f64 - 1.0 - m;
    let layout = b.markers();
    let marker_in = |x: u32, y: u32| layout.iter().find(|m| m.square == [x, y]).is_some_and(|m| m.corners_m.iter().all(|c| inside(cam.project(*c), 3.0)));
    let [nx, ny] = b.squares;
    (1..ny)
        .flat_map(|j| (1..nx).map(move |i| (i, j)))
        .filter(|&(i, j)| {
            let p = cam.project(Point3::new(f64::from(i) * b.square_m, f64::from(j) * b.square_m, 0.0));
            let adjacent = [(i - 1, j - 1), (i, j - 1), (i - 1, j), (i, j)].iter().filter(|&&(x, y)| marker_in(x, y)).count();
            inside(p, 8.0) && adjacent == 2
        })
        .count()
}

#[test]
fn partial_board_gives_only_correct_ids() {
    let b = board();
    let size = (640, 480);
    for (ox, oy) in [(0.16, 0.0), (-0.12, 0.08), (0.0, 0.1)] {
        let cam = Camera::looking_at(&b, size, 800.0, (ox, oy, 0.45), (0.3, 0.1, 0.1));
        let img = render(&b, &cam, size, 8);
        let det = find_charuco(&img, &b, &CharucoParams::default()).unwrap();
        let s = score(&det, &b, &cam);
        let expect = measurable(&b, &cam, size);
        eprintln!("partial ({ox}, {oy}): {} corners ({expect} measurable), {} markers, rms {:.4} px", s.found, det.markers.len(), s.rms);
        assert_eq!((s.wrong, s.wrong_markers), (0, 0));
        assert!(expect > 5 && s.found >= expect && s.found < 70, "found {} of {expect}", s.found);
    }
}

#[test]
fn legacy_layouts_with_even_rows_decode() {
    let size = (640, 480);
    for legacy in [false, true] {
        let b = Charuco { squares: [5, 4], square_m: 0.04, marker_m: 0.03, dictionary: Dictionary::Dict4x4_50, legacy, first_id: 0 };
        let cam = Camera::looking_at(&b, size, 900.0, (0.0, 0.0, 0.5), (0.2, -0.2, 0.1));
        let img = render(&b, &cam, size, 8);
        let det = find_charuco(&img, &b, &CharucoParams::default()).unwrap();
        let s = score(&det, &b, &cam);
        eprintln!("legacy {legacy}: {} corners, {} markers, rms {:.4} px", s.found, det.markers.len(), s.rms);
        assert_eq!((s.wrong, s.wrong_markers), (0, 0));
        assert_eq!((s.found, det.markers.len()), (12, 10), "legacy {legacy}");
    }
}

#[test]
fn wrong_dictionary_finds_nothing() {
    let b = board();
    let size = (640, 480);
    let cam = Camera::looking_at(&b, size, 700.0, (0.0, 0.0, 0.45), (0.0, 0.1, 0.1));
    let img = render(&b, &cam, size, 8);
    for dictionary in [Dictionary::Dict4x4_50, Dictionary::Dict6x6_250, Dictionary::Dict5x5_100] {
        let other = Charuco { dictionary, first_id: if dictionary == Dictionary::Dict5x5_100 { 50 } else { 0 }, ..b };
        let det = find_charuco(&img, &other, &CharucoParams::default()).unwrap();
        assert!(det.markers.is_empty() && det.ids.is_empty(), "{}: {:?}", dictionary.name(), det.markers.iter().map(|m| m.id).collect::<Vec<_>>());
    }
}

#[test]
fn two_boards_with_disjoint_ids_are_found_separately() {
    let size = (960, 480);
    let a = Charuco { squares: [5, 4], square_m: 0.04, marker_m: 0.03, dictionary: Dictionary::Dict4x4_50, legacy: false, first_id: 0 };
    let b = Charuco { first_id: 10, ..a };
    let ca = Camera::looking_at(&a, size, 800.0, (-0.14, 0.0, 0.6), (0.1, 0.1, 0.2));
    let cb = Camera::looking_at(&b, size, 800.0, (0.14, 0.0, 0.6), (-0.2, -0.1, -0.2));
    let img = render_two([(&a, &ca), (&b, &cb)], size, 8);
    for (board, cam, ids) in [(&a, &ca, 0..10), (&b, &cb, 10..20)] {
        let det = find_charuco(&img, board, &CharucoParams::default()).unwrap();
        let s = score(&det, board, cam);
        eprintln!("board first_id {}: {} corners, {} markers", board.first_id, s.found, det.markers.len());
        assert_eq!((s.wrong, s.wrong_markers), (0, 0));
        assert_eq!(det.markers.iter().map(|m| m.id).collect::<Vec<_>>(), ids.collect::<Vec<_>>());
        assert_eq!(s.found, 12);
    }
}

#[test]
fn garbage_images_never_panic() {
    let b = board();
    let p = CharucoParams::default();
    let mut seed = 12345u64;
    let mut noise = || {
        seed = seed.wrapping_mul(6364136223846793005).wrapping_add(1442695040888963407);
        (seed >> 33) as f32 / (1u64 << 31) as f32 * 255.0
    };
    let noisy = ImageF32::new(640, 480, (0..640 * 480).map(|_| noise()).collect()).unwrap();
    let det = find_charuco(&noisy, &b, &p).unwrap();
    assert!(det.markers.is_empty() && det.ids.is_empty());
    for v in [0.0, 128.0, f32::NAN, f32::INFINITY] {
        let flat = ImageF32::new(64, 48, vec![v; 64 * 48]).unwrap();
        let det = find_charuco(&flat, &b, &p).unwrap();
        assert!(det.markers.is_empty() && det.ids.is_empty());
    }
    for (w, h) in [(1, 1), (2, 7), (5, 1)] {
        assert!(find_charuco(&ImageF32::new(w, h, vec![7.0; w * h]).unwrap(), &b, &p).is_ok());
    }
    assert!(matches!(find_charuco(&ImageF32::new(0, 5, vec![]).unwrap(), &b, &p), Err(DetectError::EmptyImage { .. })));
    let bad_buffer = ImageF32 { width: 4, height: 4, data: vec![0.0; 3] };
    assert!(matches!(find_charuco(&bad_buffer, &b, &p), Err(DetectError::BadBuffer { .. })));
    // a board with NaN patches: no panic, no wrong id
    let size = (640, 480);
    let cam = Camera::looking_at(&b, size, 700.0, (0.0, 0.0, 0.45), (0.0, 0.1, 0.1));
    let mut img = render(&b, &cam, size, 4);
    for y in 100..180 {
        for x in 200..330 {
            img.data[y * 640 + x] = if (x + y) % 3 == 0 { f32::NAN } else { f32::NEG_INFINITY };
        }
    }
    let det = find_charuco(&img, &b, &p).unwrap();
    let s = score(&det, &b, &cam);
    eprintln!("NaN patch: {} corners, {} markers", s.found, det.markers.len());
    assert_eq!((s.wrong, s.wrong_markers), (0, 0));
    assert!(s.found > 20);
}

#[test]
fn bad_parameters_and_boards_are_typed_errors() {
    let img = ImageF32::new(32, 32, vec![100.0; 1024]).unwrap();
    let b = board();
    let bad = |p: CharucoParams| matches!(find_charuco(&img, &b, &p), Err(DetectError::BadParams { .. }));
    let d = CharucoParams::default();
    let m = |markers: MarkerParams| CharucoParams { markers, ..d };
    assert!(bad(m(MarkerParams { threshold_windows_px: [0, 0, 0], ..d.markers })));
    assert!(bad(m(MarkerParams { min_marker_perimeter_px: f64::NAN, ..d.markers })));
    assert!(bad(m(MarkerParams { error_correction_rate: 1.5, ..d.markers })));
    assert!(bad(CharucoParams { corners: CornerParams { max_half_window: 1, ..d.corners }, ..d }));
    assert!(bad(m(MarkerParams { threshold_offset: f32::INFINITY, ..d.markers })));
    let bad_board = Charuco { marker_m: 0.05, ..b };
    assert!(matches!(find_charuco(&img, &bad_board, &d), Err(DetectError::BadParams { .. })));
}

/// Seeded standard normal samples (LCG + Box-Muller).
fn normal_noise(seed: u64) -> impl FnMut() -> f64 {
    let mut state = seed;
    let mut uniform = move || {
        state = state.wrapping_mul(6364136223846793005).wrapping_add(1442695040888963407);
        ((state >> 11) as f64 + 0.5) / (1u64 << 53) as f64
    };
    move || (-2.0 * uniform().ln()).sqrt() * (std::f64::consts::TAU * uniform()).cos()
}

/// The accuracy cases on finely sampled CPU renders (seconds to minutes each): the slow tier,
/// skipped by `cargo test-fast` (`--skip ::slow::`), run by `cargo test`.
mod slow;
