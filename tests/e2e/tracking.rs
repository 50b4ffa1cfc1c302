//! A sequence's S-path labels carried from frame to frame (`RenderedSensor`, `SPathTrack`): the
//! same features as detecting every frame afresh, while the camera drifts and then jumps.

use nalgebra::{Isometry3, Translation3, UnitQuaternion, Vector3};
use synthcam::detect::target::{detect, TargetSpec};
use synthcam::scene::file::parse_scene;
use synthcam::sim::sensor::{RenderedSensor, Sensor};

use crate::common::renderer;

#[test]
fn carried_labels_equal_fresh_detection_frame_by_frame() {
    let mut scene = parse_scene(include_str!("../../assets/scenes/course_s_path.toml")).expect("scene");
    let start = scene.cam_from_target;
    let mut sensor = RenderedSensor::new(renderer());
    // Ten small steps (0.05 degrees and 0.5 mm each: about 1.7 px), a jump of 3 degrees, three
    // small steps.
    let steps: Vec<f64> = (1..=10).map(|k| k as f64).chain([70.0, 71.0, 72.0, 73.0]).collect();
    let mut carried = 0;
    for (n, k) in steps.iter().enumerate() {
        let turn = UnitQuaternion::from_axis_angle(&Vector3::y_axis(), (0.05 * k).to_radians());
        scene.cam_from_target = Isometry3::from_parts(Translation3::new(0.0005 * k, 0.0, 0.0), turn) * start;
        let capture = sensor.capture(&scene).expect("capture");
        let image = capture.image.as_ref().expect("image").to_detector_image().expect("grey");
        let fresh = detect(&image, &TargetSpec::for_target(&scene.target)).expect("detect");
        let ids: Vec<usize> = capture.features.iter().map(|f| f.id).collect();
        assert_eq!(Some(ids), fresh.indices, "frame {n}: labels differ");
        assert!(capture.features.iter().zip(&fresh.points_px).all(|(f, p)| f.pixel_px == *p), "frame {n}: pixels differ");
        assert!(fresh.found && fresh.points_px.len() >= 90, "frame {n}: {:?}", fresh.note);
        // Every frame after a small step is carried; the first and the one after the jump not.
        let now = sensor.track().carried();
        assert_eq!(now - carried, usize::from(n > 0 && n != 10), "frame {n}");
        carried = now;
    }
    assert_eq!(carried, steps.len() - 2);
}
