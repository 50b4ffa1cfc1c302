//! `synthcam calibrate <IMAGES | detections.json>... --target chessboard:COLSxROWS --square M`.

use std::path::PathBuf;

use anyhow::Context;
use nalgebra::{Point2, Point3};
use serde::Serialize;
use synthcam::calib::{calibrate, cross_validate, CalibModel, CalibParams, CalibResult, View};
use synthcam::camera::formats::{kalibr_yaml, mrcal_cameramodel, opencv_yaml, ros_yaml};
use synthcam::camera::{intrinsic_names, ImageSize, Lens};
use synthcam::dataset::{load_grey, write_atomic};
use synthcam::detect::target::{detect, TargetSpec};
use synthcam::report::calib::plot_png;

use super::skipped::Skipped;

/// Arguments of `calibrate`.
#[derive(Debug, clap::Args)]
pub struct CalibrateArgs {
    /// Images or folders (detected here), or one detections JSON written by `synthcam detect`.
    #[arg(required = true)]
    pub inputs: Vec<PathBuf>,
    /// Target: chessboard:COLSxROWS (inner corners).
    #[arg(long, value_parser = |s: &str| s.parse::<TargetSpec>())]
    pub target: TargetSpec,
    /// Square size, metres (the board's unit).
    #[arg(long)]
    pub square: f64,
    /// Also estimate the skew K[0][1].
    #[arg(long)]
    pub skew: bool,
    /// Lens model: opencv4, opencv5, opencv8, opencv12, opencv14, fisheye, double-sphere.
    #[arg(long, default_value = "opencv5", value_parser = |s: &str| s.parse::<CalibModel>())]
    pub model: CalibModel,
    /// Write the result as JSON.
    #[arg(long)]
    pub json: Option<PathBuf>,
    /// Write the result as OpenCV FileStorage YAML.
    #[arg(long)]
    pub opencv_yaml: Option<PathBuf>,
    /// Write the result as a ROS camera_info YAML.
    #[arg(long)]
    pub ros_yaml: Option<PathBuf>,
    /// Write the result as a Kalibr camchain YAML.
    #[arg(long)]
    pub kalibr_yaml: Option<PathBuf>,
    /// Write the result as an mrcal .cameramodel.
    #[arg(long)]
    pub mrcal: Option<PathBuf>,
    /// Plot per-view errors and residual vectors to this PNG.
    #[arg(long)]
    pub plot: Option<PathBuf>,
    /// Cross-validate over K folds of the views (K >= 2; view i in fold i mod K): each fold
    /// calibrated on the rest, its held-out views' RMS and its projection's difference from the
    /// full calibration in the JSON's `cross_validation`.
    #[arg(long, value_name = "K")]
    pub cross_validate: Option<usize>,
}

#[derive(Debug, Serialize)]
struct ViewOut {
    file: String,
    rms_px: f64,
    max_px: f64,
    rvec: [f64; 3],
    tvec: [f64; 3],
}

#[derive(Debug, Serialize)]
struct Output {
    image_size: [u32; 2],
    rms_px: f64,
    model: &'static str,
    #[serde(rename = "K")]
    k: [[f64; 3]; 3],
    #[serde(skip_serializing_if = "Option::is_none")]
    dist: Option<Vec<f64>>,
    #[serde(skip_serializing_if = "Option::is_none")]
    xi: Option<f64>,
    #[serde(skip_serializing_if = "Option::is_none")]
    alpha: Option<f64>,
    std: serde_json::Value,
    views: Vec<ViewOut>,
    used: usize,
    /// Inputs not used, each with the reason (board not found, unreadable, other image size).
    skipped: Vec<Skipped>,
    iterations: usize,
    converged: bool,
    /// Time of the calibration itself (after detection or loading), milliseconds.
    time_ms: f64,
    #[serde(skip_serializing_if = "Option::is_none")]
    cross_validation: Option<CrossOut>,
}

/// One fold of `--cross-validate`.
#[derive(Debug, Serialize)]
struct FoldOut {
    held_out: Vec<String>,
    fit_rms_px: f64,
    held_out_rms_px: f64,
    projection_diff_max_px: f64,
}

/// `--cross-validate` ([`synthcam::calib::cross_validate`]).
#[derive(Debug, Serialize)]
struct CrossOut {
    folds: usize,
    fit_rms_px: f64,
    held_out_rms_px: f64,
    projection_diff_rms_px: f64,
    projection_diff_max_px: f64,
    /// Sample standard deviation of each estimated intrinsic over the folds' cameras.
    intrinsics_spread: serde_json::Value,
    per_fold: Vec<FoldOut>,
}

/// The finite `values` by their `names`, as a JSON object.
fn named(names: &[&str], values: &[f64]) -> serde_json::Value {
    serde_json::Value::Object(names.iter().zip(values).filter(|(_, v)| v.is_finite()).map(|(n, v)| ((*n).to_string(), serde_json::json!(v))).collect())
}

