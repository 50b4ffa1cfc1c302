//! Issue 41 item 1: directional lights and the ambient term on a flat board, against the
//! Lambertian value worked out here from the pose (`a (A + E max(0, -n . d))`, n the board's
//! normal on the camera's side): every pixel wholly inside a region of the board (its unlit value
//! one of the board's grey levels) within 0.5 grey levels (the bound); the background
//! unchanged; lights the shading does not cover yet refused by name.

use nalgebra::{UnitQuaternion, Vector3};
use synthcam::scene::lighting::{LightFrame, Lighting};
use synthcam::scene::Scene;

use crate::common::{camera, chessboard_scene, renderer};

fn lit(scene: &Scene, lighting: Lighting) -> Scene {
    let mut s = scene.clone();
    s.render.lighting = lighting;
    s
}

/// The largest |lit - expected| over the pixels wholly inside a surface region, the count of
/// such pixels, and the largest change of a background pixel.
fn compare(scene: &Scene, lighting: Lighting, factor: f64) -> (f64, usize, f64) {
    let unlit = renderer().render_linear(scene).expect("unlit");
    let shaded = renderer().render_linear(&lit(scene, lighting)).expect("lit");
    let synthcam::target::Target::Chessboard(b) = &scene.target else { panic!("chessboard") };
    let (mut worst, mut n, mut background) = (0.0f64, 0, 0.0f64);
    for (u, l) in unlit.iter().zip(&shaded) {
        let (u, l) = (f64::from(*u), f64::from(*l));
        if [b.dark, b.light, b.margin].iter().any(|g| (u - g).abs() < 1e-4) {
            worst = worst.max((l - u * factor).abs());
            n += 1;
        } else if (u - b.background).abs() < 1e-4 {
            background = background.max((l - u).abs());
        }
    }
    (worst, n, background)
}

#[test]
fn a_directional_light_shades_a_flat_board_by_lamberts_law() {
    let cam = camera(640, 480, 600.0, [-0.2, 0.05, 0.0, 0.0, 0.0]);
    let mut scene = chessboard_scene(cam, [8, 6], 0.04, 35.0, 0.8, [0.05, -0.02]);
    scene.cam_from_target.rotation = UnitQuaternion::from_axis_angle(&Vector3::y_axis(), 0.3) * scene.cam_from_target.rotation;
    // The board's normal on the camera's side, worked out from the pose.
    let z = scene.cam_from_target.rotation * Vector3::z();
    let n = if z.dot(&scene.cam_from_target.translation.vector) > 0.0 { -z } else { z };
    let d = Vector3::new(0.3, -0.2, 1.0).normalize();
    let (a, e) = (0.25, 0.9);
    let mut lighting = Lighting { ambient: Some(a), ..Default::default() };
    lighting.add(LightFrame::Camera, d.into(), e).expect("light");
    let factor = a + e * (-n.dot(&d)).max(0.0);
    let (worst, count, background) = compare(&scene, lighting, factor);
    eprintln!("camera-frame light: factor {factor:.5}; {count} pixels inside regions, max |diff| {worst:.2e} grey levels; background moved {background:.1e}");
    assert!(count > 20_000 && worst <= 0.5 && background == 0.0, "{count} {worst} {background}");
    // The truth gives every feature's irradiance (the same factor on a flat board).
    let truth = synthcam::scene::truth_labels(&lit(&scene, lighting));
    assert!(truth.features.iter().all(|f| f.irradiance.is_some_and(|i| (i - factor).abs() < 1e-12)));
    assert!(synthcam::scene::truth_labels(&scene).features.iter().all(|f| f.irradiance.is_none()));
    // A target-frame light along the board's +z (into the printed side) faces it squarely at any
    // pose: the factor is A + E.
    let mut square = Lighting { ambient: Some(0.1), ..Default::default() };
    square.add(LightFrame::Target, [0.0, 0.0, 1.0], 0.7).expect("light");
    let (worst, count, _) = compare(&scene, square, 0.8);
    eprintln!("target-frame light along +z: max |diff| {worst:.2e} over {count} pixels");
    assert!(count > 20_000 && worst <= 0.5, "{worst}");
    // A light from behind the board leaves only the ambient term; no light and no ambient given
    // leaves the image as it was (every golden image depends on that).
    let mut behind = Lighting { ambient: Some(0.5), ..Default::default() };
    behind.add(LightFrame::Camera, n.into(), 2.0).expect("light");
    assert!(compare(&scene, behind, 0.5).0 <= 0.5);
    let (neutral, plain) = (renderer().render_linear(&lit(&scene, Lighting::default())).expect("neutral"), renderer().render_linear(&scene).expect("plain"));
    assert_eq!(neutral, plain);
}

