//! Camera effects with exact truth (issue 18): rolling shutter, motion blur and defocus rendered
//! by the shader's views, each checked against an independent computation.

use nalgebra::{Isometry3, Point2, Point3, Translation3, UnitQuaternion, Vector3};
use synthcam::camera::optics::ThinLens;
use synthcam::detect::{find_chessboard, ChessboardParams, ImageF32};
use synthcam::scene::file::parse_scene;
use synthcam::scene::motion::Motion;
use synthcam::scene::truth::truth_labels;
use synthcam::scene::Scene;
use synthcam::target::{Chessboard, Target};

use crate::chessboard_accuracy::{nn_errors, rms};
use crate::common::{camera, renderer};

fn rolling_scene(twist: [f64; 6]) -> Scene {
    let mut s = parse_scene(include_str!("../../assets/scenes/chessboard_k1.toml")).expect("scene");
    s.render.effects.motion = Motion { twist, line_delay_s: 30e-6, ..Motion::default() };
    s
}

/// The row-time fixed point by brute force: g(v) = v(pose(t(v))) - v sampled every 0.01 row
/// over the image, each sign change bisected to 1e-12 row.
fn brute_force_rs(scene: &Scene, p: &Point3<f64>) -> Option<Point2<f64>> {
    let m = &scene.render.effects.motion;
    let h = scene.camera.size.height;
    let at = |v: f64| scene.camera.project(&(m.cam_from_target_at(&scene.cam_from_target, m.row_time_s(v, h)) * p)).pixel_px;
    let g = |v: f64| at(v).y - v;
    let mut v = -0.5;
    while v < f64::from(h) {
        let (a, b) = (v, v + 0.01);
        if g(a).signum() != g(b).signum() {
            let (mut lo, mut hi) = (a, b);
            for _ in 0..100 {
                let mid = 0.5 * (lo + hi);
                if g(mid).signum() == g(lo).signum() {
                    lo = mid;
                } else {
                    hi = mid;
                }
            }
            return Some(at(0.5 * (lo + hi)));
        }
        v = b;
    }
    None
}

#[test]
fn rolling_shutter_truth_matches_a_brute_force_row_search() {
    for readout in [synthcam::scene::motion::Readout::TopDown, synthcam::scene::motion::Readout::BottomUp] {
        let mut scene = rolling_scene([0.2, 0.5, -0.3, 0.3, -0.1, 0.05]);
        scene.render.effects.motion.readout = readout;
        let truth = truth_labels(&scene);
        let mut worst: f64 = 0.0;
        for f in &truth.features {
            let rs = f.effects.rolling_shutter_px.expect("rolling-shutter truth");
            let bf = brute_force_rs(&scene, &Point3::from(f.point_target_m)).expect("a root");
            worst = worst.max((Point2::from(rs) - bf).norm());
        }
        eprintln!("rolling shutter {readout:?}: truth vs brute-force row search, max {worst:.2e} px over {} corners", truth.features.len());
        assert!(worst < 1e-6, "max {worst}");
    }
}

pub fn detect(img: &synthcam::render::GreyImage, grid: [usize; 2]) -> Vec<Point2<f64>> {
    let (w, h) = img.dimensions();
    let img = ImageF32::from_u8(w as usize, h as usize, &img.to_u8()).expect("image");
    find_chessboard(&img, &ChessboardParams::new(grid[0], grid[1])).expect("valid").expect("board found").points_px
}

