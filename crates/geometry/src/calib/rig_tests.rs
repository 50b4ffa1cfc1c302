//! Tests of the rig calibration on views projected through known rigs (the truth is the outside
//! value): a stereo pair of pinholes, a fisheye beside a pinhole with frames seen by one only.

use nalgebra::{Isometry3, Translation3, UnitQuaternion, Vector3};
use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;

use super::testdata::{board, with_noise};
use super::*;
use synthcam_core::camera::{Distortion, Fisheye, Intrinsics, Lens};

fn pinhole(fx: f64, k1: f64) -> CameraModel {
    CameraModel {
        size: ImageSize { width: 1280, height: 1024 },
        intrinsics: Intrinsics { fx, fy: fx + 1.0, cx: 639.5, cy: 511.5, skew: 0.0 },
        lens: Lens::OpenCv(Distortion::from_array([k1, 0.05, 0.0, 0.0, 0.0])),
    }
}

/// `n` frames of an 8 x 6 board (3 cm) in front of the rig, `cam0_from_board`.
fn frames(n: usize, rng: &mut impl Rng) -> Vec<Isometry3<f64>> {
    (0..n)
        .map(|_| {
            let axis = nalgebra::Unit::new_normalize(Vector3::new(rng.random_range(-1.0..1.0), rng.random_range(-1.0..1.0), 0.0));
            let rot = UnitQuaternion::from_axis_angle(&axis, rng.random_range(0.1..0.6));
            let t = Vector3::new(rng.random_range(-0.1..0.1) + 0.06, rng.random_range(-0.08..0.08), rng.random_range(0.45..0.7))
                - rot * Vector3::new(0.105, 0.075, 0.0);
            Isometry3::from_parts(Translation3::from(t), rot)
        })
        .collect()
}

/// Each camera's views of the frames (`None` where the board is not wholly in its image).
fn views_of(cam: &CameraModel, cam_from_cam0: &Isometry3<f64>, frames: &[Isometry3<f64>]) -> Vec<Option<View>> {
    let pts = board(8, 6, 0.03);
    frames
        .iter()
        .map(|f| {
            let v: View =
                pts.iter().map(|p| (*p, cam.project(&(cam_from_cam0 * f * p)))).filter(|(_, pr)| pr.visible()).map(|(p, pr)| (p, pr.pixel_px)).collect();
            (v.len() == pts.len()).then_some(v)
        })
        .collect()
}

fn noisy(views: Vec<Option<View>>, sigma: f64, rng: &mut impl Rng) -> Vec<Option<View>> {
    views.into_iter().map(|v| v.map(|v| with_noise(&[v], sigma, rng).remove(0))).collect()
}

fn rig_camera(name: &str, cam: &CameraModel, model: CalibModel, views: Vec<Option<View>>) -> RigCamera {
    RigCamera { name: name.into(), size: cam.size, params: CalibParams { model, ..Default::default() }, views }
}

/// Extrinsic errors: translation (board units) and rotation (degrees) of `cam0_from_cam`.
fn ext_error(est: &Isometry3<f64>, truth: &Isometry3<f64>) -> (f64, f64) {
    let d = est.inverse() * truth;
    ((est.translation.vector - truth.translation.vector).norm(), d.rotation.angle().to_degrees())
}

