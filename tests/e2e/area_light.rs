//! Issue 41 items 1 and 2: a rectangular area light shading a flat board (Lambert's polygon
//! formula in the shader) and the soft shadow a plate casts from it. The reference is this test's
//! own: the irradiance `L int cos_x cos_light / r^2 dA` over the part of the emitter the plate
//! leaves visible, row by row of the emitter with the plate's shadow on each row found
//! analytically (the plate's corners projected from the board point onto the light's plane), and
//! for each pixel the mean over 4 x 4 sub-pixel rays through the lens's exact inverse. Compared on
//! the pixels wholly inside uniform regions of the board (the unlit render one of its grey levels)
//! that see neither the plate nor its outline.

use nalgebra::{Point2, Point3, Vector3};
use synthcam::scene::area_light::{AreaLight, Rectangle};
use synthcam::scene::lighting::{LightFrame, Lighting};
use synthcam::scene::Scene;
use synthcam::target::Target;

use crate::common::renderer;
use crate::shadow::{scene as plate_scene, HALF_M};

/// Emitter rows and points per visible part of a row of the reference integral.
const ROWS: usize = 96;
const POINTS: usize = 24;

/// A 0.1 m square light 0.5 m behind the plate towards the camera, down and to the right in the
/// image, facing the board (camera frame): it lights the board from where `shadow.rs`'s
/// directional light comes.
fn light() -> AreaLight {
    AreaLight { frame: LightFrame::Camera, position_m: [0.23, 0.525, 0.2], rvec: [0.0; 3], size_m: [0.1, 0.1], intensity: 0.5 }
}

fn lit_scene(with_plate: bool) -> Scene {
    let mut s = plate_scene([0.0, 0.0, 1.0]);
    s.render.lighting = Lighting { ambient: Some(0.25), area: Some(light()), ..Default::default() };
    if !with_plate {
        s.objects.clear();
    }
    s
}

/// The plate's corners, camera frame.
fn plate_corners(s: &Scene) -> [Point3<f64>; 4] {
    let pose = s.objects[0].cam_from_object;
    [(-1.0, -1.0), (1.0, -1.0), (1.0, 1.0), (-1.0, 1.0)].map(|(x, y)| pose * Point3::new(x * HALF_M, y * HALF_M, 0.0))
}

/// The interval of the emitter's row `t` (both in the rectangle's `[0, 1]` coordinates) that the
/// plate hides from `x`: its corners projected from `x` onto the light's plane form a convex
/// quadrilateral; `None` when the row misses it or the plate is not between `x` and the light.
fn hidden(rect: &Rectangle, x: &Point3<f64>, plate: &[Point3<f64>; 4], t: f64) -> Option<(f64, f64)> {
    let e = rect.u.cross(&rect.v);
    let mut st = [(0.0, 0.0); 4];
    for (k, p) in plate.iter().enumerate() {
        let lambda = e.dot(&(rect.corner - x)) / e.dot(&(p - x));
        if !(lambda > 1.0) {
            return None;
        }
        let q = x + (p - x) * lambda - rect.corner;
        st[k] = (q.dot(&rect.u) / rect.u.norm_squared(), q.dot(&rect.v) / rect.v.norm_squared());
    }
    let cuts: Vec<f64> = (0..4)
        .filter_map(|k| {
            let (a, b) = (st[k], st[(k + 1) % 4]);
            ((a.1 - t) * (b.1 - t) <= 0.0 && a.1 != b.1).then(|| a.0 + (b.0 - a.0) * (t - a.1) / (b.1 - a.1))
        })
        .collect();
    (!cuts.is_empty()).then(|| (cuts.iter().copied().fold(f64::INFINITY, f64::min), cuts.iter().copied().fold(f64::NEG_INFINITY, f64::max)))
}