#[test]
fn rolling_shutter_corners_match_the_row_time_truth() {
    let still = rolling_scene([0.0; 6]);
    let plain = parse_scene(include_str!("../../assets/scenes/chessboard_k1.toml")).expect("scene");
    let (img_still, img_plain) = (renderer().render(&still).expect("render"), renderer().render(&plain).expect("render"));
    assert_eq!(img_still, img_plain, "a still scene under a rolling shutter is the global-shutter image");
    let ideal: Vec<Point2<f64>> = truth_labels(&plain).features.iter().map(|f| Point2::from(f.pixel_px)).collect();
    let e_plain = rms(&nn_errors(&detect(&img_plain, [11, 8]), &ideal));
    let moving = rolling_scene([0.0, 0.3, 0.0, 0.2, 0.0, 0.0]);
    let img = renderer().render(&moving).expect("render");
    let truth = truth_labels(&moving);
    let rs: Vec<Point2<f64>> = truth.features.iter().map(|f| Point2::from(f.effects.rolling_shutter_px.expect("rs"))).collect();
    let found = detect(&img, [11, 8]);
    let (e_rs, e_ideal) = (nn_errors(&found, &rs), nn_errors(&found, &ideal));
    let shift = rs.iter().zip(&ideal).map(|(a, b)| (a - b).norm()).fold(0.0, f64::max);
    eprintln!(
        "rolling shutter (30 us/row, 0.3 rad/s + 0.2 m/s): corners vs row-time truth RMS {:.4} px, max {:.4} px; vs the ideal projection RMS {:.3} px (truth moves up to {shift:.2} px); still scene RMS {e_plain:.4} px",
        rms(&e_rs),
        e_rs.iter().cloned().fold(0.0, f64::max),
        rms(&e_ideal)
    );
    assert!(rms(&e_rs) <= 0.03, "RMS {}", rms(&e_rs));
    let worst = e_rs.iter().cloned().fold(0.0, f64::max);
    assert!(worst <= 0.05, "max {worst}");
    assert!(rms(&e_ideal) > 1.0, "the motion should move the corners");
}

/// A fronto-parallel 80-px-square board 1 m in front of a 640 x 480 pinhole, f = 800 px.
fn fronto_scene() -> Scene {
    let board = Chessboard { squares: [8, 6], square_m: 0.1, margin_m: 0.05, ..Default::default() };
    let t = Vector3::new(-0.4, -0.3, 1.0);
    let mut s = Scene {
        camera: camera(640, 480, 800.0, [0.0; 5]),
        target: Target::Chessboard(board),
        cam_from_target: Isometry3::from_parts(Translation3::from(t), UnitQuaternion::identity()),
        render: Default::default(),
        objects: Vec::new(),
        background: None,
    };
    s.camera.intrinsics.cx = 320.0;
    s.camera.intrinsics.cy = 240.0;
    s
}

/// Integral of clamp(u, 0, 1) from 0 to u.
fn ramp_integral(u: f64) -> f64 {
    if u <= 0.0 {
        0.0
    } else if u <= 1.0 {
        0.5 * u * u
    } else {
        u - 0.5
    }
}

#[test]
fn motion_blurred_edges_match_the_analytic_integral() {
    let mut scene = fronto_scene();
    // 1 m/s along camera x at Z = 1 m, f = 800 px, 10 ms: the image moves 8 px left.
    scene.render.effects.motion = Motion { twist: [0.0, 0.0, 0.0, 1.0, 0.0, 0.0], exposure_s: 0.01, ..Motion::default() };
    let img = renderer().render_linear(&scene).expect("render");
    let len = 8.0;
    let (dark, light) = (scene.target.plane_intensity(0.01, 0.01).expect("dark"), scene.target.plane_intensity(0.11, 0.01).expect("light"));
    let mut worst: f64 = 0.0;
    let mut n = 0;
    for row in [280usize, 360] {
        for k in 1..8 {
            // Board line x = 0.1 k at t = 0 images at u = 800 (0.1 k - 0.4) + 320; it sweeps
            // [u - 4, u + 4] during the exposure.
            let e0 = 800.0 * (0.1 * f64::from(k) - 0.4) + 320.0;
            let board_y = (row as f64 - 240.0) / 800.0 + 0.3;
            let left = scene.target.plane_intensity(0.1 * f64::from(k) - 0.05, board_y).expect("left");
            let right = if (left - dark).abs() < 1e-9 { light } else { dark };
            for x in (e0 - 8.0) as usize..=(e0 + 8.0) as usize {
                let u = x as f64 + 0.5;
                let frac_right = (ramp_integral(u - (e0 - 0.5 * len)) - ramp_integral(u - (e0 + 0.5 * len))) / len;
                let expect = left + (right - left) * frac_right;
                worst = worst.max((f64::from(img[row * 640 + x]) - expect).abs());
                n += 1;
            }
        }
    }
    eprintln!("motion blur (8 px over the exposure): rendered edge profile vs the analytic integral, max |diff| {worst:.3} grey levels over {n} pixels");
    assert!(worst <= 0.5, "max {worst}");
}

