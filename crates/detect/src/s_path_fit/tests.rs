//! Tests of `s_path_fit`.

use super::*;
use nalgebra::{Isometry3, Translation3, UnitQuaternion, Vector3};
use synthcam_core::target::spherical_s;

/// The course S-path seen from the course's desired pose (f = 1500 px, 1280 x 1024).
pub(super) fn projected() -> (SPath, Vec<Option<Point2<f64>>>) {
    let path = spherical_s();
    let r = nalgebra::Rotation3::from_matrix_unchecked(nalgebra::Matrix3::new(0.0, -1.0, 0.0, 0.0, 0.0, 1.0, -1.0, 0.0, 0.0));
    let cam_from_world = Isometry3::from_parts(Translation3::new(0.0, -0.55, 1.8), UnitQuaternion::from_rotation_matrix(&r));
    let pts = path
        .points_m
        .iter()
        .map(|x| {
            let c = cam_from_world * x;
            (c.z > 0.0).then(|| Point2::new(640.0 + 1500.0 * c.x / c.z, 512.0 + 1500.0 * c.y / c.z))
        })
        .collect();
    (path, pts)
}

pub(super) fn dot(p: Point2<f64>, area: f64) -> Dot {
    Dot { centre_px: p, area_px: area, spread_px: 0.5 * (area / std::f64::consts::PI).sqrt(), core_px: 4, contrast: 200.0, touching: false }
}

#[test]
fn dlt_recovers_a_projection() {
    let (path, pts) = projected();
    let world: Vec<Point3<f64>> = path.points_m[..30].to_vec();
    let image: Vec<Point2<f64>> = pts[..30].iter().map(|p| p.unwrap()).collect();
    let dlt = Dlt::fit(&world, &image, None).unwrap();
    assert!(dlt.rms(&world, &image) < 1e-6);
    let q = dlt.project(&path.points_m[80]).unwrap();
    assert!((q - pts[80].unwrap()).norm() < 1e-4, "{q}");
    // The camera centre: world (1.8, 0, 0.55).
    let c = dlt.centre().unwrap();
    assert!((c - Point3::new(1.8, 0.0, 0.55)).norm() < 1e-6, "{c}");
}

#[test]
fn path_residuals_find_the_dot_that_strays() {
    // Every visible dot at its projection, dot 50 moved 3 px across the path: its residual is
    // the 3 px (the fit spreads a little of it), its deviation 3 px over the local scale.
    let (path, pts) = projected();
    let mut ordered: Vec<IndexedDot> = pts.iter().enumerate().filter_map(|(i, p)| p.map(|c| IndexedDot { index: i, centre_px: c })).collect();
    let k = ordered.iter().position(|d| d.index == 50).unwrap();
    ordered[k].centre_px += nalgebra::Vector2::new(0.0, 3.0);
    let r = path_residuals(&ordered, &path).unwrap();
    assert!((r[k].residual_px.norm() - 3.0).abs() < 0.15, "{:?}", r[k]);
    let others = r.iter().enumerate().filter(|(m, _)| *m != k).map(|(_, p)| p.residual_px.norm()).fold(0.0, f64::max);
    assert!(others < 0.3, "{others}");
    let scale = (pts[51].unwrap() - pts[50].unwrap()).norm() / (path.points_m[51] - path.points_m[50]).norm();
    assert!((r[k].deviation_m * scale / 3.0 - 1.0).abs() < 0.2, "{} m at {scale} px/m", r[k].deviation_m);
}

#[test]
fn indexes_the_path_without_its_start_and_across_a_gap() {
    // Start hidden (dots 0-7 gone), a gap of five (40-44), shuffled.
    let (path, pts) = projected();
    let mut dots: Vec<Dot> = (0..101).filter(|i| *i >= 8 && !(40..45).contains(i)).map(|i| dot(pts[i].unwrap(), 30.0)).collect();
    dots.reverse();
    dots.swap(5, 50);
    let out = index_s_path(&dots, &path, &SPathFitParams::default()).unwrap();
    let idx: Vec<usize> = out.iter().map(|d| d.index).collect();
    assert_eq!(idx, (8..101).filter(|i| !(40..45).contains(i)).collect::<Vec<_>>());
    for d in &out {
        assert!((d.centre_px - pts[d.index].unwrap()).norm() < 1e-9);
    }
}

