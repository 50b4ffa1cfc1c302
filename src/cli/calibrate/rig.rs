//! `calibrate --rig CAM0 CAM1 [...]`: one input per camera, frames matched by file name,
//! [`synthcam::calib::calibrate_rig`], the rig's JSON and (`--kalibr-yaml`) its Kalibr camchain.

use std::path::{Path, PathBuf};

use anyhow::Context;
use serde::Serialize;
use synthcam::calib::{calibrate_rig, essential_fundamental, rectified_row_errors, stereo_rectify, CalibParams, RigCamera, RigResult};
use synthcam::camera::formats::{kalibr_camchain, mrcal_cameramodel_at, opencv_stereo_yaml, ros_yaml, ros_yaml_rectified, StereoPair};
use synthcam::camera::{intrinsic_names, ImageSize, Lens};
use synthcam::dataset::write_atomic;

use super::detections::{keep_first_size, load_detections, Found};
use super::{named, CalibrateArgs};

#[derive(Debug, Serialize)]
struct Pose {
    #[serde(rename = "R")]
    r: [[f64; 3]; 3],
    t_m: [f64; 3],
}

#[derive(Debug, Serialize)]
struct CameraOut {
    name: String,
    model: &'static str,
    image_size: [u32; 2],
    #[serde(rename = "K")]
    k: [[f64; 3]; 3],
    /// The lens parameters in the model's order (`synthcam::camera::intrinsic_names`).
    lens: Vec<f64>,
    std: serde_json::Value,
    cam0_from_cam: Pose,
    rotation_std_deg: [f64; 3],
    translation_std_m: [f64; 3],
    rms_px: f64,
    points: usize,
    views: usize,
}

#[derive(Debug, Serialize)]
struct RigOut {
    /// Over every camera's points, px (as `stereoCalibrate`'s).
    rms_px: f64,
    cameras: Vec<CameraOut>,
    frames: Vec<String>,
    iterations: usize,
    time_ms: f64,
    /// The first two cameras' corners after Bouguet's rectification: their row difference, px
    /// (`calib::rectified_row_errors`); null without a shared corner.
    rectified_row_error_mean_px: Option<f64>,
    rectified_row_error_max_px: Option<f64>,
}

/// One camera's detections: its name (the input's file name) and the boards found.
fn camera_inputs(args: &CalibrateArgs) -> anyhow::Result<Vec<(String, Vec<Found>)>> {
    args.inputs
        .iter()
        .map(|input| {
            let name = input.file_stem().map_or_else(|| input.display().to_string(), |n| n.to_string_lossy().into_owned());
            let (found, skipped) = keep_first_size(load_detections(std::slice::from_ref(input), args)?);
            for s in &skipped {
                eprintln!("{name}: skipped {} ({})", s.file, s.reason);
            }
            anyhow::ensure!(!found.is_empty(), "camera {name}: the board was found in none of its inputs");
            Ok((name, found))
        })
        .collect()
}

/// Run `calibrate --rig`.
pub(super) fn run_rig(args: &CalibrateArgs, params: &CalibParams) -> anyhow::Result<()> {
    anyhow::ensure!(args.inputs.len() >= 2, "--rig takes one input (a folder of images or a detections JSON) per camera, at least 2");
    anyhow::ensure!(!args.board_warp && args.cross_validate.is_none(), "--rig does not take --board-warp or --cross-validate yet");
    anyhow::ensure!(args.plot.is_none() && args.report.is_none(), "--rig does not write --plot or --report yet");
    anyhow::ensure!(
        args.opencv_yaml.is_none() || args.inputs.len() == 2,
        "--opencv-yaml with --rig writes a stereo pair: give two cameras, got {}",
        args.inputs.len()
    );
    let per_cam = camera_inputs(args)?;
    let mut frames: Vec<String> = per_cam.iter().flat_map(|(_, f)| f.iter().map(|x| x.file.clone())).collect();
    frames.sort();
    frames.dedup();
    let cams: Vec<RigCamera> = per_cam
        .iter()
        .enumerate()
        .map(|(i, (name, found))| {
            let missing = frames.iter().filter(|n| !found.iter().any(|f| &f.file == *n)).count();
            if missing > 0 {
                eprintln!(
                    "{name}: no board in {missing} of the {} frames (no image of that name, or not detected): those frames count as not seen by {name}",
                    frames.len()
                );
            }
            RigCamera {
                name: name.clone(),
                size: ImageSize { width: found[0].width as u32, height: found[0].height as u32 },
                params: CalibParams { model: args.model(i), ..*params },
                views: frames.iter().map(|n| found.iter().find(|f| &f.file == n).map(|f| f.view.clone())).collect(),
            }
        })
        .collect();
    let t0 = std::time::Instant::now();
    let r = calibrate_rig(&cams, params.max_iterations).context("calibrating the rig")?;
    let time_ms = t0.elapsed().as_secs_f64() * 1e3;
    print_rig(&r);
    let rows = rectified_row_errors(&r, &cams);
    if let Some((mean, max)) = rows {
        println!("rectified rows of {} and {}: mean {mean:.4} px, max {max:.4} px", r.cameras[0].name, r.cameras[1].name);
    }
    // A format that cannot hold a camera fails before anything is written.
    for (p, text) in rig_files(args, &r)? {
        write_atomic(&p, text.as_bytes())?;
    }
    if let Some(p) = &args.json {
        let out = RigOut {
            rms_px: r.rms_px,
            cameras: camera_outs(&r, &cams),
            frames,
            iterations: r.iterations,
            time_ms,
            rectified_row_error_mean_px: rows.map(|r| r.0),
            rectified_row_error_max_px: rows.map(|r| r.1),
        };
        write_atomic(p, &serde_json::to_vec_pretty(&out)?)?;
    }
    Ok(())
}

