//! Issue 41 item 2: hard shadows of objects on the board under a directional light. A square
//! plate between the light and the board casts a quadrilateral shadow; each of its straight edges
//! renders where the test's own ray-cast reference puts it (the plate's edge swept along the light
//! onto the board plane, seen through the lens's exact inverse), within the 0.02 px RMS;
//! the shadowed level is the ambient term's; the truth says which corners lie in shadow, by an
//! independent test of the plate's square.

use std::sync::Arc;

use nalgebra::{Isometry3, Point3, Translation3, UnitQuaternion, Vector3};
use synthcam::mesh::{Mesh, Triangle};
use synthcam::scene::lighting::LightFrame;
use synthcam::scene::objects::{MeshAsset, SceneObject};
use synthcam::scene::Scene;
use synthcam::target::{Chessboard, Target};

use crate::common::lines::{box_crossing, line_errors_by, rms};
use crate::common::{camera, renderer};

/// Half the plate's side, metres.
pub(crate) const HALF_M: f64 = 0.05;

/// A square plate in its z = 0 plane, centred, two triangles (both faces count: two-sided casts).
pub(crate) fn plate() -> Arc<MeshAsset> {
    let p = |x: f64, y: f64| Point3::new(x, y, 0.0);
    let mesh = Mesh {
        name: "plate".into(),
        positions_m: vec![p(-HALF_M, -HALF_M), p(HALF_M, -HALF_M), p(HALF_M, HALF_M), p(-HALF_M, HALF_M)],
        triangles: vec![Triangle { v: [0, 1, 2], uv: None, albedo: Some(60.0) }, Triangle { v: [0, 2, 3], uv: None, albedo: Some(60.0) }],
        texture: None,
    };
    MeshAsset::new(mesh).expect("plate")
}

/// A 2 x 2 board of 0.3 m squares (uniform regions the shadow's edges cross) 1 m ahead, turned
/// 20 degrees about y; the plate 0.3 m in front of it near the image's bottom, turned a little,
/// so that a light from the upper left casts its shadow on the lower left light square; the
/// light travels along `light` (camera frame): irradiance 0.8 over ambient 0.25.
pub(crate) fn scene(light: [f64; 3]) -> Scene {
    let board = Chessboard { squares: [2, 2], square_m: 0.3, margin_m: 0.05, ..Default::default() };
    let rot = UnitQuaternion::from_axis_angle(&Vector3::y_axis(), 20f64.to_radians());
    let cam_from_target = Isometry3::from_parts(Translation3::from(Vector3::new(0.0, 0.0, 1.0) - rot * Vector3::new(0.3, 0.3, 0.0)), rot);
    let mut s = Scene {
        camera: camera(1280, 1024, 1100.0, [-0.2, 0.05, 0.0, 0.0, 0.0]),
        target: Target::Chessboard(board),
        cam_from_target,
        render: Default::default(),
        objects: Vec::new(),
        background: None,
    };
    let plate_pose = Isometry3::from_parts(Translation3::new(-0.02, 0.275, 0.7), UnitQuaternion::from_euler_angles(0.2, -0.1, 0.3));
    s.objects.push(SceneObject::new(plate(), plate_pose));
    s.render.lighting.ambient = Some(0.25);
    s.render.lighting.add(LightFrame::Camera, light, 0.8).expect("light");
    s
}

/// The board plane's point along ray `d` (camera frame).
fn on_board(s: &Scene, d: &Vector3<f64>) -> Point3<f64> {
    let n = s.cam_from_target.rotation * Vector3::z();
    Point3::from(d * (n.dot(&s.cam_from_target.translation.vector) / n.dot(d)))
}