/// The edge spread of the board line x = `x_m` between board y `y0` and `y1`, slanted-edge style
/// (ISO 12233): every pixel near the edge's image, by its signed distance from the line, makes a
/// densely sampled edge-spread function; its Stieltjes second moment, less the pixel box's 1/12,
/// is the line-spread variance; a disc of radius r has r^2 / 4.
fn edge_spread_radius_px(scene: &Scene, img: &[f32], x_m: f64, (y0, y1): (f64, f64), reach_px: f64) -> f64 {
    let (w, h) = (scene.camera.size.width as usize, scene.camera.size.height as usize);
    let px = |y: f64| scene.camera.project(&(scene.cam_from_target * Point3::new(x_m, y, 0.0))).pixel_px;
    let (a, b) = (px(y0), px(y1));
    let along = (b - a).normalize();
    let normal = Vector3::new(-along.y, along.x, 0.0).xy();
    let len = (b - a).norm();
    let mut samples: Vec<(f64, f64)> = Vec::new();
    for y in 0..h {
        for x in 0..w {
            let q = Point2::new(x as f64, y as f64) - a;
            let (t, d) = (q.dot(&along), q.dot(&normal));
            if t > reach_px && t < len - reach_px && d.abs() <= reach_px {
                samples.push((d, f64::from(img[y * w + x])));
            }
        }
    }
    samples.sort_by(|p, q| p.0.total_cmp(&q.0));
    let (lo, hi) = (samples[0].1, samples[samples.len() - 1].1);
    // Cumulative distribution F(d) of the line spread, from the edge levels; Stieltjes sums.
    let f: Vec<f64> = samples.iter().map(|s| (s.1 - lo) / (hi - lo)).collect();
    let steps: Vec<(f64, f64)> = samples.windows(2).zip(f.windows(2)).map(|(s, f)| (0.5 * (s[0].0 + s[1].0), f[1] - f[0])).collect();
    let mass: f64 = steps.iter().map(|s| s.1).sum();
    let mean = steps.iter().map(|s| s.0 * s.1).sum::<f64>() / mass;
    let var = steps.iter().map(|s| (s.0 - mean).powi(2) * s.1).sum::<f64>() / mass;
    2.0 * (var - 1.0 / 12.0).max(0.0).sqrt()
}

#[test]
fn defocused_edges_spread_as_the_thin_lens_circle_of_confusion() {
    let lens = ThinLens { f_number: 2.0, focal_length_m: 0.016, focus_distance_m: 1.2, aperture_samples: 16 };
    let board = Chessboard { squares: [12, 9], square_m: 0.05, margin_m: 0.025, ..Default::default() };
    // Tilted 50 degrees about y (depth changes along x), rolled 4 degrees about the optical axis
    // (depth along each board line x = const stays constant; the slant sweeps the pixel phase).
    let rot = UnitQuaternion::from_axis_angle(&Vector3::z_axis(), 4f64.to_radians()) * UnitQuaternion::from_axis_angle(&Vector3::y_axis(), 50f64.to_radians());
    let centre = Vector3::new(0.3, 0.225, 0.0);
    let mut scene = Scene {
        camera: camera(1280, 1024, 1500.0, [0.0; 5]),
        target: Target::Chessboard(board),
        cam_from_target: Isometry3::from_parts(Translation3::from(Vector3::new(0.0, 0.0, 0.85) - rot * centre), rot),
        render: Default::default(),
        objects: Vec::new(),
        background: None,
    };
    scene.render.effects.optics.thin_lens = Some(lens);
    let img = renderer().render_linear(&scene).expect("render");
    let truth = truth_labels(&scene);
    let mut worst: f64 = 0.0;
    for k in 1..12 {
        let x_m = 0.05 * f64::from(k);
        let z = (scene.cam_from_target * Point3::new(x_m, 0.225, 0.0)).z;
        let r = lens.coc_radius_px(1500.0, z);
        // The truth's circle of confusion of the corner on this line agrees.
        let corner = truth.features.iter().find(|f| (f.point_target_m[0] - x_m).abs() < 1e-9).expect("corner");
        let zc = (scene.cam_from_target * Point3::from(corner.point_target_m)).z;
        assert!((corner.effects.coc_radius_px.expect("coc") - lens.coc_radius_px(1500.0, zc)).abs() < 1e-12);
        let measured = edge_spread_radius_px(&scene, &img, x_m, (0.2, 0.25), r + 4.0);
        let rel = measured / r - 1.0;
        eprintln!(
            "defocus: edge x = {x_m:.2} m at z {z:.3} m: thin-lens circle of confusion {r:.3} px, from the edge spread {measured:.3} px ({:+.2} %)",
            100.0 * rel
        );
        worst = worst.max(rel.abs());
    }
    eprintln!("defocus: worst relative error of the edge-spread radius vs the thin-lens CoC {:.2} %", 100.0 * worst);
    assert!(worst <= 0.05, "worst {worst}");
}