/// `--cross-validate K` of the calibration `r` of `views` (the inputs `found`), printed and for
/// the JSON; `None` without the option.
fn cross_out(
    args: &CalibrateArgs,
    views: &[View],
    size: ImageSize,
    params: &CalibParams,
    r: &CalibResult,
    found: &[Found],
) -> anyhow::Result<Option<CrossOut>> {
    let Some(folds) = args.cross_validate else { return Ok(None) };
    let cv = cross_validate(views, size, params, r, folds).context("cross-validating")?;
    println!(
        "cross-validation, {folds} folds: held-out RMS {:.4} px (fit {:.4}); projection difference from the full calibration RMS {:.3} / max {:.3} px",
        cv.held_out_rms_px, r.rms_px, cv.projection_diff_rms_px, cv.projection_diff_max_px
    );
    let per_fold = cv
        .folds
        .iter()
        .map(|f| FoldOut {
            held_out: f.held_out.iter().map(|&i| found[i].0.clone()).collect(),
            fit_rms_px: f.fit_rms_px,
            held_out_rms_px: f.held_out_rms_px,
            projection_diff_max_px: f.projection_diff_max_px,
        })
        .collect();
    Ok(Some(CrossOut {
        folds,
        fit_rms_px: r.rms_px,
        held_out_rms_px: cv.held_out_rms_px,
        projection_diff_rms_px: cv.projection_diff_rms_px,
        projection_diff_max_px: cv.projection_diff_max_px,
        intrinsics_spread: named(&intrinsic_names(r.camera.lens.kind()), &cv.intrinsics_spread),
        per_fold,
    }))
}

/// (file, width, height, points) of one image in which the board was found.
type Found = (String, usize, usize, Vec<Point2<f64>>);
/// The images in which the board was found, and the skipped ones.
type Detections = (Vec<Found>, Vec<Skipped>);

fn from_json(path: &PathBuf, n: usize) -> anyhow::Result<Detections> {
    let text = std::fs::read_to_string(path).with_context(|| format!("reading {}", path.display()))?;
    let v: serde_json::Value = serde_json::from_str(&text).with_context(|| format!("{} is not JSON", path.display()))?;
    let images = v["images"].as_array().with_context(|| format!("{}: no `images` array (not a `synthcam detect` file)", path.display()))?;
    let (mut found, mut skipped) = (Vec::new(), Vec::new());
    for (i, im) in images.iter().enumerate() {
        let file = im["file"].as_str().map_or_else(|| format!("#{i}"), str::to_string);
        if im["found"].as_bool() != Some(true) {
            skipped.push(Skipped::new(file, "board not found"));
            continue;
        }
        let pts = im["points_px"].as_array().with_context(|| format!("{file}: `points_px` missing"))?;
        let pts: Vec<Point2<f64>> = pts
            .iter()
            .map(|p| match (p[0].as_f64(), p[1].as_f64()) {
                (Some(u), Some(v)) => Ok(Point2::new(u, v)),
                _ => anyhow::bail!("{file}: a point is not [u, v]"),
            })
            .collect::<anyhow::Result<_>>()?;
        anyhow::ensure!(pts.len() == n, "{file}: {} points, the target has {n}", pts.len());
        let w = im["width"].as_u64().with_context(|| format!("{file}: `width` missing"))? as usize;
        let h = im["height"].as_u64().with_context(|| format!("{file}: `height` missing"))? as usize;
        found.push((file, w, h, pts));
    }
    Ok((found, skipped))
}

/// The detections of the inputs: one detections JSON, or images detected here.
fn load_detections(args: &CalibrateArgs, n: usize) -> anyhow::Result<Detections> {
    if args.inputs.len() == 1 && args.inputs[0].extension().is_some_and(|e| e == "json") {
        return from_json(&args.inputs[0], n);
    }
    let (mut found, mut skipped) = (Vec::new(), Vec::new());
    for f in super::detect::expand_images(&args.inputs)? {
        let name = f.file_name().map_or_else(|| f.display().to_string(), |n| n.to_string_lossy().into_owned());
        match load_grey(&f) {
            Ok(img) => {
                let det = detect(&img, &args.target)?;
                if det.found {
                    found.push((name, img.width, img.height, det.points_px));
                } else {
                    skipped.push(Skipped::new(name, "board not found"));
                }
            }
            Err(e) => {
                eprintln!("error: {e}");
                skipped.push(Skipped::new(name, e.to_string()));
            }
        }
    }
    Ok((found, skipped))
}