/// The course view with every dot moved on the sphere by up to `dev_m` (uniform in a disc,
/// seeded), the start dot 10/6 times larger in radius than the others.
pub(super) fn jittered(dev_m: f64, seed: u64) -> (SPath, Vec<Dot>, Vec<Point2<f64>>) {
    use rand::{Rng, SeedableRng};
    let (path, _) = projected();
    let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(seed);
    let r = nalgebra::Rotation3::from_matrix_unchecked(nalgebra::Matrix3::new(0.0, -1.0, 0.0, 0.0, 0.0, 1.0, -1.0, 0.0, 0.0));
    let cam_from_world = Isometry3::from_parts(Translation3::new(0.0, -0.55, 1.8), UnitQuaternion::from_rotation_matrix(&r));
    let mut image = Vec::new();
    for (i, x) in path.points_m.iter().enumerate() {
        let n = path.normal_at(i);
        let t1 = n.cross(&Vector3::z()).normalize();
        let t2 = n.cross(&t1);
        let (rad, ang) = (dev_m * rng.random::<f64>().sqrt(), rng.random_range(0.0..std::f64::consts::TAU));
        let c = cam_from_world * (x + t1 * rad * ang.cos() + t2 * rad * ang.sin());
        image.push(Point2::new(640.0 + 1500.0 * c.x / c.z, 512.0 + 1500.0 * c.y / c.z));
    }
    let dots = image.iter().enumerate().map(|(i, p)| dot(*p, if i == 0 { 30.0 * (10.0f64 / 6.0).powi(2) } else { 30.0 })).collect();
    (path, dots, image)
}

#[test]
fn dots_straying_from_the_nominal_path_keep_their_indices() {
    // 2 mm (about 1.7 px here, 8 % of the dot spacing): every seed fully and rightly indexed.
    for seed in 0..10 {
        let (path, dots, image) = jittered(0.002, seed);
        let out = index_s_path(&dots, &path, &SPathFitParams::default()).unwrap_or_else(|e| panic!("seed {seed}: {e}"));
        assert_eq!(out.len(), 101, "seed {seed}");
        for d in &out {
            assert!((d.centre_px - image[d.index]).norm() < 1e-9, "seed {seed}: index {}", d.index);
        }
    }
    // 5 mm (a fifth of the spacing, issue 14): found with ChainGrowth::Strays after the strict
    // chain fails, every dot rightly indexed. With the start dot no larger than the rest (no
    // start chain: the chains label each other) most seeds are found, and with the first 25 dots
    // hidden none is (a lone chain shifted by one index fits almost as well: 3.6 against 3.0 px);
    // neither is ever mis-indexed.
    let mut plain_found = 0;
    for seed in 0..10 {
        let (path, dots, image) = jittered(0.005, seed);
        let right = |out: &[IndexedDot]| out.iter().all(|d| (d.centre_px - image[d.index]).norm() < 1e-9);
        let out = index_s_path(&dots, &path, &SPathFitParams::default()).unwrap_or_else(|e| panic!("5 mm, seed {seed}: {e}"));
        assert!(out.len() == 101 && right(&out), "5 mm, seed {seed}: {} dots, mis-indexed: {}", out.len(), !right(&out));
        let plain: Vec<Dot> = dots.iter().map(|d| Dot { area_px: 30.0, ..*d }).collect();
        for (case, dots) in [("no start dot", plain), ("25 hidden", dots[25..].to_vec())] {
            if let Ok(out) = index_s_path(&dots, &path, &SPathFitParams::default()) {
                assert!(right(&out), "5 mm, {case}, seed {seed}: a dot mis-indexed");
                plain_found += usize::from(case == "no start dot" && out.len() == 101);
            }
        }
    }
    assert!(plain_found >= 8, "5 mm, no start dot: {plain_found} of 10 found");
}

