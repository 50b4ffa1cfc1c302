//! Every pixel of the GPU renderer against the exact box filter (issue 14, item 1).
//!
//! Randomised planar scenes (seeded, so a failure reproduces): chessboards and dot grids rolled in
//! all four quadrants, tilted up to 70 degrees about any in-plane axis, squares and dots of 6 to
//! 200 px, distortion on and off, boards cut by the image border. Each GPU render before
//! quantisation is compared, pixel by pixel, with `scene::exact::render_exact_planar` (polygon
//! clipping of exact 1/8-pixel footprints, written apart from the shader). Gate: max |diff|
//! <= 0.25 grey levels on every pixel (the issue asks 0.5), reported per coverage path (what
//! crosses the pixel). Before the exact paths: 14.6 grey levels at rolled X-junctions.

use nalgebra::{Isometry3, Point2, Translation3, UnitQuaternion, Vector2, Vector3};
use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;
use synthcam::camera::{CameraModel, Distortion, ImageSize, Intrinsics};
use synthcam::scene::exact::{plane_point, render_exact_planar};
use synthcam::scene::{RenderSettings, Scene};
use synthcam::target::{Chessboard, DotGrid, Target};

use crate::common::renderer;

/// The gate is 0.5 grey levels; measured max 0.08 on lavapipe (LLVM 15), so 0.25 leaves
/// room for other LLVM versions' f32 rounding while still catching any coverage-path error.
const GATE: f64 = 0.25;
const SUBDIVISIONS: u32 = 8;

/// A camera whose whole image stays well inside the lens model's fold (the renderer and the
/// reference treat rays beyond it alike, as background, but not pixels straddling it).
pub(crate) fn random_camera(rng: &mut ChaCha8Rng, w: u32, h: u32) -> CameraModel {
    loop {
        let f = rng.random_range(250.0..700.0);
        let distorted = rng.random_bool(0.6);
        let dist = if distorted {
            [rng.random_range(-0.3..0.15), rng.random_range(-0.05..0.1), rng.random_range(-0.003..0.003), rng.random_range(-0.003..0.003), 0.0]
        } else {
            [0.0; 5]
        };
        let skew = if rng.random_bool(0.2) { rng.random_range(-2.0..2.0) } else { 0.0 };
        let cam = CameraModel {
            size: ImageSize { width: w, height: h },
            intrinsics: Intrinsics {
                fx: f,
                fy: f * rng.random_range(0.98..1.02),
                cx: 0.5 * f64::from(w) - 0.5 + rng.random_range(-8.0..8.0),
                cy: 0.5 * f64::from(h) - 0.5 + rng.random_range(-8.0..8.0),
                skew,
            },
            lens: synthcam::camera::Lens::OpenCv(Distortion::from_array(dist)),
        };
        let r_max = cam.lens.max_radius().unwrap_or(f64::INFINITY);
        let corners = [(-1.0, -1.0), (f64::from(w), -1.0), (-1.0, f64::from(h)), (f64::from(w), f64::from(h))];
        let inside = corners.iter().all(|&(x, y)| cam.unproject(&Point2::new(x, y)).is_ok_and(|d| d.xy().norm() < 0.9 * r_max));
        if inside {
            return cam;
        }
    }
}

/// Target rolled by any angle, tilted up to 70 degrees about a random in-plane axis, its centre
/// at a random image point (boards may leave the image) at the distance that gives `feature_px`.
pub(crate) fn random_pose(rng: &mut ChaCha8Rng, cam: &CameraModel, feature_m: f64, feature_px: f64, centre_m: Vector3<f64>) -> Isometry3<f64> {
    let f = cam.intrinsics.fx;
    let distance = f * feature_m / feature_px;
    let roll = UnitQuaternion::from_axis_angle(&Vector3::z_axis(), rng.random_range(-std::f64::consts::PI..std::f64::consts::PI));
    let phi: f64 = rng.random_range(0.0..std::f64::consts::PI);
    let axis = nalgebra::Unit::new_normalize(Vector3::new(phi.cos(), phi.sin(), 0.0));
    let tilt = UnitQuaternion::from_axis_angle(&axis, rng.random_range(0f64..70.0).to_radians());
    let rot = tilt * roll;
    let (w, h) = (f64::from(cam.size.width), f64::from(cam.size.height));
    let aim = Vector3::new(rng.random_range(-0.6..0.6) * w / f, rng.random_range(-0.6..0.6) * h / f, 1.0) * distance;
    Isometry3::from_parts(Translation3::from(aim - rot * centre_m), rot)
}

