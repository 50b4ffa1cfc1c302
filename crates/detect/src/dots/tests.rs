//! Tests of `dots`.

use super::super::image::area_sampled;
use super::*;

/// Area-sampled dark disc at (cx, cy), radius r, on a light surround.
fn disc(w: usize, h: usize, cx: f64, cy: f64, r: f64) -> ImageF32 {
    area_sampled(w, h, 16, |u, v| if (u - cx).hypot(v - cy) < r { 20.0 } else { 225.0 })
}

#[test]
fn finds_disc_centre() {
    for (cx, cy, r) in [(20.0, 20.0, 5.0), (20.3, 19.7, 2.0), (19.55, 20.45, 1.5)] {
        let img = disc(40, 40, cx, cy, r);
        let dots = find_dots(&img, &DotParams::default()).unwrap();
        assert_eq!(dots.len(), 1, "r {r}");
        let c = dots[0].centre_px;
        // The coverage-weighted centroid of a sampled disc is within ~0.01 px of its centre.
        assert!((c.x - cx).abs() < 0.01 && (c.y - cy).abs() < 0.01, "{c} vs ({cx}, {cy})");
    }
}

/// A bead (level 20, radius 4.5) at `bead` next to the outline of a 450-px sphere (225) on
/// the background (90), in front of the sphere or behind it (hidden where they overlap),
/// area-sampled; with the exact centroid of the bead's visible part.
fn bead_at_outline(bead: [f64; 2], in_front: bool) -> (ImageF32, [f64; 2]) {
    let sphere = [50.3 + 450.0, 47.8];
    let on_bead = |u: f64, v: f64| (u - bead[0]).hypot(v - bead[1]) < 4.5 && (in_front || (u - sphere[0]).hypot(v - sphere[1]) >= 450.0);
    let img = area_sampled(96, 96, 16, |u, v| {
        if on_bead(u, v) {
            20.0
        } else if (u - sphere[0]).hypot(v - sphere[1]) < 450.0 {
            225.0
        } else {
            90.0
        }
    });
    // The exact centroid of the visible part: the bead's coverage of each pixel, weighted.
    let cov = area_sampled(96, 96, 16, |u, v| f64::from(u8::from(on_bead(u, v))));
    let (mut a, mut su, mut sv) = (0.0, 0.0, 0.0);
    for (k, c) in cov.data.iter().enumerate() {
        let c = f64::from(*c);
        a += c;
        su += c * (k % 96) as f64;
        sv += c * (k / 96) as f64;
    }
    (img, [su / a, sv / a])
}

#[test]
fn beads_in_front_of_and_behind_the_outline() {
    // The outline runs near x = 50.3; beads straddle it.
    for (bead, in_front) in [([49.6, 47.2], true), ([51.7, 45.4], false), ([52.4, 47.9], false), ([48.1, 46.6], true)] {
        let (img, truth) = bead_at_outline(bead, in_front);
        let dots = find_dots(&img, &DotParams::default()).unwrap();
        assert_eq!(dots.len(), 1, "{bead:?} in front {in_front}");
        let err = (dots[0].centre_px - Point2::from(truth)).norm();
        // The plain darkness against the closing is off by tenths of a pixel here.
        assert!(err < 0.02, "{bead:?} in front {in_front}: {} vs {truth:?}: {err}", dots[0].centre_px);
    }
}

#[test]
fn blank_and_tiny_images_have_no_dots() {
    assert!(find_dots(&ImageF32::new(50, 50, vec![128.0; 2500]).unwrap(), &DotParams::default()).unwrap().is_empty());
    assert!(find_dots(&ImageF32::new(1, 1, vec![0.0]).unwrap(), &DotParams::default()).unwrap().is_empty());
    assert!(find_dots(&ImageF32 { width: 5, height: 5, data: vec![] }, &DotParams::default()).is_err());
}

