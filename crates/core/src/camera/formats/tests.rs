//! Round trips of every camera file, and the formats' refusals.

use super::*;
use crate::camera::{Distortion, DoubleSphere, Fisheye, ImageSize, Intrinsics};
use nalgebra::{Isometry3, Translation3, UnitQuaternion, Vector3};

fn cam(lens: Lens, skew: f64) -> CameraModel {
    CameraModel { size: ImageSize { width: 1280, height: 1024 }, intrinsics: Intrinsics { fx: 401.25, fy: 402.5, cx: 640.125, cy: 511.75, skew }, lens }
}

fn same(a: &CameraModel, b: &CameraModel) -> bool {
    let (pa, pb) = (a.lens.params(), b.lens.params());
    a.size == b.size
        && a.lens.kind() == b.lens.kind()
        && (a.intrinsics.fx - b.intrinsics.fx).abs() < 1e-12
        && pa.iter().zip(pb).all(|(x, y)| (x - y).abs() < 1e-15)
        && a.intrinsics == b.intrinsics
}

#[test]
fn every_writer_round_trips_through_the_reader() {
    let opencv5 = cam(Lens::OpenCv(Distortion::from_array([-0.25, 0.12, 1e-3, -5e-4, 0.01])), 0.0);
    let opencv4 = cam(Lens::OpenCv(Distortion::from_array([-0.25, 0.12, 1e-3, -5e-4, 0.0])), 0.0);
    let opencv8 = cam(Lens::OpenCv(Distortion::from_opencv(&[-0.2, 0.05, 1e-3, -2e-3, 0.01, 0.03, -0.01, 0.002]).unwrap_or_default()), 0.0);
    let opencv14 =
        cam(Lens::OpenCv(Distortion::from_coefficients([-0.2, 0.05, 1e-3, -2e-3, 0.01, 0.03, -0.01, 0.002, 1e-3, -2e-4, 5e-4, 3e-4, 0.02, -0.015])), 0.5);
    let fisheye = cam(Lens::Fisheye(Fisheye { k: [0.05, -0.01, 0.002, -0.0005] }), 0.0);
    let ds = cam(Lens::DoubleSphere(DoubleSphere { xi: -0.2, alpha: 0.6 }), 0.0);
    let cases: Vec<(&str, &CameraModel, Result<String, CameraFileError>)> = vec![
        ("opencv5 yaml", &opencv5, opencv_yaml(&opencv5, 0.1)),
        ("opencv14 yaml", &opencv14, opencv_yaml(&opencv14, 0.1)),
        ("fisheye yaml", &fisheye, opencv_yaml(&fisheye, 0.1)),
        ("ros plumb_bob", &opencv5, ros_yaml(&opencv5, "c")),
        ("ros rational", &opencv8, ros_yaml(&opencv8, "c")),
        ("ros equidistant", &fisheye, ros_yaml(&fisheye, "c")),
        ("kalibr radtan", &opencv4, kalibr_yaml(&opencv4)),
        ("kalibr equi", &fisheye, kalibr_yaml(&fisheye)),
        ("kalibr ds", &ds, kalibr_yaml(&ds)),
        ("mrcal 5", &opencv5, mrcal_cameramodel(&opencv5)),
        ("mrcal 8", &opencv8, mrcal_cameramodel(&opencv8)),
    ];
    for (name, c, text) in cases {
        let text = text.unwrap_or_else(|e| panic!("{name}: {e}"));
        let back = read(&text).unwrap_or_else(|e| panic!("{name}: {e}\n{text}"));
        assert!(same(c, &back), "{name}: {c:?} vs {back:?}\n{text}");
    }
    assert!(ros_yaml(&opencv5, "c").is_ok_and(|t| t.contains("plumb_bob")));
    assert!(kalibr_yaml(&ds).is_ok_and(|t| t.contains("camera_model: ds") && t.contains("distortion_model: none")));
}

#[test]
fn formats_refuse_what_they_cannot_hold() {
    let ds = cam(Lens::DoubleSphere(DoubleSphere { xi: -0.2, alpha: 0.6 }), 0.0);
    let skewed = cam(Lens::default(), 0.5);
    let opencv5 = cam(Lens::OpenCv(Distortion::from_array([-0.25, 0.12, 1e-3, -5e-4, 0.01])), 0.0);
    let tilted = cam(Lens::OpenCv(Distortion { tau_x: 0.01, ..Distortion::default() }), 0.0);
    let fisheye = cam(Lens::Fisheye(Fisheye::default()), 0.0);
    for r in [
        opencv_yaml(&ds, 0.0),
        ros_yaml(&ds, "c"),
        ros_yaml(&tilted, "c"),
        kalibr_yaml(&skewed),
        kalibr_yaml(&opencv5),
        mrcal_cameramodel(&tilted),
        mrcal_cameramodel(&fisheye),
        mrcal_cameramodel(&skewed),
    ] {
        assert!(matches!(r, Err(CameraFileError::Unsupported { .. })), "{r:?}");
    }
    assert!(matches!(read("hello: 1"), Err(CameraFileError::Parse(_))));
    assert!(read("%YAML:1.0\nimage_width: 10\n").is_err());
}