#[test]
fn a_stereo_pair_recovers_its_baseline_to_micrometres() {
    // 12 cm baseline, 2 degrees of toe-in.
    let mut rng = ChaCha8Rng::seed_from_u64(40);
    let (c0, c1) = (pinhole(1000.0, -0.2), pinhole(1010.0, -0.15));
    let cam0_from_cam1 = Isometry3::from_parts(Translation3::new(0.12, 0.0, 0.0), UnitQuaternion::from_axis_angle(&Vector3::y_axis(), -2f64.to_radians()));
    let f = frames(20, &mut rng);
    // 0.005 px: the corner noise of renders with noise sigma 1 grey level.
    let v0 = noisy(views_of(&c0, &Isometry3::identity(), &f), 0.005, &mut rng);
    let v1 = noisy(views_of(&c1, &cam0_from_cam1.inverse(), &f), 0.005, &mut rng);
    assert!(v1.iter().filter(|v| v.is_some()).count() >= 12);
    let cams = [rig_camera("left", &c0, CalibModel::OpenCv5, v0), rig_camera("right", &c1, CalibModel::OpenCv5, v1)];
    let r = calibrate_rig(&cams, 100).expect("rig");
    let (dt, dr) = ext_error(&r.cameras[1].cam0_from_cam, &cam0_from_cam1);
    eprintln!(
        "stereo: baseline error {:.4} mm, rotation {:.5} deg, sigma t {:?} m, r {:?} deg; rms {:.4}",
        dt * 1e3,
        dr,
        r.cameras[1].translation_std,
        r.cameras[1].rotation_std_deg,
        r.rms_px
    );
    assert!(dt < 5e-5 && dr < 0.002, "{dt} m, {dr} deg");
    // Within 3 reported sigmas (the sigmas are the rotation vector's, per axis).
    let sr = r.cameras[1].rotation_std_deg.iter().map(|s| s * s).sum::<f64>().sqrt();
    let st = r.cameras[1].translation_std.iter().map(|s| s * s).sum::<f64>().sqrt();
    assert!(dr < 3.0 * sr && dt < 3.0 * st, "{dr} deg vs sigma {sr}, {dt} m vs {st}");
    assert!((r.cameras[1].camera.intrinsics.fx - 1010.0).abs() < 0.2);
    assert!(r.rms_px < 0.01 && r.cameras.iter().all(|c| c.translation_std.iter().all(|s| s.is_finite())));
    let (mean, max) = rectified_row_errors(&r, &cams).expect("shared corners");
    eprintln!("rectified rows: mean {mean:.4} px, max {max:.4} px");
    assert!(mean < 0.01 && max < 0.05, "{mean} {max}");
    // A wrong extrinsic shows: 0.5 degrees more toe-in.
    let mut wrong = r.clone();
    wrong.cameras[1].cam0_from_cam.rotation =
        UnitQuaternion::from_axis_angle(&Vector3::x_axis(), 0.5f64.to_radians()) * wrong.cameras[1].cam0_from_cam.rotation;
    assert!(rectified_row_errors(&wrong, &cams).is_some_and(|(m, _)| m > 1.0));
}

#[test]
fn a_fisheye_beside_a_pinhole_with_frames_seen_by_one_only() {
    let mut rng = ChaCha8Rng::seed_from_u64(41);
    let fisheye = CameraModel { lens: Lens::Fisheye(Fisheye { k: [0.05, -0.01, 0.002, -0.0005] }), ..pinhole(420.0, 0.0) };
    let pin = pinhole(900.0, -0.1);
    let cam0_from_cam1 = Isometry3::from_parts(Translation3::new(0.08, 0.01, -0.005), UnitQuaternion::from_axis_angle(&Vector3::y_axis(), -10f64.to_radians()));
    let mut f = frames(24, &mut rng);
    // Frames off to the fisheye's side: the pinhole misses them.
    for fr in f.iter_mut().take(6) {
        fr.translation.vector.x -= 0.45;
    }
    let v0 = noisy(views_of(&fisheye, &Isometry3::identity(), &f), 0.005, &mut rng);
    let v1 = noisy(views_of(&pin, &cam0_from_cam1.inverse(), &f), 0.005, &mut rng);
    let only0 = v0.iter().zip(&v1).filter(|(a, b)| a.is_some() && b.is_none()).count();
    assert!(only0 >= 3, "{only0} frames seen by the fisheye only");
    let r = calibrate_rig(&[rig_camera("fisheye", &fisheye, CalibModel::Fisheye, v0), rig_camera("pinhole", &pin, CalibModel::OpenCv5, v1)], 100).expect("rig");
    let (dt, dr) = ext_error(&r.cameras[1].cam0_from_cam, &cam0_from_cam1);
    eprintln!("mixed: {:.4} mm, {:.5} deg ({only0} frames by the fisheye alone)", dt * 1e3, dr);
    assert!(dt < 1e-4 && dr < 0.005, "{dt} m, {dr} deg");
}

