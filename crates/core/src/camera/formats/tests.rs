//! Round trips of every camera file, and the formats' refusals.

use super::*;
use crate::camera::{Distortion, DoubleSphere, Fisheye, ImageSize, Intrinsics};

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
    use nalgebra::{Isometry3, Matrix4, Translation3, UnitQuaternion, Vector3};
    let a = cam(Lens::OpenCv(Distortion::from_array([-0.25, 0.12, 1e-3, -5e-4, 0.0])), 0.0);
    let b = cam(Lens::Fisheye(Fisheye { k: [0.05, -0.01, 0.002, -0.0005] }), 0.0);
    let poses = [
        Isometry3::identity(),
        Isometry3::from_parts(Translation3::new(0.12, 0.0, 0.001), UnitQuaternion::from_axis_angle(&Vector3::y_axis(), -0.035)),
        Isometry3::from_parts(Translation3::new(0.0, -0.05, 0.02), UnitQuaternion::from_axis_angle(&Vector3::x_axis(), 0.5)),
    ];
    let text = kalibr_camchain(&[a, b, a], &poses).expect("camchain");
    // Read the T_cn_cnm1 blocks back by name and chain them: cam0_from_camN.
    let mut chained = vec![Isometry3::identity()];
    for n in 1..3 {
        let block = text.split(&format!("cam{n}:\n")).nth(1).expect("block");
        let rows: Vec<Vec<f64>> = block
            .lines()
            .skip(1)
            .take(4)
            .map(|l| l.trim_start_matches("  - [").trim_end_matches(']').split(", ").map(|v| v.parse().expect("number")).collect())
            .collect();
        let t = Matrix4::from_fn(|r, c| rows[r][c]);
        let cn_from_cnm1 =
            Isometry3::from_parts(Translation3::new(t[(0, 3)], t[(1, 3)], t[(2, 3)]), UnitQuaternion::from_matrix(&t.fixed_view::<3, 3>(0, 0).into_owned()));
        let prev = chained[n - 1];
        chained.push(prev * cn_from_cnm1.inverse());
    }
    for (got, want) in chained.iter().zip(&poses) {
        assert!((got.to_homogeneous() - want.to_homogeneous()).abs().max() < 1e-12, "{got} vs {want}");
    }
    assert!(text.contains("cam1:\n  T_cn_cnm1:") && text.contains("distortion_model: equidistant") && !text.contains("cam0:\n  T_cn_cnm1"));
    assert!(kalibr_camchain(&[a, b], &poses).is_err());
}