#[test]
fn a_kalibr_camchain_chains_the_rig_poses() {
    let a = cam(Lens::OpenCv(Distortion::from_array([-0.25, 0.12, 1e-3, -5e-4, 0.0])), 0.0);
    let b = cam(Lens::Fisheye(Fisheye { k: [0.05, -0.01, 0.002, -0.0005] }), 0.0);
    let poses = [
        Isometry3::identity(),
        Isometry3::from_parts(Translation3::new(0.12, 0.0, 0.001), UnitQuaternion::from_axis_angle(&Vector3::y_axis(), -0.035)),
        Isometry3::from_parts(Translation3::new(0.0, -0.05, 0.02), UnitQuaternion::from_axis_angle(&Vector3::x_axis(), 0.5)),
    ];
    let text = kalibr_camchain(&[a, b, a], &poses).expect("camchain");
    // Read back by name (read_camchain chains the T_cn_cnm1 blocks): cam0_from_camN.
    let chained: Vec<Isometry3<f64>> = read_camchain(&text).expect("read").into_iter().map(|(_, p)| p).collect();
    for (got, want) in chained.iter().zip(&poses) {
        assert!((got.to_homogeneous() - want.to_homogeneous()).abs().max() < 1e-12, "{got} vs {want}");
    }
    assert!(text.contains("cam1:\n  T_cn_cnm1:") && text.contains("distortion_model: equidistant") && !text.contains("cam0:\n  T_cn_cnm1"));
    assert!(kalibr_camchain(&[a, b], &poses).is_err());
}

/// Kalibr's own camchain (the wiki's "Yaml formats" example, its omni cam1 made a pinhole with
/// the same T_cn_cnm1, as this reader takes pinhole, equidistant and ds cameras), with its
/// T_cam_imu, timeshift and rostopic keys: both cameras by their fields, and cam0_from_cam1 the
/// inverse of T_cn_cnm1 (worked out by hand: -R^T t = (0.110035, -0.000228, 0.001109)).
#[test]
fn kalibrs_camchain_reads_with_its_extra_keys() {
    let text = "cam0:\n  camera_model: pinhole\n  intrinsics: [461.629, 460.152, 362.680, 246.049]\n  distortion_model: radtan\n  distortion_coeffs: [-0.27695497, 0.06712482, 0.00087538, 0.00011556]\n  T_cam_imu:\n  - [0.01779318, 0.99967549,-0.01822936, 0.07008565]\n  - [-0.9998017, 0.01795239, 0.00860714,-0.01771023]\n  - [0.00893160, 0.01807260, 0.99979678, 0.00399246]\n  - [0.0, 0.0, 0.0, 1.0]\n  timeshift_cam_imu: -8.121e-05\n  rostopic: /cam0/image_raw\n  resolution: [752, 480]\ncam1:\n  camera_model: pinhole\n  intrinsics: [833.006, 830.345, 373.850, 253.345]\n  distortion_model: equidistant\n  distortion_coeffs: [-0.33518750, 0.13211436, 0.00055967, 0.00057686]\n  T_cn_cnm1:\n  - [ 0.99998854, 0.00216014, 0.00427195,-0.11003785]\n  - [-0.00221074, 0.99992702, 0.01187697, 0.00045792]\n  - [-0.00424598,-0.01188627, 0.99992034,-0.00064487]\n  - [0.0, 0.0, 0.0, 1.0]\n  rostopic: /cam1/image_raw\n  resolution: [752, 480]\n";
    let chain = read_camchain(text).expect("camchain");
    assert_eq!(chain.len(), 2);
    let (c0, c1) = (&chain[0].0, &chain[1].0);
    assert_eq!((c0.size.width, c0.size.height, c0.intrinsics.fx, c0.intrinsics.cy), (752, 480, 461.629, 246.049));
    assert!(matches!(c0.lens, Lens::OpenCv(d) if d.coefficients()[0] == -0.27695497));
    assert!(matches!(c1.lens, Lens::Fisheye(f) if f.k[1] == 0.13211436) && c1.intrinsics.fy == 830.345);
    assert_eq!(chain[0].1, Isometry3::identity());
    let t = chain[1].1.translation.vector;
    assert!((t - Vector3::new(0.11003486, -0.00022785, 0.00110946)).abs().max() < 1e-7, "{t}");
    // Bad chains are named errors.
    assert!(read_camchain("").is_err());
    assert!(read_camchain(&text.replace("cam1:", "cam2:")).is_err());
    assert!(read_camchain(&text.replace("  - [ 0.99998854", "  - [ 1.5")).is_err());
}