fn random_scene(rng: &mut ChaCha8Rng, chessboard: bool) -> Scene {
    let (w, h) = if rng.random_bool(0.25) { (480, 360) } else { (320, 256) };
    let camera = random_camera(rng, w, h);
    let feature_px = (rng.random_range(6f64.ln()..200f64.ln())).exp();
    let dark = rng.random_range(0.0..80.0);
    let light = rng.random_range(170.0..255.0);
    let background = rng.random_range(0.0..255.0);
    let (target, feature_m, centre) = if chessboard {
        let s = rng.random_range(0.01..0.08);
        let squares = [rng.random_range(3..13), rng.random_range(3..11)];
        let b = Chessboard {
            warp_m: [0.0; 2],
            squares,
            square_m: s,
            margin_m: s * rng.random_range(0.0..1.0),
            dark,
            light,
            margin: rng.random_range(100.0..255.0),
            background,
        };
        let c = Vector3::new(0.5 * s * f64::from(squares[0]), 0.5 * s * f64::from(squares[1]), 0.0);
        (Target::Chessboard(b), s, c)
    } else {
        let n = rng.random_range(2..8);
        let edge = rng.random_range(0.1..0.5);
        let pitch = edge / f64::from(n - 1);
        let r = pitch * rng.random_range(0.1..0.45);
        let g = DotGrid { n, edge_m: edge, dot_radius_m: r, margin_m: r + pitch * rng.random_range(0.0..0.5), dark, light, background };
        (Target::DotGrid(g), 2.0 * r, Vector3::zeros())
    };
    // The target's centre is `distance` in front of the camera, so the scene validates.
    let pose = random_pose(rng, &camera, feature_m, feature_px, centre);
    Scene { camera, target, cam_from_target: pose, render: RenderSettings::default(), objects: Vec::new(), background: None }
}

/// What crosses pixel (x, y): the coverage path the renderer takes there.
#[derive(Debug, Clone, Copy, PartialEq, Eq, PartialOrd, Ord)]
enum Path {
    Flat,
    SquareEdge,
    XJunction,
    MarginOrBackgroundEdge,
    SeveralEdges,
    DiscEdge,
    PlateEdge,
}