#[test]
fn clutter_is_not_a_path() {
    let (path, _) = projected();
    // A closed ring of 60 dots: the S has an inflection, no view of it closes up. (A shorter
    // circular arc is no test: parts of the S are circular arcs, and a DLT maps a circle to
    // any ellipse, so an arc of evenly spaced dots is a possible view of them.)
    let ring: Vec<Dot> = (0..60)
        .map(|i| {
            let a = f64::from(i) * std::f64::consts::TAU / 60.0;
            dot(Point2::new(500.0 + 150.0 * a.cos(), 400.0 + 150.0 * a.sin()), 30.0)
        })
        .collect();
    assert!(index_s_path(&ring, &path, &SPathFitParams::default()).is_err());
    // Scattered dots.
    let mut state = 12345u64;
    let mut next = || {
        state = state.wrapping_mul(6364136223846793005).wrapping_add(1442695040888963407);
        (state >> 11) as f64 / (1u64 << 53) as f64
    };
    let scatter: Vec<Dot> = (0..80).map(|_| dot(Point2::new(1280.0 * next(), 1024.0 * next()), 30.0)).collect();
    assert!(index_s_path(&scatter, &path, &SPathFitParams::default()).is_err());
}

#[test]
fn a_stretch_after_a_gap_is_not_placed_one_index_off() {
    // 5 mm strays, no start dot, a few dots missing (too thin to detect near the outline): a
    // chain that bridged a stray step wrongly just after the gap shifts only the stretch
    // between the gap and that step. Any labelling found must index every dot rightly.
    let (mut found, mut wrong) = (0, Vec::new());
    for seed in 0..20 {
        let (path, dots, image) = jittered(0.005, seed);
        for gap in [(26, 31), (60, 64)] {
            let kept: Vec<(usize, Dot)> =
                dots.iter().copied().enumerate().filter(|(i, _)| !(gap.0..gap.1).contains(i)).map(|(i, d)| (i, Dot { area_px: 30.0, ..d })).collect();
            let plain: Vec<Dot> = kept.iter().map(|k| k.1).collect();
            if let Ok(out) = index_s_path(&plain, &path, &SPathFitParams::default()) {
                found += 1;
                let off = out.iter().filter(|d| (d.centre_px - image[d.index]).norm() > 1e-9).count();
                if off > 0 {
                    wrong.push((seed, gap, off));
                }
            }
        }
    }
    // Before the stretches were moved apart from each other, 2 of the 36 found were mis-indexed.
    assert!(wrong.is_empty(), "mis-indexed (seed, gap, dots): {wrong:?}; {found} of 40 found");
    assert!(found >= 30, "{found} of 40 found");
}

#[test]
fn a_start_chain_joins_only_up_to_its_first_contradiction() {
    // The start chain (dots 10..14 at indices 0..4) miscounted after index 1: dot 12 is at
    // index 3 by the other labels, so its entries from index 2 on are one index off; dot 14's
    // index 4 is contradicted by nothing, yet it must not join.
    let anchor = vec![(3, 13), (0, 10), (2, 12), (1, 11), (4, 14)];
    let labels = vec![(3, 12), (5, 20), (6, 21)];
    assert_eq!(anchor::agreeing_prefix(anchor, &labels), vec![(0, 10), (1, 11)]);
    assert_eq!(anchor::agreeing_prefix(vec![(1, 11), (0, 10)], &labels), vec![(0, 10), (1, 11)]);
}

#[test]
fn a_blob_holding_two_dots_is_placed_but_not_reported() {
    // Dots along a line, spread 2 px (the start dot 10/6 of that); dots 0 and 1 seen as one blob
    // (index 1 unplaced, spread 1.4 times the start dot's): listed as unmeasured. The same
    // spread with its neighbour placed, or a single start dot, is reported.
    let at = |i: usize, spread: f64| Dot { spread_px: spread, ..dot(Point2::new(100.0 + 20.0 * i as f64, 50.0), 30.0) };
    let run = |skip: &[usize], start_spread: f64| {
        let dots: Vec<Dot> = (0..12).map(|i| at(i, if i == 0 { start_spread } else { 2.0 })).collect();
        let ordered: Vec<IndexedDot> = (0..12).filter(|i| !skip.contains(i)).map(|i| IndexedDot { index: i, centre_px: dots[i].centre_px }).collect();
        unmeasured(ordered, &dots)
    };
    let merged = 1.4 * START_RADIUS_RATIO * 2.0;
    let (kept, out) = run(&[1], merged);
    assert_eq!((kept.len(), out), (10, vec![0]));
    assert_eq!(run(&[], merged).1, Vec::<usize>::new());
    assert_eq!(run(&[1], START_RADIUS_RATIO * 2.0).1, Vec::<usize>::new());
    // A blob of two 6 mm dots in the middle of the path.
    let mut dots: Vec<Dot> = (0..12).map(|i| at(i, 2.0)).collect();
    dots[6].spread_px = 2.0 * 1.5;
    let ordered: Vec<IndexedDot> = (0..12).filter(|&i| i != 7).map(|i| IndexedDot { index: i, centre_px: dots[i].centre_px }).collect();
    assert_eq!(unmeasured(ordered, &dots).1, vec![6]);
}

