//! Tests of the AprilGrid detector on grids rendered by the test renderer
//! (`markers::test_render`).

use std::time::Instant;

use nalgebra::Point2;

use super::*;
use crate::markers::test_render::{render, Camera};
use synthcam_core::target::Dictionary;

/// Kalibr's default grid scaled down: 6 x 6 tag36h11, 2-bit border, spacing 0.3.
fn grid() -> AprilGrid {
    AprilGrid { tags: [6, 6], tag_m: 0.03, spacing: 0.3, family: Dictionary::AprilTag36h11, border_bits: 2, first_id: 0 }
}

/// Comparison of a detection with the truth of `cam`.
struct Score {
    found: usize,
    /// Corners farther than 0.25 px from their id's truth.
    wrong: usize,
    /// Tags whose corners are farther than 1 px from their id's truth.
    wrong_tags: usize,
    rms: f64,
    max: f64,
}

fn score(det: &AprilGridDetection, g: &AprilGrid, cam: &Camera) -> Score {
    let truth: Vec<Point2<f64>> = g.corners_by_id_m().iter().map(|p| cam.project(*p)).collect();
    let errs: Vec<f64> = det.ids.iter().zip(&det.corners_px).map(|(id, p)| truth.get(*id as usize).map_or(f64::INFINITY, |t| (p - t).norm())).collect();
    let wrong_tags = det
        .tags
        .iter()
        .filter(|t| {
            let Some(k) = t.id.checked_sub(g.first_id).filter(|k| *k < g.tags[0] * g.tags[1]) else { return true };
            g.tag_corners_m(k).iter().zip(&t.corners_px).any(|(b, p)| (cam.project(*b) - p).norm() > 1.0)
        })
        .count();
    let good: Vec<f64> = errs.iter().copied().filter(|e| *e <= 0.25).collect();
    let rms = (good.iter().map(|e| e * e).sum::<f64>() / good.len().max(1) as f64).sqrt();
    Score { found: det.ids.len(), wrong: errs.len() - good.len(), wrong_tags, rms, max: good.iter().fold(0.0, |a, b| a.max(*b)) }
}

fn check_sorted(det: &AprilGridDetection) {
    assert!(det.ids.windows(2).all(|w| w[0] < w[1]), "ids not ascending");
    assert!(det.tags.windows(2).all(|w| w[0].id < w[1].id), "tags not sorted");
    assert_eq!(det.ids.len(), det.corners_px.len());
}

#[test]
fn partial_grid_gives_only_correct_ids() {
    let g = grid();
    let size = (640, 480);
    for (ox, oy) in [(0.1, 0.0), (-0.08, 0.06), (0.0, 0.09)] {
        let cam = Camera::looking_at(&g, size, 800.0, (ox, oy, 0.4), (0.3, 0.1, 0.1));
        let img = render(&g, &cam, size, 8);
        let det = find_aprilgrid(&img, &g, &AprilGridParams::default()).unwrap();
        let s = score(&det, &g, &cam);
        // tags wholly inside the image with a margin
        let inside = |p: Point2<f64>| p.x >= 8.0 && p.y >= 8.0 && p.x <= size.0 as f64 - 9.0 && p.y <= size.1 as f64 - 9.0;
        let visible = (0..36).filter(|&k| g.tag_corners_m(k).iter().all(|c| inside(cam.project(*c)))).count();
        eprintln!("partial ({ox}, {oy}): {} corners, {} tags ({visible} wholly visible), rms {:.4} px", s.found, det.tags.len(), s.rms);
        check_sorted(&det);
        assert_eq!((s.wrong, s.wrong_tags), (0, 0));
        assert!(visible > 3 && det.tags.len() >= visible && det.tags.len() < 36, "{} tags of {visible}", det.tags.len());
        assert!(s.found >= 4 * visible, "{} corners of {visible} tags", s.found);
        assert!(s.rms <= 0.01 && s.max <= 0.04, "rms {} max {}", s.rms, s.max);
    }
}