/// The irradiance factor `A + L int_visible cos_x cos_light / r^2 dA` at board point `x`
/// (normal `n` on the camera's side).
fn reference(s: &Scene, x: &Point3<f64>, n: &Vector3<f64>) -> f64 {
    let l = light();
    let rect = l.rectangle_in_camera(&s.cam_from_target);
    let e = rect.u.cross(&rect.v).normalize();
    let plate = (!s.objects.is_empty()).then(|| plate_corners(s));
    let w = |sv: f64, tv: f64| {
        let d = rect.at(sv, tv) - x;
        let r2 = d.norm_squared();
        (n.dot(&d) * -e.dot(&d)).max(0.0) / (r2 * r2)
    };
    let midpoint = |t: f64, a: f64, b: f64| (0..POINTS).map(|k| w(a + (b - a) * (k as f64 + 0.5) / POINTS as f64, t)).sum::<f64>() * (b - a) / POINTS as f64;
    let mut integral = 0.0;
    for r in 0..ROWS {
        let t = (r as f64 + 0.5) / ROWS as f64;
        let gap = plate.as_ref().and_then(|p| hidden(&rect, x, p, t)).map(|(a, b)| (a.clamp(0.0, 1.0), b.clamp(0.0, 1.0)));
        integral += match gap {
            Some((a, b)) => midpoint(t, 0.0, a) + midpoint(t, b, 1.0),
            None => midpoint(t, 0.0, 1.0),
        } / ROWS as f64;
    }
    0.25 + l.radiance() * integral * l.size_m[0] * l.size_m[1]
}

/// The board's plane `n . x = c` (camera frame), `n` its normal on the camera's side, worked out
/// from the pose.
fn board_plane(s: &Scene) -> (Vector3<f64>, f64) {
    let z = s.cam_from_target.rotation * Vector3::z();
    let n = if z.dot(&s.cam_from_target.translation.vector) > 0.0 { -z } else { z };
    (n, n.dot(&s.cam_from_target.translation.vector))
}

/// Whether the camera ray `d` passes through the plate enlarged by 2 % (its outline's pixels).
fn near_plate(s: &Scene, d: &Vector3<f64>) -> bool {
    let inv = s.objects[0].cam_from_object.inverse();
    let (o, dir) = (inv * Point3::origin(), inv.rotation * d);
    let t = -o.z / dir.z;
    t > 0.0 && (o.x + t * dir.x).abs() < 1.02 * HALF_M && (o.y + t * dir.y).abs() < 1.02 * HALF_M
}

/// Whether the plate hides any of the light from `x`.
fn shadowed(s: &Scene, x: &Point3<f64>) -> bool {
    let rect = light().rectangle_in_camera(&s.cam_from_target);
    let plate = plate_corners(s);
    (0..ROWS).any(|r| hidden(&rect, x, &plate, (r as f64 + 0.5) / ROWS as f64).is_some_and(|(a, b)| b > 0.0 && a < 1.0))
}

/// Per compared pixel: (reference, rendered, whether the plate hides some of the light from a
/// corner of the pixel), every `stride`-th uniform pixel and every `near`-th where the plate hides
/// some of the light from a corner.
fn compare(s: &Scene, stride: usize, near: usize) -> Vec<(f64, f64, bool, usize)> {
    let unlit_scene = Scene { render: Default::default(), objects: Vec::new(), ..s.clone() };
    let unlit = renderer().render_linear(&unlit_scene).expect("unlit");
    let img = renderer().render_linear(s).expect("lit");
    let Target::Chessboard(b) = &s.target else { unreachable!() };
    let (n, c) = board_plane(s);
    let on_board = |d: &Vector3<f64>| Point3::from(d * (c / n.dot(d)));
    let w = s.camera.size.width as usize;
    let mut out = Vec::new();
    for (k, u) in unlit.iter().enumerate().step_by(near) {
        let u = f64::from(*u);
        if ![b.dark, b.light, b.margin].iter().any(|g| (u - g).abs() < 1e-4) {
            continue;
        }
        let (px, py) = ((k % w) as f64, (k / w) as f64);
        let corners = [(-0.5, -0.5), (0.5, -0.5), (0.5, 0.5), (-0.5, 0.5)].map(|(dx, dy)| s.camera.unproject(&Point2::new(px + dx, py + dy)).expect("ray"));
        let dark = !s.objects.is_empty() && corners.iter().any(|d| shadowed(s, &on_board(d)));
        if (!dark && k % stride != 0) || (!s.objects.is_empty() && corners.iter().any(|d| near_plate(s, d))) {
            continue;
        }
        let factor = (0..16)
            .map(|j| {
                let q = Point2::new(px - 0.375 + 0.25 * f64::from(j % 4), py - 0.375 + 0.25 * f64::from(j / 4));
                reference(s, &on_board(&s.camera.unproject(&q).expect("ray")), &n)
            })
            .sum::<f64>()
            / 16.0;
        out.push((u * factor, f64::from(img[k]), dark, k));
    }
    out
}

