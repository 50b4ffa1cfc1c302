//! A stereo rig from a dataset spec, in memory: the spec's `[[cameras]]` rig
//! (`assets/specs/stereo_rig_1280.toml`: two 1280 x 1024 pinholes, 12 cm baseline, 2 degrees of
//! toe-in, 20 synchronised frames, noise 1), each frame rendered by both cameras from the same
//! board pose, detected, and the rig calibrated jointly; prints the extrinsics' error against
//! the spec's truth and exits non-zero beyond 0.05 mm / 0.002 deg (issue 40's bounds).
//!
//! `cargo run --release --example stereo_rig`

use synthcam::calib::{calibrate_rig, rectified_row_errors, RigCamera};
use synthcam::dataset::poses::{rig_scene_of, sample_view};
use synthcam::dataset::spec::parse_dataset_spec;
use synthcam::prelude::*;

fn main() -> Result<(), Box<dyn std::error::Error>> {
    let plan = parse_dataset_spec(include_str!("../assets/specs/stereo_rig_1280.toml"))?;
    let (renderer, spec) = (Renderer::headless()?, TargetSpec::for_target(&plan.target));
    let mut detections: Vec<Vec<Detection>> = vec![Vec::new(); plan.rig.len()];
    for k in 0..plan.count {
        let view = sample_view(&plan, k)?;
        for (i, dets) in detections.iter_mut().enumerate() {
            let scene = rig_scene_of(&plan, &view, i).ok_or("no such camera")?;
            dets.push(detect(&renderer.render(&scene)?.to_detector_image()?, &spec)?);
        }
    }
    let square_m = 0.03;
    let cams = plan
        .rig
        .iter()
        .zip(&detections)
        .map(|(m, dets)| {
            let found = views_from_detections(dets, &spec, square_m)?;
            let mut views = vec![None; dets.len()];
            for (v, i) in found.views.into_iter().zip(found.used) {
                views[i] = Some(v);
            }
            Ok(RigCamera { name: m.name.clone(), size: m.camera.size, params: CalibParams::default(), views })
        })
        .collect::<Result<Vec<_>, synthcam::calib::CalibError>>()?;
    let rig = calibrate_rig(&cams, CalibParams::default().max_iterations)?;
    // The truth: cam0_from_cam1 is the inverse of the spec's cam_from_cam0.
    let truth = plan.rig[1].cam_from_cam0.inverse();
    let est = rig.cameras[1].cam0_from_cam;
    let dt_mm = (est.translation.vector - truth.translation.vector).norm() * 1e3;
    let dr_deg = (est.rotation.inverse() * truth.rotation).angle().to_degrees();
    let rows = rectified_row_errors(&rig, &cams).map_or(f64::NAN, |r| r.0);
    println!("rig RMS {:.4} px; baseline error {dt_mm:.4} mm, rotation error {dr_deg:.5} deg; rectified rows mean {rows:.4} px", rig.rms_px);
    if !(dt_mm <= 0.05 && dr_deg <= 0.002) {
        return Err(format!("extrinsics off the truth: {dt_mm} mm, {dr_deg} deg").into());
    }
    Ok(())
}