#[test]
fn lights_the_shading_does_not_cover_are_named_errors() {
    let cam = camera(320, 240, 300.0, [0.0; 5]);
    let scene = chessboard_scene(cam, [6, 5], 0.04, 10.0, 0.8, [0.0, 0.0]);
    let mut light = Lighting::default();
    light.add(LightFrame::Camera, [0.0, 0.0, 1.0], 1.0).expect("light");
    let mut warped = lit(&scene, light);
    if let synthcam::target::Target::Chessboard(b) = &mut warped.target {
        b.warp_m = [0.001, 0.0];
    }
    assert!(warped.validate().is_err_and(|e| e.to_string().contains("light")));
    assert!(renderer().render(&warped).is_err());
    let mut bad = Lighting::default();
    assert!(bad.add(LightFrame::Camera, [0.0; 3], 1.0).is_err());
    assert!(bad.add(LightFrame::Camera, [0.0, 0.0, 1.0], f64::NAN).is_err());
    assert!(lit(&scene, Lighting { ambient: Some(-1.0), ..light }).validate().is_err());
    let text = "[camera]\nwidth = 320\nheight = 240\nfx = 300.0\nfy = 300.0\ncx = 159.5\ncy = 119.5\n[target]\nkind = \"chessboard\"\nsquares = [6, 5]\nsquare_m = 0.04\n[facing]\ndistance_m = 0.8\n[render]\nambient = 0.2\n[[light]]\nkind = \"directional\"\ndirection = [0.0, 0.0, 1.0]\nirradiance = 0.8\n";
    let spec = synthcam::scene::file::parse_spec(text).expect("spec");
    let s = spec.to_scene().expect("scene");
    assert_eq!(s.render.lighting.ambient, Some(0.2));
    let area = text.replace("kind = \"directional\"", "kind = \"area\"");
    let e = synthcam::scene::file::parse_spec(&area).and_then(|s| s.to_scene()).expect_err("an area light with a direction");
    assert!(e.to_string().contains("no direction"), "{e}");
    let spot = text.replace("kind = \"directional\"", "kind = \"spot\"");
    let e = synthcam::scene::file::parse_spec(&spot).and_then(|s| s.to_scene()).expect_err("a spot light");
    assert!(e.to_string().contains("\"area\""), "{e}");
    let point = text.replace("kind = \"directional\"", "kind = \"point\"");
    let e = synthcam::scene::file::parse_spec(&point).and_then(|s| s.to_scene()).expect_err("a point light without position_m");
    assert!(e.to_string().contains("position_m"), "{e}");
}