#[test]
fn a_dot_stepped_over_takes_its_index_and_moves_the_stretch_up() {
    // Dots 10 px apart on a line; the labelling stepped from dot 2 to dot 4 as one step, so dots
    // 4..6 sit at indices 3..5 and dot 3 is unplaced between dots 2 and 4.
    let dots: Vec<Dot> = (0..7).map(|i| dot(Point2::new(100.0 + 10.0 * i as f64, 50.0 + 0.3 * i as f64), 30.0)).collect();
    let low = vec![(0, 0), (1, 1), (2, 2), (3, 4), (4, 5), (5, 6)];
    let right: Labels = (0..7).map(|i| (i, i)).collect();
    assert_eq!(skipped::insert_skipped(&dots, low.clone(), 101), right);
    // No index left for the stretch to move into: unchanged.
    assert_eq!(skipped::insert_skipped(&dots, low.clone(), 6), low);
    // A dot far off to the side (a detour of 1.56 times the step), or too small, is not between them.
    let mut aside = dots.clone();
    aside[3].centre_px.y += 12.0;
    assert_eq!(skipped::insert_skipped(&aside, low.clone(), 101), low);
    let mut tiny = dots.clone();
    tiny[3].area_px = 5.0;
    assert_eq!(skipped::insert_skipped(&tiny, low.clone(), 101), low);
    // The right labels stay.
    assert_eq!(skipped::insert_skipped(&dots, right.clone(), 101), right);
}

#[test]
fn a_chain_that_counted_one_stray_step_as_two_is_labelled_rightly() {
    // 5 mm strays, dots 3..100 (start hidden), the chain's step after dot 40 counted as two:
    // every placement of the chain as grown is one index off on one side (issue 14, held-out
    // views: 4.3 against 4.4 px for the best two). Its open steps decided per placement, the
    // right labelling wins clearly.
    let params = SPathFitParams::default();
    for seed in 0..5 {
        let (path, dots, _) = jittered(0.005, seed);
        let chain: Vec<(i64, usize)> = (3..101).map(|i| (i as i64 + i64::from(i > 40), i)).collect();
        let right: Labels = (3..101).map(|i| (i, i)).collect();
        let got = label_chain(&chain, &dots, &path, &params, true, &[], true);
        assert_eq!(got.as_ref(), Some(&right), "seed {seed}");
    }
}

#[test]
fn a_start_chain_miscounted_beyond_its_first_steps_still_rules() {
    // The whole path in one chain (5 mm strays); the start chain beside it (indices 0..19)
    // counted one step too many after index 11. Its first entries agree with the right
    // labelling only: that one is found (before, every labelling contradicted the anchor).
    let params = SPathFitParams::default();
    for seed in 0..5 {
        let (path, dots, _) = jittered(0.005, seed);
        let chain: Vec<(i64, usize)> = (0..101).map(|i| (i as i64 - 50, 100 - i)).collect();
        let anchor: Labels = (0..20).map(|i| (i + usize::from(i > 11), i)).collect();
        let right: Labels = (0..101).map(|i| (i, i)).collect();
        assert_eq!(label_chain(&chain, &dots, &path, &params, true, &anchor, true), Some(right), "seed {seed}");
        // An anchor contradicting the right labelling from its first entry rules it out.
        let shifted: Labels = (0..20).map(|i| (i + 1, i)).collect();
        assert_eq!(label_chain(&chain, &dots, &path, &params, true, &shifted, true), None, "seed {seed}");
    }
}