#[test]
fn a_thin_sliver_broken_by_the_threshold_is_one_dot() {
    // Ellipses 12 px long and 1.0 to 1.4 px wide, turned 6 or 10 degrees from the rows: the
    // threshold leaves pieces along the staircase up to two pixels apart (a cap seen 83 degrees
    // from its normal near the S-path sphere's outline). Symmetric: the centroid is the centre.
    // Before pieces two pixels apart were joined, 4 of these 5 gave two dots.
    for (half_width_px, deg) in [(0.5, 6.0), (0.6, 6.0), (0.7, 6.0), (0.6, 10.0), (0.7, 10.0)] {
        for (cx, cy) in [(20.0, 15.0), (20.3, 15.4), (19.6, 14.8), (20.15, 15.25)] {
            let (c, s) = (f64::cos(f64::to_radians(deg)), f64::sin(f64::to_radians(deg)));
            let img = area_sampled(40, 30, 16, |u, v| {
                let (a, b) = ((u - cx) * c + (v - cy) * s, -(u - cx) * s + (v - cy) * c);
                if (a / 6.0).powi(2) + (b / half_width_px).powi(2) < 1.0 {
                    20.0
                } else {
                    225.0
                }
            });
            let dots = find_dots(&img, &DotParams::default()).unwrap();
            assert_eq!(dots.len(), 1, "{half_width_px} px, {deg} deg, at ({cx}, {cy}): {dots:?}");
            let e = dots[0].centre_px - Point2::new(cx, cy);
            assert!(e.norm() < 0.05, "{half_width_px} px, {deg} deg, at ({cx}, {cy}): off by {e}");
        }
    }
}

/// Dark ellipses (level 20 on 225) 12 px long, `(cx, cy, half_width_px)` each, their long axes
/// along `deg` from the rows, area-sampled.
fn slivers(w: usize, h: usize, deg: f64, at: &[(f64, f64, f64)]) -> ImageF32 {
    let (c, s) = (f64::cos(f64::to_radians(deg)), f64::sin(f64::to_radians(deg)));
    area_sampled(w, h, 16, |u, v| {
        let inside = at.iter().any(|&(cx, cy, hw)| {
            let (a, b) = ((u - cx) * c + (v - cy) * s, -(u - cx) * s + (v - cy) * c);
            (a / 6.0).powi(2) + (b / hw).powi(2) < 1.0
        });
        if inside {
            20.0
        } else {
            225.0
        }
    })
}

#[test]
fn a_faint_sliver_beyond_the_rim_does_not_pull_its_neighbour() {
    // Two slivers in a line, 1.5 px of clean surround between their ends; the second so thin
    // (0.6 px) that no pixel of it is dark enough for a core of its own. Its head lies one
    // pixel beyond the first's rim: counted with the first, it pulled it by 0.1 px (a cap 84
    // degrees from its normal on the S-path sphere, 0.16 px).
    for deg in [-60.0, -35.0, 20.0, 55.0, 120.0] {
        let (c, s) = (f64::cos(f64::to_radians(deg)), f64::sin(f64::to_radians(deg)));
        let (cx, cy) = (24.3, 23.6);
        let img = slivers(50, 50, deg, &[(cx, cy, 0.8), (cx + 13.5 * c, cy + 13.5 * s, 0.3)]);
        let dots = find_dots(&img, &DotParams::default()).unwrap();
        let first = dots.iter().find(|d| (d.centre_px - Point2::new(cx, cy)).norm() < 1.0).unwrap_or_else(|| panic!("{deg} deg: {dots:?}"));
        let e = (first.centre_px - Point2::new(cx, cy)).norm();
        assert!(e < 0.03 && !first.touching, "{deg} deg: off by {e} px, {first:?}");
    }
}