#[test]
fn bad_rigs_are_typed_errors() {
    let mut rng = ChaCha8Rng::seed_from_u64(42);
    let c = pinhole(1000.0, 0.0);
    let f = frames(8, &mut rng);
    let v = views_of(&c, &Isometry3::identity(), &f);
    let one = [rig_camera("a", &c, CalibModel::OpenCv5, v.clone())];
    assert!(matches!(calibrate_rig(&one, 50), Err(CalibError::BadOption { .. })));
    let dup = [rig_camera("a", &c, CalibModel::OpenCv5, v.clone()), rig_camera("a", &c, CalibModel::OpenCv5, v.clone())];
    assert!(matches!(calibrate_rig(&dup, 50), Err(CalibError::BadOption { .. })));
    let short = [rig_camera("a", &c, CalibModel::OpenCv5, v.clone()), rig_camera("b", &c, CalibModel::OpenCv5, v[..5].to_vec())];
    assert!(matches!(calibrate_rig(&short, 50), Err(CalibError::BadOption { .. })));
    // Camera b sees the board only in frames camera a does not.
    let (va, vb): (Vec<Option<View>>, Vec<Option<View>>) = v.iter().enumerate().map(|(k, x)| if k < 4 { (x.clone(), None) } else { (None, x.clone()) }).unzip();
    let disjoint = [rig_camera("a", &c, CalibModel::OpenCv5, va), rig_camera("b", &c, CalibModel::OpenCv5, vb)];
    assert!(matches!(calibrate_rig(&disjoint, 50), Err(CalibError::Degenerate { .. })));
}

mod slow {
    use super::*;

    #[test]
    fn extrinsic_sigmas_cover_the_errors_over_20_data_sets() {
        let (c0, c1) = (pinhole(1000.0, -0.2), pinhole(1010.0, -0.15));
        let cam0_from_cam1 = Isometry3::from_parts(Translation3::new(0.12, 0.0, 0.0), UnitQuaternion::from_axis_angle(&Vector3::y_axis(), -2f64.to_radians()));
        let (mut within1, mut within2, mut n) = (0, 0, 0);
        for seed in 0..20u64 {
            let mut rng = ChaCha8Rng::seed_from_u64(100 + seed);
            let f = frames(16, &mut rng);
            let v0 = noisy(views_of(&c0, &Isometry3::identity(), &f), 0.02, &mut rng);
            let v1 = noisy(views_of(&c1, &cam0_from_cam1.inverse(), &f), 0.02, &mut rng);
            let params = CalibParams { outlier_threshold: None, ..Default::default() };
            let cams = [RigCamera { name: "l".into(), size: c0.size, params, views: v0 }, RigCamera { name: "r".into(), size: c1.size, params, views: v1 }];
            let r = calibrate_rig(&cams, 100).expect("rig");
            let c = &r.cameras[1];
            // Per component: translation, and the rotation vector of the estimate's error.
            let dt = c.cam0_from_cam.translation.vector - cam0_from_cam1.translation.vector;
            let dr = (cam0_from_cam1.rotation.inverse() * c.cam0_from_cam.rotation).scaled_axis().map(f64::to_degrees);
            for (e, s) in dt.iter().zip(c.translation_std).chain(dr.iter().zip(c.rotation_std_deg)) {
                n += 1;
                within1 += usize::from(e.abs() <= s);
                within2 += usize::from(e.abs() <= 2.0 * s);
            }
        }
        let (p1, p2) = (within1 as f64 / n as f64, within2 as f64 / n as f64);
        eprintln!("extrinsics over 20 data sets: {:.0} % within 1 sigma, {:.0} % within 2 ({n} components)", 100.0 * p1, 100.0 * p2);
        assert!((0.55..=0.8).contains(&p1) && p2 >= 0.88, "{p1} {p2}");
    }
}