#[test]
fn the_two_pieces_of_a_split_sliver_hold_one_index() {
    // Dots 20 px apart on a line; dot 5 seen as two touching pieces 3.8 px apart (its middle too
    // light to join them), labelled 5 and 6, so dots 6..9 sit at indices 7..10.
    let mut dots: Vec<Dot> = (0..10).map(|i| dot(Point2::new(100.0 + 20.0 * i as f64, 50.0), 30.0)).collect();
    dots[5] = Dot { centre_px: Point2::new(198.1, 50.0), touching: true, ..dots[5] };
    dots.push(Dot { centre_px: Point2::new(201.9, 50.0), touching: true, ..dots[5] });
    let high: Labels = (0..5).map(|i| (i, i)).chain([(5, 5), (6, 10)]).chain((6..10).map(|i| (i + 1, i))).collect();
    let right: Labels = (0..10).map(|i| (i, i)).collect();
    assert_eq!(skipped::join_split(&dots, high.clone()), right);
    // Pieces that do not touch, or two dots 0.33 steps apart (strays at the outline), keep theirs.
    let mut apart = dots.clone();
    apart[10].touching = false;
    assert_eq!(skipped::join_split(&apart, high.clone()), high);
    let mut far = dots.clone();
    far[10].centre_px.x = 198.1 + 6.6;
    assert_eq!(skipped::join_split(&far, high.clone()), high);
    assert_eq!(skipped::join_split(&dots, right.clone()), right);
}

#[test]
fn dots_straying_by_seven_mm_are_never_mis_indexed() {
    // 7 mm (27 % of the 25.7 mm spacing, issue 37), within the default tolerated deviation
    // (7.5 mm): the assignment places every dot where the start dot tells the placements apart,
    // and never one at a wrong index; without a larger start dot a placement is only reported
    // where no shift of it explains the dots nearly as well.
    let mut placed = (0, 0);
    for seed in 0..10 {
        let (path, dots, image) = jittered(0.007, seed);
        let right = |out: &[IndexedDot]| out.iter().all(|d| (d.centre_px - image[d.index]).norm() < 1e-9);
        let out = index_s_path(&dots, &path, &SPathFitParams::default()).unwrap_or_default();
        assert!(right(&out), "7 mm, seed {seed}: a dot mis-indexed");
        placed.0 += usize::from(out.len() >= 100);
        let plain: Vec<Dot> = dots.iter().map(|d| Dot { area_px: 30.0, ..*d }).collect();
        if let Ok(out) = index_s_path(&plain, &path, &SPathFitParams::default()) {
            assert!(right(&out), "7 mm, no start dot, seed {seed}: a dot mis-indexed");
            placed.1 += out.len();
        }
    }
    // Measured: 8 of 10 views placed whole (seeds 2 and 6 refused: no seed reaches the right
    // placement); 807 of 1010 dots without a start dot.
    assert!(placed.0 >= 8, "7 mm: {} of 10 views placed", placed.0);
    assert!(placed.1 >= 600, "7 mm, no start dot: {} of 1010 dots placed", placed.1);
}

#[test]
fn a_seed_one_index_off_is_corrected_not_reported() {
    // The assignment of a seed shifted by one along the path has its own shifts as rivals: the
    // right labelling (a shift of the seed) wins, on nominal dots and on 7 mm strays alike.
    for (dev, seed) in [(0.0, 0), (0.007, 1), (0.007, 2)] {
        let (path, dots, image) = jittered(dev, seed);
        let truth: Labels = (0..101).map(|i| (i, i)).collect();
        let off = assign::shift(&truth, 1, path.len());
        let params = SPathFitParams::default();
        let (labels, _) =
            assign::best_assignment(&dots, &path, &[off], &params, start::StartDot::Breaks(0)).unwrap_or_else(|| panic!("{dev} m, seed {seed}: refused"));
        assert!(labels.iter().all(|&(i, j)| (dots[j].centre_px - image[i]).norm() < 1e-9), "{dev} m, seed {seed}: mis-indexed");
        assert!(labels.len() >= 100, "{dev} m, seed {seed}: {} placed", labels.len());
    }
}