fn report(what: &str, rows: &[(f64, f64, bool, usize)]) -> f64 {
    let errs: Vec<f64> = rows.iter().map(|(r, g, ..)| (g - r).abs()).collect();
    let max = errs.iter().copied().fold(0.0, f64::max);
    let rms = (errs.iter().map(|e| e * e).sum::<f64>() / errs.len().max(1) as f64).sqrt();
    eprintln!("{what}: {} pixels, |rendered - reference| RMS {rms:.4}, max {max:.4} grey levels", rows.len());
    max
}

/// Lambert's polygon formula in the shader against the test's integral over the emitter: every
/// 17th pixel wholly inside a region of the board, within the 0.5 grey levels; the
/// shading varies over the board (a lamp 0.8-1.2 m away).
#[test]
fn an_area_light_shades_a_flat_board_as_its_integral_says() {
    let rows = compare(&lit_scene(false), 17, 17);
    let max = report("area light, no objects", &rows);

    let (lo, hi) = rows.iter().map(|(r, ..)| *r).fold((f64::INFINITY, 0.0f64), |(lo, hi), r| (lo.min(r), hi.max(r)));
    assert!(rows.len() > 1000 && max <= 0.5 && hi > 1.5 * lo, "{} pixels, max {max}, levels {lo}..{hi}", rows.len());
}

/// The plate's soft shadow from the area light: every 5th pixel the shadow touches and every
/// 97th elsewhere against the reference, within 0.25 grey levels (half the Lambert bound;
/// measured max 0.135, RMS 0.034; each emitter row's hidden part in closed form, the cells of the
/// soft-shadow lattice interpolated) and 0.06 RMS. The truth's features get the shadowed irradiance of
/// the library's own sampling, within 0.01 of this test's.
#[test]
fn a_plates_soft_shadow_matches_the_integral_over_the_visible_emitter() {
    let s = lit_scene(true);
    if let Ok(path) = std::env::var("SOFT_SHADOW_PNG") {
        let img = renderer().render_linear(&s).expect("render");
        let bytes: Vec<u8> = img.iter().map(|v| v.round().clamp(0.0, 255.0) as u8).collect();
        image::GrayImage::from_raw(1280, 1024, bytes).expect("image").save(path).expect("png");
    }
    let rows = compare(&s, 97, 5);
    let penumbra: Vec<_> = rows.iter().copied().filter(|r| r.2).collect();
    if let Ok(path) = std::env::var("SOFT_SHADOW_ERRORS") {
        std::fs::write(path, penumbra.iter().map(|r| format!("{} {} {}\n", r.3, r.0, r.1)).collect::<String>()).expect("write");
    }
    let max_all = report("soft shadow, whole board", &rows);
    report("soft shadow, penumbra and umbra", &penumbra);
    assert!(penumbra.len() > 500, "the plate's shadow covers many compared pixels: {}", penumbra.len());
    let rms = (penumbra.iter().map(|(r, g, ..)| (g - r) * (g - r)).sum::<f64>() / penumbra.len() as f64).sqrt();
    assert!(max_all <= 0.25 && rms <= 0.06, "soft shadows within 0.25 grey levels (max) and 0.06 (RMS): {max_all}, {rms}");
    let (n, _) = board_plane(&s);
    let truth = synthcam::scene::truth_labels(&s);
    for f in &truth.features {
        let x = s.cam_from_target * Point3::from(f.point_target_m);
        let e = f.irradiance.expect("irradiance");
        assert!((e - reference(&s, &x, &n)).abs() < 0.01, "feature {}: {e} vs {}", f.id, reference(&s, &x, &n));
    }
}

