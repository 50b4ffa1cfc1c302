//! Tests of the dataset specs: every example spec parses and is feasible, bad fields are named.

use super::*;

const EXAMPLES: [(&str, &str); 15] = [
    ("tiny", include_str!("../../../assets/specs/tiny.toml")),
    ("chessboard_1280", include_str!("../../../assets/specs/chessboard_1280.toml")),
    ("course_calibration", include_str!("../../../assets/specs/course_calibration.toml")),
    ("s_path_robot", include_str!("../../../assets/specs/s_path_robot.toml")),
    ("fisheye_1280", include_str!("../../../assets/specs/fisheye_1280.toml")),
    ("fisheye_edge_1280", include_str!("../../../assets/specs/fisheye_edge_1280.toml")),
    ("fisheye_wide_1280", include_str!("../../../assets/specs/fisheye_wide_1280.toml")),
    ("charuco_full_1280", include_str!("../../../assets/specs/charuco_full_1280.toml")),
    ("charuco_partial_1280", include_str!("../../../assets/specs/charuco_partial_1280.toml")),
    ("aprilgrid_full_1280", include_str!("../../../assets/specs/aprilgrid_full_1280.toml")),
    ("aprilgrid_partial_1280", include_str!("../../../assets/specs/aprilgrid_partial_1280.toml")),
    ("stereo_rig_1280", include_str!("../../../assets/specs/stereo_rig_1280.toml")),
    ("lit_chessboard_1280", include_str!("../../../assets/specs/lit_chessboard_1280.toml")),
    ("lamp_chessboard_1280", include_str!("../../../assets/specs/lamp_chessboard_1280.toml")),
    ("glare_chessboard_1280", include_str!("../../../assets/specs/glare_chessboard_1280.toml")),
];

#[test]
fn only_a_lens_that_sees_behind_its_camera_plane_takes_boards_there() {
    let wide = EXAMPLES[6].1;
    assert!(parse_dataset_spec(wide).is_ok());
    // The same ranges with a fisheye that folds at 57 degrees: distance_m must be > 0.
    let folding = wide.replace("dist = [0.02, -0.005, 0.0, 0.0]", "dist = [-0.3, 0.0, 0.0, 0.0]");
    let e = parse_dataset_spec(&folding).unwrap_err().to_string();
    assert!(e.contains("poses.distance_m") && e.contains("must be > 0"), "{e}");
}

#[test]
fn example_specs_parse_and_are_feasible() {
    for (name, text) in EXAMPLES {
        let plan = parse_dataset_spec(text).unwrap_or_else(|e| panic!("{name}: {e}"));
        let rate = crate::dataset::poses::check_feasible(&plan).unwrap_or_else(|e| panic!("{name}: {e}"));
        assert!(rate > 0.01, "{name}: acceptance {rate}");
    }
}

#[test]
fn invalid_fields_are_named() {
    let tiny = EXAMPLES[0].1;
    let cases = [
        (tiny.replace("offset_x_m = [-0.03, 0.03]", "offset_x_m = [0.03]"), "poses.offset_x_m"),
        (tiny.replace("distance_m = [0.45, 0.7]", "distance_m = [0.0, 0.7]"), "poses.distance_m"),
        (tiny.replace("tilt_deg = [0.0, 35.0]", "tilt_deg = [0.0, 95.0]"), "poses.tilt_deg"),
        (tiny.replace("margin_px = 4.0", "margin_px = -1.0"), "poses.margin_px"),
        (tiny.replace("count = 200", "count = 2000000"), "count"),
        (tiny.replace("width = 320", "width = 0"), "width"),
    ];
    for (text, needle) in cases {
        let e = parse_dataset_spec(&text).unwrap_err().to_string();
        assert!(e.contains(needle), "{needle}: {e}");
    }
    let robot = EXAMPLES[3].1;
    let e = parse_dataset_spec(&robot.replace("spread_rad = 0.25", "spread_rad = nan")).unwrap_err().to_string();
    assert!(e.contains("poses.spread_rad"), "{e}");
    let e = parse_dataset_spec(&robot.replace("[1.0, 0.0, 0.0], [0.0, 1.0, 0.0]]", "[1.0, 0.0, 0.0], [0.0, 2.0, 0.0]]")).unwrap_err().to_string();
    assert!(e.contains("tool_from_cam_R"), "{e}");
}

/// The rig spec: cameras in order, `cam_from_cam0` from the rig poses (right_from_left = the
/// inverse of rig_from_right, the left camera being the rig frame), every sampled frame seen
/// whole by both cameras (`min_cameras = 2`), and the rig's bad fields named.
#[test]
fn a_rig_spec_places_its_cameras_and_sees_the_board_in_min_cameras() {
    let text = EXAMPLES[11].1;
    let plan = parse_dataset_spec(text).unwrap();
    let names: Vec<&str> = plan.rig.iter().map(|m| m.name.as_str()).collect();
    assert_eq!(names, ["left", "right"]);
    assert_eq!((plan.min_cameras, plan.camera), (2, plan.rig[0].camera));
    let rig_from_right = nalgebra::Isometry3::from_parts(
        nalgebra::Translation3::new(0.12, 0.0, 0.0),
        nalgebra::UnitQuaternion::from_axis_angle(&nalgebra::Vector3::y_axis(), -2f64.to_radians()),
    );
    assert!((plan.rig[1].cam_from_cam0.to_homogeneous() - rig_from_right.inverse().to_homogeneous()).abs().max() < 1e-12);
    let pts = plan.target.feature_points_m();
    for k in 0..10 {
        let v = crate::dataset::poses::sample_view(&plan, k).unwrap();
        for m in &plan.rig {
            assert!(m.camera.sees_all(&(m.cam_from_cam0 * v.cam_from_target), &pts, plan.margin_px), "frame {k}, {}", m.name);
        }
    }
    let bad = [
        ("\nmin_cameras = 2", "\nmin_cameras = 3", "poses.min_cameras"),
        ("\nmin_cameras = 2", "\nmin_cameras = 0", "poses.min_cameras"),
        ("name = \"right\"", "name = \"left\"", "unique"),
        ("[target]", "[camera]\nwidth = 64\nheight = 64\nfx = 50.0\nfy = 50.0\ncx = 31.5\ncy = 31.5\n[target]", "not both"),
    ];
    for (from, to, want) in bad {
        let e = parse_dataset_spec(&text.replacen(from, to, 1)).unwrap_err().to_string();
        assert!(e.contains(want), "{to}: {e}");
    }
    let one = EXAMPLES[0].1.replace("mode = \"board\"", "mode = \"board\"\nmin_cameras = 1");
    assert!(parse_dataset_spec(&one).unwrap_err().to_string().contains("applies to [[cameras]] rigs"));
}