/// A point light 0.35 m from the board: each pixel wholly inside a region against the
/// inverse-square law worked out here at the board point its centre's ray meets (the shading
/// varies over the board by a factor of about two), within 0.5 grey levels; the truth's
/// irradiance per feature the same law at the feature.
#[test]
fn a_point_light_shades_each_pixel_by_the_inverse_square_law() {
    let cam = camera(640, 480, 600.0, [-0.2, 0.05, 0.0, 0.0, 0.0]);
    let scene = chessboard_scene(cam, [8, 6], 0.04, 25.0, 0.8, [0.02, 0.01]);
    let lamp = Vector3::new(-0.15, -0.2, 0.5);
    let (a, i) = (0.15, 0.12);
    let mut lighting = Lighting { ambient: Some(a), ..Default::default() };
    lighting.add_point(LightFrame::Camera, lamp.into(), i).expect("lamp");
    let z = scene.cam_from_target.rotation * Vector3::z();
    let n = if z.dot(&scene.cam_from_target.translation.vector) > 0.0 { -z } else { z };
    let c = n.dot(&scene.cam_from_target.translation.vector);
    let law = |x: &Vector3<f64>| {
        let d = x - lamp;
        a + i * (-n.dot(&d)).max(0.0) / d.norm().powi(3)
    };
    let unlit = renderer().render_linear(&scene).expect("unlit");
    let shaded = renderer().render_linear(&lit(&scene, lighting)).expect("lit");
    let synthcam::target::Target::Chessboard(b) = &scene.target else { panic!("chessboard") };
    let (mut worst, mut count, mut lo, mut hi) = (0.0f64, 0, f64::INFINITY, 0.0f64);
    for (k, (u, l)) in unlit.iter().zip(&shaded).enumerate() {
        let u = f64::from(*u);
        if ![b.dark, b.light, b.margin].iter().any(|g| (u - g).abs() < 1e-4) {
            continue;
        }
        let q = nalgebra::Point2::new((k % 640) as f64, (k / 640) as f64);
        let ray = cam.unproject(&q).expect("ray");
        let e = law(&(ray * (c / n.dot(&ray))));
        (lo, hi) = (lo.min(e), hi.max(e));
        worst = worst.max((f64::from(*l) - u * e).abs());
        count += 1;
    }
    eprintln!("point light: shading {lo:.3}..{hi:.3} over the board; {count} pixels, max |diff| {worst:.2e} grey levels");
    assert!(count > 20_000 && worst <= 0.5 && hi > 1.5 * lo, "{count} {worst} {lo} {hi}");
    let truth = synthcam::scene::truth_labels(&lit(&scene, lighting));
    for f in &truth.features {
        let p = scene.cam_from_target * nalgebra::Point3::from(f.point_target_m);
        assert!((f.irradiance.expect("irradiance") - law(&p.coords)).abs() < 1e-9);
    }
}

/// A glossy board under a lamp beside the camera: the highlight (the render minus the same render
/// without gloss) peaks within 1 px of the mirror-reflection point worked out here (the lamp
/// mirrored in the board's plane, joined to the camera centre, projected through the lens), and
/// the shader's peak value matches the library's GGX term at that pixel's board point.
#[test]
fn a_glossy_boards_highlight_sits_at_the_mirror_point() {
    use synthcam::scene::lighting::Gloss;
    let cam = camera(640, 480, 600.0, [-0.2, 0.05, 0.0, 0.0, 0.0]);
    let scene = chessboard_scene(cam, [8, 6], 0.04, 20.0, 0.7, [0.03, 0.02]);
    // A lamp placed so that its reflection is seen near the board's centre: on the line from the
    // camera's mirror image through a point beside the centre.
    let z = scene.cam_from_target.rotation * Vector3::z();
    let aim = scene.cam_from_target * nalgebra::Point3::new(0.13, 0.11, 0.0);
    let eye_mirrored = 2.0 * z.dot(&scene.cam_from_target.translation.vector) * z;
    let lamp = eye_mirrored + 1.7 * (aim.coords - eye_mirrored);
    let mut lighting = Lighting { ambient: Some(0.3), ..Default::default() };
    lighting.add_point(LightFrame::Camera, lamp.into(), 0.2).expect("lamp");
    let glossy = Lighting { gloss: Some(Gloss { specular: 0.04, roughness: 0.25 }), ..lighting };
    let matte = renderer().render_linear(&lit(&scene, lighting)).expect("matte");
    let shiny = renderer().render_linear(&lit(&scene, glossy)).expect("glossy");
    let (k, peak) = matte.iter().zip(&shiny).map(|(m, s)| f64::from(s - m)).enumerate().fold((0, f64::MIN), |a, (k, d)| if d > a.1 { (k, d) } else { a });
    let q = nalgebra::Point2::new((k % 640) as f64, (k / 640) as f64);
    // The mirror point: the lamp reflected in the plane n . x = c, on the camera's line to it.
    let n = if z.dot(&scene.cam_from_target.translation.vector) > 0.0 { -z } else { z };
    let c = n.dot(&scene.cam_from_target.translation.vector);
    let mirrored = lamp - 2.0 * (n.dot(&lamp) - c) * n;
    let m = mirrored * (c / n.dot(&mirrored));
    let want = cam.project_unchecked(&nalgebra::Point3::from(m));
    let off = (q - want).norm();
    let ray = cam.unproject(&q).expect("ray");
    let library = glossy.specular_at(&(ray * (c / n.dot(&ray))), &n, &scene.cam_from_target);
    eprintln!(
        "highlight: peak {peak:.2} grey levels at ({}, {}), mirror point ({:.2}, {:.2}): {off:.3} px apart; the library's GGX there {library:.2}",
        q.x, q.y, want.x, want.y
    );
    assert!(peak > 20.0 && off <= 1.0, "peak {peak} at {q}, mirror {want}");
    assert!((peak - library).abs() <= 1e-3 * library, "{peak} vs {library}");
}