#[test]
fn garbage_images_never_panic() {
    let g = grid();
    let p = AprilGridParams::default();
    let mut seed = 4242u64;
    let mut noise = || {
        seed = seed.wrapping_mul(6364136223846793005).wrapping_add(1442695040888963407);
        (seed >> 33) as f32 / (1u64 << 31) as f32 * 255.0
    };
    let noisy = ImageF32::new(640, 480, (0..640 * 480).map(|_| noise()).collect()).unwrap();
    let det = find_aprilgrid(&noisy, &g, &p).unwrap();
    assert!(det.tags.is_empty() && det.ids.is_empty());
    for v in [0.0, 128.0, f32::NAN, f32::INFINITY] {
        let flat = ImageF32::new(64, 48, vec![v; 64 * 48]).unwrap();
        let det = find_aprilgrid(&flat, &g, &p).unwrap();
        assert!(det.tags.is_empty() && det.ids.is_empty());
    }
    for (w, h) in [(1, 1), (2, 7), (5, 1), (17, 16)] {
        assert!(find_aprilgrid(&ImageF32::new(w, h, vec![7.0; w * h]).unwrap(), &g, &p).is_ok());
    }
    assert!(matches!(find_aprilgrid(&ImageF32::new(0, 5, vec![]).unwrap(), &g, &p), Err(DetectError::EmptyImage { .. })));
    let bad_buffer = ImageF32 { width: 4, height: 4, data: vec![0.0; 3] };
    assert!(matches!(find_aprilgrid(&bad_buffer, &g, &p), Err(DetectError::BadBuffer { .. })));
    let img = ImageF32::new(32, 32, vec![100.0; 1024]).unwrap();
    assert!(matches!(find_aprilgrid(&img, &AprilGrid { border_bits: 3, ..g }, &p), Err(DetectError::BadParams { .. })));
    let bad_corners = AprilGridParams { corners: CornerParams { max_half_window: 0, ..p.corners }, ..p };
    assert!(matches!(find_aprilgrid(&img, &g, &bad_corners), Err(DetectError::BadParams { .. })));
    // a grid with NaN patches: no panic, no wrong id
    let size = (640, 480);
    let cam = Camera::looking_at(&g, size, 700.0, (0.0, 0.0, 0.45), (0.0, 0.1, 0.1));
    let mut img = render(&g, &cam, size, 4);
    for y in 100..180 {
        for x in 200..330 {
            img.data[y * 640 + x] = if (x + y) % 3 == 0 { f32::NAN } else { f32::NEG_INFINITY };
        }
    }
    let det = find_aprilgrid(&img, &g, &p).unwrap();
    let s = score(&det, &g, &cam);
    eprintln!("NaN patch: {} corners, {} tags", s.found, det.tags.len());
    assert_eq!((s.wrong, s.wrong_tags), (0, 0));
    assert!(s.found > 60, "{}", s.found);
}

/// The accuracy cases on finely sampled CPU renders (seconds to minutes each): the slow tier,
/// skipped by `cargo test-fast` (`--skip ::slow::`), run by `cargo test`.
mod slow {
    use super::*;

    #[test]
    fn rotated_grids_keep_their_ids() {
        let g = grid();
        let size = (800, 800);
        for roll_deg in [90.0f64, 180.0, 37.0, -123.0] {
            let cam = Camera::looking_at(&g, size, 1100.0, (0.0, 0.0, 0.6), (roll_deg.to_radians(), 0.15, 0.1));
            // 32 x 32 sub-samples: at rolls of 90 degrees the edges are axis-aligned and the render's
            // 1 / n px quantisation of their positions would take most of the error budget
            let img = render(&g, &cam, size, 32);
            let det = find_aprilgrid(&img, &g, &AprilGridParams::default()).unwrap();
            let s = score(&det, &g, &cam);
            eprintln!("roll {roll_deg}: {} corners, {} tags, rms {:.4} px, max {:.4} px", s.found, det.tags.len(), s.rms, s.max);
            check_sorted(&det);
            assert_eq!((s.wrong, s.wrong_tags), (0, 0), "roll {roll_deg}");
            assert_eq!((s.found, det.tags.len()), (144, 36), "roll {roll_deg}");
            assert!(s.rms <= 0.01 && s.max <= 0.04, "roll {roll_deg}: rms {} max {}", s.rms, s.max);
        }
    }

    #[test]
    fn first_id_offset_and_one_bit_border() {
        let size = (800, 600);
        for g in [AprilGrid { tags: [5, 4], first_id: 100, ..grid() }, AprilGrid { tags: [4, 3], border_bits: 1, spacing: 0.25, ..grid() }] {
            let cam = Camera::looking_at(&g, size, 900.0, (0.0, 0.0, 0.4), (-0.3, 0.2, 0.1));
            let img = render(&g, &cam, size, 16);
            let det = find_aprilgrid(&img, &g, &AprilGridParams::default()).unwrap();
            let s = score(&det, &g, &cam);
            let n = (g.tags[0] * g.tags[1]) as usize;
            eprintln!(
                "first_id {} border {}: {} corners, {} tags, rms {:.4} px, max {:.4} px",
                g.first_id,
                g.border_bits,
                s.found,
                det.tags.len(),
                s.rms,
                s.max
            );
            check_sorted(&det);
            assert_eq!((s.wrong, s.wrong_tags), (0, 0));
            assert_eq!((s.found, det.tags.len()), (4 * n, n));
            assert_eq!(det.tags.first().map(|t| t.id), Some(g.first_id));
            assert!(s.rms <= 0.01 && s.max <= 0.04, "rms {} max {}", s.rms, s.max);
        }
    }