/// Keep the images of the first image's size; the others go to `skipped` with a warning (one
/// camera has one image size: a resized or cropped frame would bias the intrinsics).
fn keep_first_size((found, mut skipped): Detections) -> Detections {
    let Some(&(_, w, h, _)) = found.first() else { return (found, skipped) };
    let (same, other): (Vec<Found>, Vec<Found>) = found.into_iter().partition(|f| f.1 == w && f.2 == h);
    skipped.extend(other.into_iter().map(|(file, fw, fh, _)| Skipped::other_size(file, (fw, fh), (w, h), "")));
    (same, skipped)
}

/// The camera files asked for, as (path, text); an error names the format that cannot hold the camera.
fn export_files<'a>(args: &'a CalibrateArgs, cam: &synthcam::camera::CameraModel, rms_px: f64) -> anyhow::Result<Vec<(&'a PathBuf, String)>> {
    let mut out = Vec::new();
    if let Some(p) = &args.opencv_yaml {
        out.push((p, opencv_yaml(cam, rms_px)?));
    }
    if let Some(p) = &args.ros_yaml {
        out.push((p, ros_yaml(cam, "synthcam")?));
    }
    if let Some(p) = &args.kalibr_yaml {
        out.push((p, kalibr_yaml(cam)?));
    }
    if let Some(p) = &args.mrcal {
        out.push((p, mrcal_cameramodel(cam)?));
    }
    Ok(out)
}

/// Run `calibrate`.
pub fn run(args: &CalibrateArgs) -> anyhow::Result<()> {
    let TargetSpec::Chessboard { cols, rows } = args.target else {
        anyhow::bail!("calibrate takes a chessboard target (chessboard:COLSxROWS)");
    };
    anyhow::ensure!(args.square.is_finite() && args.square > 0.0, "--square must be a positive number of metres, got {}", args.square);
    let n = cols * rows;
    let (found, skipped) = keep_first_size(load_detections(args, n)?);
    let Some(&(_, w, h, _)) = found.first() else { anyhow::bail!("the board was found in none of the inputs") };
    let board: Vec<Point3<f64>> = (0..n).map(|k| Point3::new((k % cols) as f64 * args.square, (k / cols) as f64 * args.square, 0.0)).collect();
    let views: Vec<View> = found.iter().map(|(_, _, _, pts)| board.iter().copied().zip(pts.iter().copied()).collect()).collect();
    let size = ImageSize { width: w as u32, height: h as u32 };
    let t0 = std::time::Instant::now();
    let params = CalibParams { estimate_skew: args.skew, model: args.model, ..Default::default() };
    let r = calibrate(&views, size, &params).context("calibrating")?;
    let time_ms = t0.elapsed().as_secs_f64() * 1e3;
    // Files the chosen formats cannot hold fail before anything is written.
    let files = export_files(args, &r.camera, r.rms_px)?;
    let k = r.camera.intrinsics;
    let std = named(&intrinsic_names(r.camera.lens.kind()), &r.std);
    let n_lens = args.model.n_lens_params();
    let (dist, xi, alpha) = match r.camera.lens {
        Lens::DoubleSphere(d) => (None, Some(d.xi), Some(d.alpha)),
        l => (Some(l.params()[..n_lens].to_vec()), None, None),
    };
    println!("{} views used, {} skipped; RMS {:.4} px", found.len(), skipped.len(), r.rms_px);
    println!(
        "fx {:.4} +- {:.4}  fy {:.4} +- {:.4}  cx {:.4} +- {:.4}  cy {:.4} +- {:.4}  skew {:.4}",
        k.fx, r.std[0], k.fy, r.std[1], k.cx, r.std[2], k.cy, r.std[3], k.skew
    );
    let lens_names = &r.camera.lens.kind().param_names()[..n_lens];
    println!("{} ({}) = {:?}", args.model, lens_names.join(", "), &r.camera.lens.params()[..n_lens]);
    let out = Output {
        image_size: [size.width, size.height],
        rms_px: r.rms_px,
        model: args.model.name(),
        k: [[k.fx, k.skew, k.cx], [0.0, k.fy, k.cy], [0.0, 0.0, 1.0]],
        dist,
        xi,
        alpha,
        std,
        views: found
            .iter()
            .zip(&r.views)
            .map(|((file, ..), v)| ViewOut { file: file.clone(), rms_px: v.rms_px, max_px: v.max_px, rvec: v.rvec.into(), tvec: v.tvec.into() })
            .collect(),
        used: found.len(),
        skipped,
        iterations: r.iterations,
        converged: r.converged,
        time_ms,
        cross_validation: cross_out(args, &views, size, &params, &r, &found)?,
    };
    if let Some(p) = &args.json {
        write_atomic(p, &serde_json::to_vec_pretty(&out)?)?;
    }
    for (p, text) in files {
        write_atomic(p, text.as_bytes())?;
    }
    if let Some(p) = &args.plot {
        let pts: Vec<Vec<Point2<f64>>> = found.iter().map(|f| f.3.clone()).collect();
        write_atomic(p, &plot_png(&r, &pts)?)?;
    }
    Ok(())
}