#[test]
fn slivers_meeting_end_to_end_are_marked_touching() {
    // Ends overlapping by half a pixel: the image does not say where one ends. Apart by 4 px:
    // two clean measurements.
    for (gap_px, touching) in [(-0.5, true), (0.0, true), (4.0, false)] {
        for deg in [-35.0, 20.0, 55.0] {
            let (c, s) = (f64::cos(f64::to_radians(deg)), f64::sin(f64::to_radians(deg)));
            let d = 12.0 + gap_px;
            let (cx, cy) = (22.3, 21.6);
            let img = slivers(50, 50, deg, &[(cx, cy, 0.7), (cx + d * c, cy + d * s, 0.7)]);
            let dots = find_dots(&img, &DotParams::default()).unwrap();
            assert!(!dots.is_empty(), "gap {gap_px}, {deg} deg");
            assert!(dots.iter().all(|d| d.touching == touching), "gap {gap_px}, {deg} deg: {dots:?}");
            if !touching {
                assert_eq!(dots.len(), 2);
                for q in [Point2::new(cx, cy), Point2::new(cx + d * c, cy + d * s)] {
                    assert!(dots.iter().any(|p| (p.centre_px - q).norm() < 0.05), "gap {gap_px}, {deg} deg: {q} not in {dots:?}");
                }
            }
        }
    }
}

#[test]
fn the_spread_of_a_disc_is_half_its_radius() {
    // A uniform disc of radius r has variance r^2 / 4 along any axis; the area sampling adds a
    // pixel's 1/12.
    for (cx, cy, r) in [(20.0, 20.0, 5.0), (20.3, 19.7, 3.0), (19.55, 20.45, 8.0)] {
        let dots = find_dots(&disc(40, 40, cx, cy, r), &DotParams::default()).unwrap();
        let expected = (r * r / 4.0 + 1.0 / 12.0).sqrt();
        assert!((dots[0].spread_px / expected - 1.0).abs() < 0.01, "r {r}: {} vs {expected}", dots[0].spread_px);
    }
}

/// Paint (20) on a 450-px sphere (225; background 90) whose outline passes through (48, 48) with
/// its inward normal at `normal_deg` from the x axis: a sliver (an ellipse `across` x 7 px, along
/// the outline, centred `inside` px in from it) cut by the outline, and a disc far from it;
/// area-sampled, with the sliver's exact centroid.
fn sliver_at_outline(normal_deg: f64, inside: f64, across: f64) -> (ImageF32, Point2<f64>) {
    let n = [normal_deg.to_radians().cos(), normal_deg.to_radians().sin()];
    let sphere = [48.0 + 450.0 * n[0], 48.0 + 450.0 * n[1]];
    let on_sphere = |u: f64, v: f64| (u - sphere[0]).hypot(v - sphere[1]) < 450.0;
    let c = [48.0 + inside * n[0], 48.0 + inside * n[1]];
    let on_sliver = |u: f64, v: f64| {
        let (du, dv) = (u - c[0], v - c[1]);
        let (a, b) = (du * n[0] + dv * n[1], -du * n[1] + dv * n[0]);
        (a / across).powi(2) + (b / 7.0).powi(2) < 1.0 && on_sphere(u, v)
    };
    let on_disc = |u: f64, v: f64| (u - 48.0 - 25.0 * n[0]).hypot(v - 48.0 - 25.0 * n[1]) < 4.0;
    let img = area_sampled(96, 96, 16, |u, v| match (on_sliver(u, v) || on_disc(u, v), on_sphere(u, v)) {
        (true, _) => 20.0,
        (false, true) => 225.0,
        (false, false) => 90.0,
    });
    let cov = area_sampled(96, 96, 16, |u, v| f64::from(u8::from(on_sliver(u, v))));
    let (mut a, mut cu, mut cv) = (0.0, 0.0, 0.0);
    for (k, w) in cov.data.iter().enumerate() {
        let w = f64::from(*w);
        (a, cu, cv) = (a + w, cu + w * (k % 96) as f64, cv + w * (k / 96) as f64);
    }
    (img, Point2::new(cu / a, cv / a))
}