/// `path` with `name` before its extension (`out/cam.yaml` -> `out/cam.left.yaml`).
fn per_camera_path(path: &Path, name: &str) -> PathBuf {
    let stem = path.file_stem().map_or_else(|| "camera".to_string(), |s| s.to_string_lossy().into_owned());
    match path.extension() {
        Some(ext) => path.with_file_name(format!("{stem}.{name}.{}", ext.to_string_lossy())),
        None => path.with_file_name(format!("{stem}.{name}")),
    }
}

/// The camera files asked for, as (path, text); an error if a format cannot hold the rig.
fn rig_files(args: &CalibrateArgs, r: &RigResult) -> anyhow::Result<Vec<(PathBuf, String)>> {
    let mut out = Vec::new();
    let models: Vec<_> = r.cameras.iter().map(|c| c.camera).collect();
    if let Some(p) = &args.kalibr_yaml {
        let poses: Vec<_> = r.cameras.iter().map(|c| c.cam0_from_cam).collect();
        out.push((p.clone(), kalibr_camchain(&models, &poses)?));
    }
    let pair = match r.cameras.as_slice() {
        [c0, c1] if args.opencv_yaml.is_some() || args.ros_yaml.is_some() => {
            let cam1_from_cam0 = c1.cam0_from_cam.inverse();
            let rect = stereo_rectify(&c0.camera, &c1.camera, &cam1_from_cam0).context("rectifying the pair")?;
            let (e, f) = essential_fundamental(&c0.camera, &c1.camera, &cam1_from_cam0);
            let (r1, r2, p1, p2, q) = (rect.r1, rect.r2, rect.p1, rect.p2, rect.q);
            Some(StereoPair { cam0: &c0.camera, cam1: &c1.camera, cam1_from_cam0, e, f, r1, r2, p1, p2, q, rms_px: r.rms_px })
        }
        _ => None,
    };
    if let (Some(p), Some(pair)) = (&args.opencv_yaml, &pair) {
        out.push((p.clone(), opencv_stereo_yaml(pair)?));
    }
    if let Some(p) = &args.ros_yaml {
        for (i, c) in r.cameras.iter().enumerate() {
            let text = match &pair {
                Some(s) if i == 0 => ros_yaml_rectified(&c.camera, &c.name, &s.r1, &s.p1)?,
                Some(s) => ros_yaml_rectified(&c.camera, &c.name, &s.r2, &s.p2)?,
                None => ros_yaml(&c.camera, &c.name)?,
            };
            out.push((per_camera_path(p, &c.name), text));
        }
    }
    if let Some(p) = &args.mrcal {
        for c in &r.cameras {
            out.push((per_camera_path(p, &c.name), mrcal_cameramodel_at(&c.camera, &c.cam0_from_cam.inverse())?));
        }
    }
    Ok(out)
}

fn print_rig(r: &RigResult) {
    println!("{} cameras; RMS {:.4} px over every camera's points ({} iterations)", r.cameras.len(), r.rms_px, r.iterations);
    for c in &r.cameras {
        let t = c.cam0_from_cam.translation.vector;
        let angle = c.cam0_from_cam.rotation.angle().to_degrees();
        println!(
            "{}: RMS {:.4} px, fx {:.3} fy {:.3}; cam0_from_cam t = [{:.5}, {:.5}, {:.5}] m (sigma {:.2e} m), rotation {:.4} deg (sigma {:.2e} deg)",
            c.name,
            c.rms_px,
            c.camera.intrinsics.fx,
            c.camera.intrinsics.fy,
            t.x,
            t.y,
            t.z,
            c.translation_std.iter().map(|s| s * s).sum::<f64>().sqrt(),
            angle,
            c.rotation_std_deg.iter().map(|s| s * s).sum::<f64>().sqrt()
        );
    }
}

fn camera_outs(r: &RigResult, cams: &[RigCamera]) -> Vec<CameraOut> {
    r.cameras
        .iter()
        .zip(cams)
        .map(|(c, cam)| {
            let k = c.camera.intrinsics;
            let n_lens = cam.params.model.n_lens_params();
            let lens = match c.camera.lens {
                Lens::DoubleSphere(d) => vec![d.xi, d.alpha],
                l => l.params()[..n_lens].to_vec(),
            };
            let m = c.cam0_from_cam.rotation.to_rotation_matrix();
            let t = c.cam0_from_cam.translation.vector;
            CameraOut {
                name: c.name.clone(),
                model: cam.params.model.name(),
                image_size: [cam.size.width, cam.size.height],
                k: [[k.fx, k.skew, k.cx], [0.0, k.fy, k.cy], [0.0, 0.0, 1.0]],
                lens,
                std: named(&intrinsic_names(c.camera.lens.kind()), &c.std),
                cam0_from_cam: Pose { r: std::array::from_fn(|i| std::array::from_fn(|j| m[(i, j)])), t_m: [t.x, t.y, t.z] },
                rotation_std_deg: c.rotation_std_deg,
                translation_std_m: c.translation_std,
                rms_px: c.rms_px,
                points: c.points,
                views: cam.views.iter().filter(|v| v.is_some()).count(),
            }
        })
        .collect()
}