/// The gripper's soft shadow (`assets/scenes/objects/gripper_soft_shadow.toml`: a mesh of many
/// triangles, whose shadow rays walk a deep hierarchy, where llvmpipe's loop budget per
/// invocation could cut the shader's integral short) against the library's own CPU sampling
/// ([`against_cpu_sampling`], every 41st shadowed board pixel). Within 0.5 grey levels and 0.1
/// RMS (measured max 0.155, RMS 0.024 with 16 emitter rows a point; 0.19 / 0.033 with 8; against
/// 48 x 48 cells, before the reference was refined:
/// 0.25 / 0.044 for this renderer, 0.54 / 0.085 for the one that integrated every pixel with
/// sampled rows).
#[test]
fn the_grippers_soft_shadow_matches_the_librarys_sampling() {
    let (errs, deepest) = against_cpu_sampling(&gripper_scene(), 41);
    let (count, worst, rms) = summary("gripper's soft shadow", &errs, deepest);
    assert!(count > 300 && deepest < 0.7, "the shadow covers many pixels, some deeply: {count}, {deepest}");
    assert!(worst <= 0.5 && rms <= 0.1, "within the stated tolerance: max {worst}, RMS {rms}");
}

/// The gripper's soft shadow with the gripper turned up to 0.3 rad about a random axis and moved
/// up to 2 cm, and the light moved up to 4 cm and resized to 5-15 cm a side, from a fresh seed
/// each run (printed; `SYNTHCAM_STRESS_SEED` repeats it): every 97th shadowed board pixel against
/// the library's CPU sampling, the same bounds as the fixed view. Attacks the soft-shadow
/// lattice's checks and the rows' closed form with penumbrae they were not tuned on.
#[test]
fn soft_shadows_hold_under_random_poses_and_lights() {
    random_soft_shadow(crate::common::stress_seed());
}

/// A seed the random test failed on (max 0.65 grey levels, RMS 0.085): an edge of the turned
/// gripper ran along the emitter's rows, where the rule across rows errs by up to half a row's
/// share; with 16 rows a point (64 a pixel and a lattice point) instead of 8 (32): max 0.29,
/// RMS 0.031.
#[test]
fn soft_shadows_hold_where_an_edge_runs_along_the_emitters_rows() {
    random_soft_shadow(1_796_684_115_240_995_042);
}

/// [`soft_shadows_hold_under_random_poses_and_lights`] for `seed`.
fn random_soft_shadow(seed: u64) {
    use nalgebra::{Isometry3, Translation3, UnitQuaternion};
    use rand::{Rng, SeedableRng};
    let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(seed);
    let mut s = gripper_scene();
    let mut r = || rng.random_range(-1.0f64..1.0);
    let axis = Vector3::new(r(), r(), r()).try_normalize(1e-6).unwrap_or_else(Vector3::z);
    let turn = UnitQuaternion::from_axis_angle(&nalgebra::Unit::new_unchecked(axis), 0.3 * r());
    let shift = Translation3::new(0.02 * r(), 0.02 * r(), 0.02 * r());
    let pose = &mut s.objects[0].cam_from_object;
    *pose = Isometry3::from_parts(shift * pose.translation, turn * pose.rotation);
    let light = s.render.lighting.area.as_mut().expect("an area light");
    light.position_m = [light.position_m[0] + 0.04 * r(), light.position_m[1] + 0.04 * r(), light.position_m[2]];
    light.size_m = [0.1 + 0.05 * r(), 0.1 + 0.05 * r()];
    let (errs, deepest) = against_cpu_sampling(&s, 97);
    let (count, worst, rms) = summary(&format!("random soft shadow (seed {seed})"), &errs, deepest);
    assert!(count > 50, "seed {seed}: the shadow falls on the board: {count} pixels");
    assert!(worst <= 0.5 && rms <= 0.1, "seed {seed}: within the stated tolerance: max {worst}, RMS {rms}");
}