    #[test]
    fn barrel_distortion_k1() {
        let g = grid();
        let size = (1024, 768);
        let mut cam = Camera::looking_at(&g, size, 800.0, (0.0, 0.0, 0.3), (0.1, 0.2, -0.15));
        cam.k1 = -0.2;
        let img = render(&g, &cam, size, 16);
        let det = find_aprilgrid(&img, &g, &AprilGridParams::default()).unwrap();
        let s = score(&det, &g, &cam);
        eprintln!("k1 = -0.2: {} corners, {} tags, rms {:.4} px, max {:.4} px", s.found, det.tags.len(), s.rms, s.max);
        assert_eq!((s.wrong, s.wrong_tags), (0, 0));
        assert_eq!((s.found, det.tags.len()), (144, 36));
        assert!(s.rms <= 0.01 && s.max <= 0.04, "rms {} max {}", s.rms, s.max);
    }

    #[test]
    fn full_grid_all_ids_and_accurate_corners() {
        let g = grid();
        let size = (1280, 1024);
        let cam = Camera::looking_at(&g, size, 1400.0, (0.01, -0.005, 0.45), (0.05, 0.25, -0.2));
        let img = render(&g, &cam, size, 16);
        let params = AprilGridParams::default();
        let det = find_aprilgrid(&img, &g, &params).unwrap();
        let runs = 10;
        let t0 = Instant::now();
        for _ in 0..runs {
            std::hint::black_box(find_aprilgrid(&img, &g, &params).unwrap());
        }
        let ms = t0.elapsed().as_secs_f64() * 1e3 / runs as f64;
        let s = score(&det, &g, &cam);
        eprintln!(
            "full grid 1280x1024: {} / 144 corners, {} / 36 tags, rms {:.4} px, max {:.4} px, {ms:.2} ms per image",
            s.found,
            det.tags.len(),
            s.rms,
            s.max
        );
        check_sorted(&det);
        assert_eq!((s.wrong, s.wrong_tags), (0, 0));
        assert_eq!((s.found, det.tags.len()), (144, 36));
        assert!(s.rms <= 0.01 && s.max <= 0.04, "rms {} max {}", s.rms, s.max);
    }

    #[test]
    fn wrong_family_border_or_mirror_finds_nothing_wrong() {
        let g = grid();
        let size = (800, 600);
        let cam = Camera::looking_at(&g, size, 900.0, (0.0, 0.0, 0.45), (0.1, 0.1, 0.1));
        let img = render(&g, &cam, size, 8);
        for family in [Dictionary::AprilTag16h5, Dictionary::AprilTag25h9, Dictionary::AprilTag36h10, Dictionary::Dict6x6_250] {
            let other = AprilGrid { family, tags: [5, 5], ..g };
            let det = find_aprilgrid(&img, &other, &AprilGridParams::default()).unwrap();
            assert!(det.tags.is_empty() && det.ids.is_empty(), "{}: {:?}", family.name(), det.tags.iter().map(|m| m.id).collect::<Vec<_>>());
        }
        // ids 36.. of the same family, and a 1-bit border
        for other in [AprilGrid { first_id: 36, ..g }, AprilGrid { border_bits: 1, ..g }] {
            let det = find_aprilgrid(&img, &other, &AprilGridParams::default()).unwrap();
            assert!(det.tags.is_empty() && det.ids.is_empty(), "{other:?}: {:?}", det.tags.iter().map(|m| m.id).collect::<Vec<_>>());
        }
        // seen from behind (mirrored)
        let mirrored = Camera::facing(&g, size, 900.0, (0.0, 0.0, 0.45), (0.1, 0.1, 0.1), false);
        let img = render(&g, &mirrored, size, 8);
        let det = find_aprilgrid(&img, &g, &AprilGridParams::default()).unwrap();
        let s = score(&det, &g, &mirrored);
        eprintln!("mirrored: {} tags, {} corners", det.tags.len(), s.found);
        assert!(det.tags.is_empty() && det.ids.is_empty(), "{:?}", det.tags.iter().map(|m| m.id).collect::<Vec<_>>());
    }
}