#[test]
fn a_known_camera_places_seven_mm_strays_a_projective_camera_cannot_tell_apart() {
    // Dots 0-39 hidden (no start dot, no end of the path in view), every dot up to 7 mm off its
    // point: a projective camera (11 degrees of freedom) fits the placements shifted along the
    // path nearly as well and refuses most views; the camera's pose (6) tells them apart.
    let camera = synthcam_core::camera::CameraModel::sxga_1500px();
    let (mut projective, mut calibrated) = (0, 0);
    for seed in 0..10 {
        let (path, dots, image) = jittered(0.007, 100 + seed);
        let part: Vec<Dot> = dots[40..].to_vec();
        let right = |out: &[IndexedDot]| out.iter().all(|d| (d.centre_px - image[d.index]).norm() < 1e-9);
        let plain = index_s_path(&part, &path, &SPathFitParams::default()).unwrap_or_default();
        let known = index_s_path(&part, &path, &SPathFitParams { camera: Some(camera), ..SPathFitParams::default() }).unwrap_or_default();
        assert!(right(&plain) && right(&known), "seed {seed}: a dot mis-indexed");
        projective += plain.len();
        calibrated += known.len();
    }
    // Measured: projective 53, calibrated 610 of 610 (these seeds were the development set of
    // the known-camera placement; renders of other seeds are measured in BENCHMARKS.md).
    assert!(calibrated >= 600 && projective < 300, "projective {projective}, calibrated {calibrated} of 610");
}

#[test]
fn a_stretch_its_own_shape_places_elsewhere_is_left_out() {
    // Two stretches of nominal dots (0-30, 60-80); the second labelled one index off, as a single
    // camera extrapolated through a lens it cannot model would: its dots are left out, the rest
    // kept; labelled rightly, nothing is left out.
    let (path, pts) = projected();
    let idx: Vec<usize> = (0..=30).chain(60..=80).collect();
    let dots: Vec<Dot> = idx.iter().map(|&i| dot(pts[i].unwrap(), if i == 0 { 83.0 } else { 30.0 })).collect();
    let right: Labels = idx.iter().enumerate().map(|(j, &i)| (i, j)).collect();
    let off: Labels = right.iter().map(|&(i, j)| (if i >= 60 { i + 1 } else { i }, j)).collect();
    let params = SPathFitParams::default();
    let order = SPathOrderParams { points: path.len(), ..params.order };
    assert_eq!(checks::drop_contradicted(&dots, &path, right.clone(), &params, &order), right);
    let kept = checks::drop_contradicted(&dots, &path, off, &params, &order);
    assert_eq!(kept, right.iter().copied().filter(|&(i, _)| i <= 30).collect::<Labels>());
}

#[test]
fn turning_a_windows_pose_about_its_chord_reaches_more_of_the_view() {
    // A window of 15 dots (43-57, the S's straightest stretch: 32 mm from its chord) straying up
    // to 7 mm under its right labels: the pose fitted to it alone is loose (about the chord
    // most), and the matches its camera grows to (`seeds::consensus`) hold fewer right dots than
    // those grown from its best turn.
    let camera = synthcam_core::camera::CameraModel::sxga_1500px();
    let params = SPathFitParams { camera: Some(camera), ..SPathFitParams::default() };
    let (mut fitted, mut swept) = (0, 0);
    for seed in 0..10 {
        let (path, dots, _) = jittered(0.007, 200 + seed);
        let window: Labels = (43..58).map(|i| (i, i)).collect();
        let plain = seeds::consensus(&dots, &path, &window, &params).unwrap_or_default();
        let turned = sweep::best_turns(&[(0.0, window)], &dots, &path, &camera.intrinsics, params.match_fraction, 1);
        let turned = turned.first().and_then(|l| seeds::consensus(&dots, &path, l, &params)).unwrap_or_default();
        let right = |l: &Labels| l.iter().filter(|&&(i, j)| i == j).count();
        eprintln!("seed {seed}: fitted {} ({} right), turned {} ({} right)", plain.len(), right(&plain), turned.len(), right(&turned));
        fitted += right(&plain);
        swept += right(&turned);
    }
    assert!(swept > fitted, "right dots grown from the fitted pose {fitted}, from the turned {swept} of 1010");
}