#[test]
fn a_plates_shadow_edges_land_on_their_ray_cast_reference() {
    let light = Vector3::new(-0.5, -0.5, 1.0).normalize();
    let s = scene(light.into());
    let img = renderer().render_linear(&s).expect("render");
    if let Ok(path) = std::env::var("SHADOW_PNG") {
        let bytes: Vec<u8> = img.iter().map(|v| v.round().clamp(0.0, 255.0) as u8).collect();
        image::GrayImage::from_raw(1280, 1024, bytes).expect("image").save(path).expect("png");
    }
    let plate_pose = s.objects[0].cam_from_object;
    let n = s.cam_from_target.rotation * Vector3::z();
    // Each plate edge, swept along the light, meets the board plane in a line; the side of a
    // board point against it is the side of the plane through the edge and the light.
    let corners: Vec<Point3<f64>> =
        [(-1.0, -1.0), (1.0, -1.0), (1.0, 1.0), (-1.0, 1.0)].iter().map(|(x, y)| plate_pose * Point3::new(x * HALF_M, y * HALF_M, 0.0)).collect();
    // The lit and shadowed levels of the light squares (the target's light grey).
    let Target::Chessboard(b) = &s.target else { unreachable!() };
    let cos = light.dot(&n).abs();
    let levels = [(b.light * 0.25) as f32, (b.light * (0.25 + 0.8 * cos)) as f32];
    let mut all = Vec::new();
    // A plate corner's shadow: along the light until the board plane.
    let c_plane = n.dot(&s.cam_from_target.translation.vector);
    let cast = |p: &Point3<f64>| p + light * ((c_plane - n.dot(&p.coords)) / n.dot(&light));
    for k in 0..4 {
        let (a, c) = (corners[k], corners[(k + 1) % 4]);
        let normal = (c - a).cross(&light);
        let (a2, c2) = (cast(&a), cast(&c));
        // The side of the shadow edge's line, on its middle 90 % only (NaN elsewhere: the line
        // beyond the edge meets the plate's own outline, as dark as the shadow).
        let side = |d: &Vector3<f64>| {
            let x = on_board(&s, d);
            let u = (x - a2).dot(&(c2 - a2)) / (c2 - a2).norm_squared();
            if (0.05..0.95).contains(&u) {
                normal.dot(&(x - a))
            } else {
                f64::NAN
            }
        };
        let errs = line_errors_by(&s.camera, &img, levels, side, box_crossing);
        eprintln!("shadow edge {k}: {} rows, RMS {:.4} px, max {:.4} px", errs.len(), rms(&errs), errs.iter().copied().fold(0.0, f64::max));
        all.extend(errs);
    }
    assert!(all.len() > 100, "the shadow's edges cross many rows: {}", all.len());
    assert!(rms(&all) <= 0.02, "issue 41: a hard shadow's edge within 0.02 px RMS of the ray-cast reference, {:.4}", rms(&all));
    let truth = synthcam::scene::truth_labels(&s);
    // Independently: a corner is in shadow when its ray towards the light meets the plate's square.
    let inv = plate_pose.inverse();
    let expected = |p: &[f64; 3]| {
        let x = s.cam_from_target * Point3::from(*p);
        let (o, d) = (inv * x, inv.rotation * -light);
        let t = -o.z / d.z;
        t > 0.0 && (o.x + t * d.x).abs() < HALF_M && (o.y + t * d.y).abs() < HALF_M
    };
    for f in &truth.features {
        assert_eq!(f.in_shadow, Some(expected(&f.point_target_m)), "feature {}", f.id);
    }
    // The same test over a 40 x 40 grid of board points (the board's one inner corner alone would
    // say little): `scene::shadow::in_shadow` agrees everywhere, some points shadowed.
    let sun = synthcam::scene::shadow::shadow_light(&s).expect("a shadow light");
    let mut shadowed = 0;
    for k in 0..1600 {
        let p = [-0.04 + 0.68 * f64::from(k % 40) / 39.0, -0.04 + 0.68 * f64::from(k / 40) / 39.0, 0.0];
        let got = synthcam::scene::shadow::in_shadow(&s, &sun, &(s.cam_from_target * Point3::from(p)));
        assert_eq!(got, expected(&p), "board point {p:?}");
        shadowed += usize::from(got);
    }
    assert!(shadowed > 10, "{shadowed} grid points in the plate's shadow");
}

#[test]
fn point_lights_with_objects_stay_refused_by_name() {
    let mut s = scene([0.0, 0.0, 1.0]);
    s.render.lighting.add_point(LightFrame::Camera, [0.1, 0.0, 0.0], 0.5).expect("point");
    let err = renderer().render_linear(&s).expect_err("refused");
    assert!(err.to_string().contains("light"), "{err}");
}

/// Vulkan and GL agree on a scene with shadows to 0.01 grey levels per pixel, not to the bit as
/// every scene of the determinism test does: 114 of 1.3 million float pixels on the shadow's
/// edges differ, by at most 3e-5 grey levels, and one of them straddles a rounding boundary (one
/// 8-bit level apart in the PNGs). Where the backends' arithmetic parts is not found yet.
#[test]
fn vulkan_and_gl_agree_on_shadows_to_a_hundredth_of_a_grey_level() {
    use synthcam::render::{BackendChoice, GpuContext, Renderer};
    let gl = Renderer::new(GpuContext::with_backend(BackendChoice::Gl).expect("GL backend (llvmpipe)"));
    let meshes = synthcam::dataset::MeshLibrary::new(std::path::Path::new("assets/scenes/objects"));
    // The gripper head-lit, and lit by the scene's light (its own shadow rays: lit_objects.rs).
    for (name, text) in [
        ("gripper_shadow", include_str!("../../assets/scenes/objects/gripper_shadow.toml")),
        ("gripper_lit", include_str!("../../assets/scenes/objects/gripper_lit.toml")),
    ] {
        let s = synthcam::scene::file::parse_scene_with(text, &meshes).expect("scene");
        let (a, b) = (renderer().render_linear(&s).expect("vulkan"), gl.render_linear(&s).expect("gl"));
        let worst = a.iter().zip(&b).map(|(x, y)| (x - y).abs()).fold(0.0f32, f32::max);
        let differing = a.iter().zip(&b).filter(|(x, y)| x.to_bits() != y.to_bits()).count();
        eprintln!("{name}: {differing} of {} float pixels differ between the backends, worst {worst}", a.len());
        assert!(worst < 0.01, "{name}: {worst}");
    }
}