fn classify(scene: &Scene, x: f64, y: f64) -> Path {
    let pts: Vec<Vector2<f64>> =
        [(-0.5, -0.5), (0.5, -0.5), (0.5, 0.5), (-0.5, 0.5)].iter().filter_map(|(dx, dy)| plane_point(scene, Point2::new(x + dx, y + dy)).flatten()).collect();
    if pts.len() < 4 {
        return Path::Flat;
    }
    let lo = pts.iter().fold(pts[0], |a, p| a.inf(p));
    let hi = pts.iter().fold(pts[0], |a, p| a.sup(p));
    let crosses = |v: f64, a: f64, b: f64| a <= v && v <= b;
    match &scene.target {
        Target::Chessboard(b) => {
            let s = b.square_m;
            let lines = |lo: f64, hi: f64, n: u32| (0..=n).filter(|i| crosses(f64::from(*i) * s, lo, hi)).count();
            let nx = lines(lo.x, hi.x, b.squares[0]);
            let ny = lines(lo.y, hi.y, b.squares[1]);
            let (wm, hm) = (s * f64::from(b.squares[0]) + b.margin_m, s * f64::from(b.squares[1]) + b.margin_m);
            let outer = usize::from(crosses(-b.margin_m, lo.x, hi.x) || crosses(wm, lo.x, hi.x) || crosses(-b.margin_m, lo.y, hi.y) || crosses(hm, lo.y, hi.y));
            match (nx, ny, outer) {
                (0, 0, 0) => Path::Flat,
                (1, 0, 0) | (0, 1, 0) => Path::SquareEdge,
                (1, 1, 0) => Path::XJunction,
                (_, _, 1) if nx + ny == 0 => Path::MarginOrBackgroundEdge,
                _ => Path::SeveralEdges,
            }
        }
        Target::DotGrid(g) => {
            let half = 0.5 * g.edge_m;
            let outer = half + g.margin_m;
            if crosses(-outer, lo.x, hi.x) || crosses(outer, lo.x, hi.x) || crosses(-outer, lo.y, hi.y) || crosses(outer, lo.y, hi.y) {
                return Path::PlateEdge;
            }
            let near = g.dot_centres_m().iter().any(|c| {
                let d: Vec<f64> = pts.iter().map(|p| (p - c.xy().coords).norm()).collect();
                let (dmin, dmax) = d.iter().fold((f64::INFINITY, 0.0f64), |(a, b), v| (a.min(*v), b.max(*v)));
                // The nearest point of the footprint may be inside its corners' hull: use the bbox.
                let inside_box = c.x >= lo.x && c.x <= hi.x && c.y >= lo.y && c.y <= hi.y;
                (dmin <= g.dot_radius_m || inside_box) && dmax >= g.dot_radius_m
            });
            if near {
                Path::DiscEdge
            } else {
                Path::Flat
            }
        }
        Target::SPath(_) | Target::Charuco(_) | Target::AprilGrid(_) => Path::Flat,
    }
}

#[derive(Default)]
struct Stats {
    pixels: usize,
    max: f64,
    sum: f64,
}

#[test]
fn every_pixel_matches_the_exact_box_filter() {
    let mut rng = ChaCha8Rng::seed_from_u64(14);
    let mut per_path: std::collections::BTreeMap<Path, Stats> = Default::default();
    let mut worst = (0.0, String::new());
    let (mut scenes, mut pixels, mut undefined) = (0, 0usize, 0usize);
    for k in 0..40 {
        let chess = k % 2 == 0;
        let scene = random_scene(&mut rng, chess);
        let gpu = renderer().render_linear(&scene).expect("render");
        let exact = render_exact_planar(&scene, SUBDIVISIONS).expect("exact");
        let w = scene.camera.size.width as usize;
        let mut scene_max = 0.0f64;
        for (i, (g, e)) in gpu.iter().zip(&exact).enumerate() {
            let Some(e) = e else {
                undefined += 1;
                continue;
            };
            let d = (f64::from(*g) - e).abs();
            pixels += 1;
            let (x, y) = ((i % w) as f64, (i / w) as f64);
            let path = classify(&scene, x, y);
            let st = per_path.entry(path).or_default();
            st.pixels += 1;
            st.max = st.max.max(d);
            st.sum += d;
            scene_max = scene_max.max(d);
            if d > worst.0 {
                worst = (d, format!("scene {k} ({}) pixel ({x}, {y}): gpu {g:.3} exact {e:.3}, {path:?}", scene.target.kind_name()));
            }
        }
        scenes += 1;
        eprintln!("scene {k:2} {:9} {}x{} max |diff| {scene_max:.3}", scene.target.kind_name(), w, scene.camera.size.height);
    }
    eprintln!("{scenes} scenes, {pixels} pixels compared ({undefined} beyond the lens fold skipped)");
    for (path, st) in &per_path {
        eprintln!("  {path:?}: {} pixels, max |diff| {:.4}, mean {:.5}", st.pixels, st.max, st.sum / st.pixels.max(1) as f64);
    }
    eprintln!("worst: {:.4} grey levels at {}", worst.0, worst.1);
    assert!(undefined * 100 < pixels, "too many pixels beyond the fold: {undefined}");
    assert!(worst.0 <= GATE, "max |diff| {:.4} > {GATE}: {}", worst.0, worst.1);
}