#[test]
fn a_painted_sliver_on_the_outline_is_weighed_as_paint() {
    // A sliver 1.2 px across cut by the outline (0.8 px of it on the sphere): no pixel wholly
    // dark, its darkest far lighter than the paint, and the bright share of pixels on the outline
    // nearly all painted. Weighed as an occluder (its own darkest pixel taken for the paint level,
    // the paint bound missed) the centre was 0.13 px off at both angles; the disc's level decides.
    for deg in [40.0, -140.0] {
        let (img, truth) = sliver_at_outline(deg, 0.2, 0.6);
        let dots = find_dots(&img, &DotParams::default()).unwrap();
        let err = dots.iter().map(|d| (d.centre_px - truth).norm()).fold(f64::INFINITY, f64::min);
        assert!(err < 0.01, "normal at {deg} deg: {err} px ({} dots)", dots.len());
    }
}

#[test]
fn a_sliver_ending_in_a_neighbours_grown_core_keeps_its_end() {
    // A sliver 16 x 1.4 px whose tapering end lies 1 px from a wider neighbour's: the end's
    // pixels are nearer the neighbour's core, which owns them. Before the sliver's region could
    // take them (no clearly dark pixel of the neighbour beside them) its centre was 0.076 px off.
    let a = |u: f64, v: f64| ((u - 40.0) / 8.0).powi(2) + ((v - 48.3) / 0.7).powi(2) < 1.0;
    let b = |u: f64, v: f64| ((u - 54.0) / 5.0).powi(2) + ((v - 48.6) / 1.2).powi(2) < 1.0;
    let img = area_sampled(96, 96, 16, |u, v| if a(u, v) || b(u, v) { 20.0 } else { 225.0 });
    let cov = area_sampled(96, 96, 16, |u, v| f64::from(u8::from(a(u, v))));
    let (mut s, mut cu, mut cv) = (0.0, 0.0, 0.0);
    for (k, w) in cov.data.iter().enumerate() {
        let w = f64::from(*w);
        (s, cu, cv) = (s + w, cu + w * (k % 96) as f64, cv + w * (k / 96) as f64);
    }
    let truth = Point2::new(cu / s, cv / s);
    let dots = find_dots(&img, &DotParams::default()).unwrap();
    let err = dots.iter().map(|d| (d.centre_px - truth).norm()).fold(f64::INFINITY, f64::min);
    assert!(err < 0.01, "{err} px ({} dots)", dots.len());
}

/// The block-wise core mask (`core_runs`, which skips blocks that cannot hold a core pixel) gives
/// the runs of the per-pixel rule of the module docs, on noisy images with dots, a grey level
/// step and sizes that leave partial blocks.
#[test]
fn core_runs_follow_the_per_pixel_rule() {
    use rand::{Rng, SeedableRng};
    let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(11);
    for (w, h) in [(61, 45), (128, 96), (33, 70)] {
        let mut img = disc(w, h, w as f64 * 0.3, h as f64 * 0.4, 4.0);
        for (i, v) in img.data.iter_mut().enumerate() {
            let step = if i % w > w / 2 { -120.0 } else { 0.0 };
            *v += step + rng.random_range(-30.0..30.0f32);
        }
        let params = DotParams::default();
        let (block_min, block_max) = pool_min_max(&img);
        let r4 = params.window_px.div_ceil(POOL);
        let (lo, hi) = (extreme_filter(&block_min, r4, false), extreme_filter(&block_max, r4, true));
        let pw = lo.width;
        let want = crate::runs::runs_where(w, h, |x, y| {
            let i = (y / POOL) * pw + x / POOL;
            let (l, hh, v) = (lo.data[i], hi.data[i], img.data[y * w + x]);
            hh - l > params.min_contrast && v < l + params.core_fraction * (hh - l)
        });
        let got = core_runs(&img, (&lo, &hi), &block_min, &params);
        assert!(want.len() > 3, "{w} x {h}: the test needs cores");
        assert_eq!(got, want, "{w} x {h}");
    }
}