/// The mean of sharp renders, one per view, each an ordinary scene: a motion view is the scene at
/// its time; a defocus view of a distortion-free camera is a pinhole at the aperture point `a`
/// with the principal point moved by `f a / F` (the ray through the focus plane, in the shifted
/// camera's normalised coordinates `x - a / F`).
fn mean_of_sharp_views(scene: &Scene) -> Vec<f64> {
    let set = synthcam::scene::views::view_set(scene);
    assert!(!set.per_row);
    let mut acc = vec![0.0f64; (scene.camera.size.width * scene.camera.size.height) as usize];
    for v in &set.views {
        let mut s = scene.clone();
        s.render.effects = Default::default();
        s.cam_from_target = v.cam_from_target;
        if let Some(f) = v.focus_m {
            let [ax, ay] = v.aperture_m;
            s.cam_from_target = Isometry3::translation(-ax, -ay, 0.0) * v.cam_from_target;
            s.camera.intrinsics.cx += s.camera.intrinsics.fx * ax / f;
            s.camera.intrinsics.cy += s.camera.intrinsics.fy * ay / f;
        }
        let img = renderer().render_linear(&s).expect("render");
        acc.iter_mut().zip(&img).for_each(|(a, v)| *a += f64::from(*v) / set.views.len() as f64);
    }
    acc
}

#[test]
fn views_renders_equal_the_mean_of_their_sharp_views() {
    for (name, motion, lens) in [
        ("motion blur", Motion { twist: [0.2, -0.4, 0.3, 0.6, 0.2, 0.0], exposure_s: 0.01, time_samples: 12, ..Motion::default() }, None),
        ("defocus", Motion::default(), Some(ThinLens { f_number: 1.4, focal_length_m: 0.016, focus_distance_m: 0.5, aperture_samples: 16 })),
        (
            "both",
            Motion { twist: [0.0, 0.0, 0.5, 0.3, 0.0, 0.0], exposure_s: 0.005, time_samples: 6, ..Motion::default() },
            Some(ThinLens { f_number: 2.0, focal_length_m: 0.016, focus_distance_m: 0.9, aperture_samples: 12 }),
        ),
    ] {
        let mut scene = parse_scene(include_str!("../../assets/scenes/charuco_k1.toml")).expect("scene");
        scene.camera = camera(480, 384, 560.0, [0.0; 5]);
        scene.render.effects.motion = motion;
        scene.render.effects.optics.thin_lens = lens;
        let img = renderer().render_linear(&scene).expect("render");
        let reference = mean_of_sharp_views(&scene);
        let d: Vec<f64> = img.iter().zip(&reference).map(|(a, b)| (f64::from(*a) - b).abs()).collect();
        let max = d.iter().cloned().fold(0.0, f64::max);
        let changed = img
            .iter()
            .zip(&renderer().render_linear(&Scene { render: Default::default(), ..scene.clone() }).expect("sharp"))
            .filter(|(a, b)| (**a - **b).abs() > 1.0)
            .count();
        eprintln!(
            "{name}: views render vs the mean of {} sharp renders: max |diff| {max:.4} grey levels ({changed} pixels differ from the sharp image by > 1 grey)",
            synthcam::scene::views::view_set(&scene).views.len()
        );
        assert!(max < 0.02, "{name}: {max}");
        assert!(changed > 1000, "{name}: the effect should change the image");
    }
}