#[test]
fn exact_reference_has_converged() {
    // The reference's only approximation is a uniform image-to-plane density within each
    // sub-square (its error falls as 1 / subdivisions); 8 (the property test's) vs 16
    // subdivisions must agree far inside the gate. Scenes 16 (chessboard) and 25 (dot grid) of
    // the property test: the ones with its largest differences.
    let mut rng = ChaCha8Rng::seed_from_u64(14);
    let scenes: Vec<Scene> = (0..26).map(|k| random_scene(&mut rng, k % 2 == 0)).collect();
    for k in [16, 25] {
        // The central 160 x 128 window (the principal point moves with the crop).
        let mut scene = scenes[k].clone();
        let (w, h) = (scene.camera.size.width, scene.camera.size.height);
        scene.camera.size = ImageSize { width: 160, height: 128 };
        scene.camera.intrinsics.cx -= f64::from((w - 160) / 2);
        scene.camera.intrinsics.cy -= f64::from((h - 128) / 2);
        let a = render_exact_planar(&scene, SUBDIVISIONS).expect("exact");
        let b = render_exact_planar(&scene, 2 * SUBDIVISIONS).expect("exact");
        let max = a.iter().zip(&b).filter_map(|(x, y)| Some((x.as_ref()? - y.as_ref()?).abs())).fold(0.0, f64::max);
        eprintln!("scene {k} ({}): {SUBDIVISIONS} vs {} subdivisions max |diff| {max:.2e} grey levels", scenes[k].target.kind_name(), 2 * SUBDIVISIONS);
        assert!(max < 0.02, "{max}");
    }
}

/// The S-path course scene at 320 x 256 (as the golden image), beads or painted discs, optionally
/// turned about the sphere's centre and seen through k1.
fn s_path_scene(style: &str, turn_deg: [f64; 2], k1: f64) -> Scene {
    let text = include_str!("../../assets/scenes/course_s_path.toml").replace("style = \"bead\"", &format!("style = \"{style}\""));
    let mut s = synthcam::scene::file::parse_scene(&text).expect("scene");
    let k = s.camera.intrinsics;
    let scale = 0.25;
    s.camera = CameraModel {
        size: ImageSize { width: 320, height: 256 },
        intrinsics: Intrinsics { fx: k.fx * scale, fy: k.fy * scale, cx: (k.cx + 0.5) * scale - 0.5, cy: (k.cy + 0.5) * scale - 0.5, skew: 0.0 },
        lens: synthcam::camera::Lens::OpenCv(Distortion::from_array([k1, 0.0, 0.0, 0.0, 0.0])),
    };
    // Turn the target about its sphere's centre (target frame (0, 0, 0.5)).
    let c = nalgebra::Point3::new(0.0, 0.0, 0.5);
    let turn = UnitQuaternion::from_euler_angles(turn_deg[0].to_radians(), 0.0, turn_deg[1].to_radians());
    let about = Isometry3::from_parts(Translation3::from(c.coords), turn) * Isometry3::from_parts(Translation3::from(-c.coords), UnitQuaternion::identity());
    s.cam_from_target *= about;
    s.render.samples = 16;
    s
}