/// A saturated highlight over interior corners (the robustness experiment's highlight condition
/// at lamp intensity 3, fresh poses): the board is still found, the clipped corners come back
/// untrusted (infinite sigma), every trusted corner within 0.3 px of the truth (the saddle
/// model's bias under the highlight's gradient: 0.22 px measured at its edge); the same board
/// with those corners hidden under a mid-grey blob that is *not* clipped is not completed.
#[test]
fn corners_under_a_clipped_highlight_come_back_untrusted() {
    use synthcam::detect::chessboard::TRUSTED_CORNER_PX;
    use synthcam::detect::{find_chessboard, ChessboardParams};
    use synthcam::sim::robustness::conditions::highlight;
    let base = synthcam::scene::file::parse_scene(synthcam::sim::robustness::CHESSBOARD_K1).expect("scene");
    let scene = highlight(&base, 3.0);
    let img = renderer().render(&scene).expect("render");
    let truth = synthcam::scene::truth_labels(&scene);
    let det = find_chessboard(&img.to_detector_image().expect("image"), &ChessboardParams::new(11, 8)).expect("detect").expect("found despite the glare");
    let untrusted = det.untrusted(TRUSTED_CORNER_PX);
    let clipped = truth.features.iter().filter(|f| f.specular.unwrap_or(0.0) > 255.0).count();
    let worst_trusted = (0..88)
        .filter(|k| !untrusted.contains(k))
        .map(|k| truth.features.iter().map(|f| (det.points_px[k].x - f.pixel_px[0]).hypot(det.points_px[k].y - f.pixel_px[1])).fold(f64::INFINITY, f64::min))
        .fold(0.0, f64::max);
    eprintln!("highlight 3: {} untrusted, {clipped} corners under a specular share above 255, worst trusted {worst_trusted:.4} px", untrusted.len());
    assert!(!untrusted.is_empty() && clipped > 0, "the highlight clips some corners");
    assert!(untrusted.iter().all(|k| det.position_sigma_px[*k].is_infinite() || 2.0 * det.position_sigma_px[*k] > TRUSTED_CORNER_PX));
    assert!(worst_trusted < 0.3, "trusted corners near the truth: worst {worst_trusted:.4} px");
    // The blob the highlight leaves, drawn in mid-grey (not clipped): no corner can be seen there
    // either, but nothing says why, so the board is not completed.
    let mut grey = img.to_detector_image().expect("image");
    let max = grey.data.iter().copied().fold(0.0f32, f32::max);
    grey.data.iter_mut().filter(|v| **v >= max).for_each(|v| *v = 128.0);
    let params = ChessboardParams::new(11, 8);
    assert!(find_chessboard(&grey, &params).expect("detect").is_none_or(|b| b.untrusted(TRUSTED_CORNER_PX).len() < untrusted.len()));
}