fn gripper_scene() -> Scene {
    let meshes = synthcam::dataset::MeshLibrary::new(std::path::Path::new("assets/scenes/objects"));
    synthcam::scene::file::parse_scene_with(include_str!("../../assets/scenes/objects/gripper_soft_shadow.toml"), &meshes).expect("scene")
}

/// Print and return the count, max and RMS of `errs` (sorted).
fn summary(what: &str, errs: &[f64], deepest: f64) -> (usize, f64, f64) {
    let (count, worst) = (errs.len(), errs.last().copied().unwrap_or(0.0));
    let rms = (errs.iter().map(|e| e * e).sum::<f64>() / count.max(1) as f64).sqrt();
    let p99 = errs.get(count * 99 / 100).copied().unwrap_or(0.0);
    eprintln!("{what}: {count} pixels, |rendered - CPU sampling| RMS {rms:.3}, p99 {p99:.3}, max {worst:.3} grey levels, deepest shadow ratio {deepest:.3}");
    (count, worst, rms)
}

/// Emitter cells per side of the CPU reference (`scene::shadow::visible_share`): at 48 its own
/// error reached 0.72 grey levels on a random view (0.27 at 128) with a narrow light.
const REFERENCE_CELLS: usize = 128;

/// Every `step`-th board pixel the objects' shadow touches in `s` (away from the objects'
/// outlines and the board's edges): |the render - the lit board's render times the mean over the
/// pixel's 2 x 2 points of `A + E V` over the mean of `A + E`|, `V` from
/// `scene::shadow::visible_share` ([`REFERENCE_CELLS`] a side), sorted; and the deepest shadow ratio.
fn against_cpu_sampling(s: &Scene, step: usize) -> (Vec<f64>, f64) {
    let img = renderer().render_linear(s).expect("soft");
    let lit = renderer().render_linear(&Scene { objects: Vec::new(), ..s.clone() }).expect("lit");
    let unlit = renderer().render_linear(&Scene { objects: Vec::new(), render: Default::default(), ..s.clone() }).expect("unlit");
    let light = synthcam::scene::shadow::shadow_light(s).expect("a shadow light");
    let synthcam::scene::shadow::ShadowLight::Area { rect, radiance, ambient } = light else { panic!("an area light") };
    let greys = s.target.greys();
    let (n, c) = board_plane(s);
    let w = s.camera.size.width as usize;
    let (mut errs, mut deepest) = (Vec::new(), 1.0f64);
    for k in (0..img.len()).step_by(step) {
        if !greys[..3].iter().any(|g| (f64::from(unlit[k]) - g).abs() < 1e-4) {
            continue;
        }
        let (px, py) = ((k % w) as f64, (k / w) as f64);
        let ray = |dx: f64, dy: f64| s.camera.unproject(&Point2::new(px + dx, py + dy)).expect("ray");
        let edges = [(-0.6, -0.6), (0.6, -0.6), (0.6, 0.6), (-0.6, 0.6), (0.0, 0.0)];
        if edges.iter().any(|(dx, dy)| synthcam::scene::objects::cast_objects(&s.objects, &ray(*dx, *dy), f64::INFINITY).is_some()) {
            continue;
        }
        let points = [(-0.25, -0.25), (0.25, -0.25), (-0.25, 0.25), (0.25, 0.25)].map(|(dx, dy)| {
            let d = ray(dx, dy);
            Point3::from(d * (c / n.dot(&d)))
        });
        if !points.iter().any(|x| synthcam::scene::shadow::in_shadow(s, &light, x)) {
            continue;
        }
        let (mut shaded, mut full) = (0.0, 0.0);
        for x in &points {
            let e = radiance * rect.projected_solid_angle(x, &n);
            shaded += ambient + e * synthcam::scene::shadow::visible_share(s, &rect, x, &n, REFERENCE_CELLS);
            full += ambient + e;
        }
        let expected = f64::from(lit[k]) * shaded / full;
        errs.push((f64::from(img[k]) - expected).abs());
        deepest = deepest.min(shaded / full);
    }
    errs.sort_by(f64::total_cmp);
    (errs, deepest)
}