/// The S-path against `scene::scanline` (converged scan-line integration of exact rays, written
/// apart from the shader): every pixel of five 320 x 256 views (course pose, turned, k1 -0.1),
/// gated at 0.5 grey levels per pixel as the planar targets. Before the fine pass's adaptive
/// integration across lines, its samples in dot and outline chords and its loop budget (and the
/// reference's own adaptive rows): discs 0.48-2.0, beads 2.3-2.9 grey levels, 0-98 pixels over 0.5
/// per view.
#[test]
fn s_path_pixels_against_the_scanline_reference() {
    use synthcam::scene::scanline::{render_scanline_reference, ScanlineParams};
    let scenes =
        [("bead", [0.0, 0.0], 0.0), ("disc", [0.0, 0.0], 0.0), ("bead", [12.0, -15.0], -0.1), ("disc", [-10.0, 20.0], -0.1), ("disc", [25.0, 10.0], 0.0)];
    let mut worst: (f64, String) = (0.0, String::new());
    for (style, turn, k1) in scenes {
        let scene = s_path_scene(style, turn, k1);
        let gpu = renderer().render_linear(&scene).expect("render");
        let t0 = std::time::Instant::now();
        let reference = render_scanline_reference(&scene, &ScanlineParams::default()).expect("reference");
        let (mut flat, mut edge) = (0.0f64, 0.0f64);
        let (mut over_half, mut over_one, mut over_three, mut n_edge) = (0, 0, 0, 0);
        let w = scene.camera.size.width as usize;
        for (i, (g, r)) in gpu.iter().zip(&reference.values).enumerate() {
            let d = (f64::from(*g) - r).abs();
            if reference.integrated[i] {
                n_edge += 1;
                edge = edge.max(d);
                over_half += usize::from(d > 0.5);
                over_one += usize::from(d > 1.0);
                over_three += usize::from(d > 3.0);
            } else {
                flat = flat.max(d);
            }
            if d > worst.0 {
                worst = (d, format!("{style} turn {turn:?} k1 {k1}: pixel ({}, {}) gpu {g:.2} reference {r:.2}", i % w, i / w));
            }
        }
        assert!(edge <= 0.5, "{style} {turn:?} k1 {k1}: max {edge}, {over_half} pixels > 0.5");
        assert_eq!(flat, 0.0, "a flat pixel differs");
        eprintln!(
            "s-path {style} turn {turn:?} k1 {k1}: {n_edge} edge pixels (reference {:.1} s, {} unconverged): max |diff| {edge:.2}, > 0.5: {over_half}, > 1: {over_one}, > 3: {over_three}; flat max {flat:.3}",
            t0.elapsed().as_secs_f64(),
            reference.unconverged
        );
    }
    eprintln!("worst: {:.2} at {}", worst.0, worst.1);
}

/// The course's beads at full size (1280 x 1024, k1 -0.1, course pose and turned) against the
/// scan-line reference: their rims and outlines in closed form (`shaders/s_path.wgsl` `bead_rim_agrees`,
/// `bead_beside_rim`) as exact
/// as the fine pass's scan lines were (measured before and after: max 0.449 / 0.368 grey levels,
/// 99th percentile 0.022, 44 676 / 42 479 edge pixels). 64 s: on demand,
/// `cargo test --release --test e2e -- --ignored s_path_beads_at_full_size`.
#[test]
#[ignore = "64 s; run on demand"]
fn s_path_beads_at_full_size_against_the_scanline_reference() {
    use synthcam::scene::scanline::{render_scanline_reference, ScanlineParams};
    for turn in [[0.0, 0.0], [12.0, -15.0]] {
        let mut scene = s_path_scene("bead", turn, -0.1);
        let full = synthcam::scene::file::parse_scene(include_str!("../../assets/scenes/course_s_path.toml")).expect("scene");
        scene.camera = CameraModel { lens: scene.camera.lens, ..full.camera };
        let gpu = renderer().render_linear(&scene).expect("render");
        let reference = render_scanline_reference(&scene, &ScanlineParams::default()).expect("reference");
        let mut d: Vec<f64> =
            gpu.iter().zip(&reference.values).zip(&reference.integrated).filter(|(_, i)| **i).map(|((g, r), _)| (f64::from(*g) - r).abs()).collect();
        d.sort_by(f64::total_cmp);
        eprintln!(
            "full-size beads {turn:?}: {} edge pixels, max {:.3}, p99 {:.3}, > 0.5: {}",
            d.len(),
            d[d.len() - 1],
            d[d.len() * 99 / 100],
            d.iter().filter(|v| **v > 0.5).count()
        );
        assert!(d[d.len() - 1] <= 0.5, "{turn:?}: {}", d[d.len() - 1]);
    }
}
