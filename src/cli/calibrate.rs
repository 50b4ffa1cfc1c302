//! `synthcam calibrate <IMAGES | detections.json>... --target chessboard:COLSxROWS | charuco:NXxNY:DICT:RATIO --square M`.
//!
//! Coded boards calibrate from partial views: each view's points are matched to the board by id.

use std::path::PathBuf;

use anyhow::Context;
use nalgebra::Point2;
use serde::Serialize;
use synthcam::calib::{calibrate, cross_validate, BoardExtent, CalibModel, CalibParams, CalibResult, View};
use synthcam::camera::formats::{kalibr_yaml, mrcal_cameramodel, opencv_yaml, ros_yaml};
use synthcam::camera::{intrinsic_names, ImageSize, Lens};
use synthcam::dataset::write_atomic;
use synthcam::detect::target::TargetSpec;
use synthcam::report::calib::{document, plot_png, CalibInputs};
use synthcam::report::doc::{Block, Document};

use super::skipped::Skipped;
use detections::{keep_first_size, load_detections, Found};

mod detections;
mod output;
mod rig;
mod summary;

use summary::{print_result, undetermined_names};

use output::{uncertainty_out, RejectionOut, SearchOut, UncertaintyOut};

/// Arguments of `calibrate`.
#[derive(Debug, clap::Args)]
pub struct CalibrateArgs {
    /// Images or folders (detected here), or one detections JSON written by `synthcam detect`.
    #[arg(required = true)]
    pub inputs: Vec<PathBuf>,
    /// Target: chessboard:COLSxROWS (inner corners) or charuco:NXxNY:DICT:MARKER_OVER_SQUARE[:legacy].
    #[arg(long, value_parser = |s: &str| s.parse::<TargetSpec>())]
    pub target: TargetSpec,
    /// Square size, metres (the board's unit; ChArUco: the square; AprilGrid: the tag).
    #[arg(long)]
    pub square: f64,
    /// Also estimate the skew K[0][1].
    #[arg(long)]
    pub skew: bool,
    /// Lens model: opencv4, opencv5, opencv8, opencv12, opencv14, fisheye, double-sphere. With
    /// --rig, one for every camera or one per camera in the inputs' order (`--model fisheye
    /// --model opencv5`, or `--model fisheye,opencv5`).
    #[arg(long, default_value = "opencv5", value_delimiter = ',', value_parser = |s: &str| s.parse::<CalibModel>())]
    pub model: Vec<CalibModel>,
    /// Write the result as JSON.
    #[arg(long)]
    pub json: Option<PathBuf>,
    /// Write the result as OpenCV FileStorage YAML (--rig with two cameras: the stereo pair's
    /// K1 D1 K2 D2 R T E F and stereoRectify's R1 R2 P1 P2 Q).
    #[arg(long)]
    pub opencv_yaml: Option<PathBuf>,
    /// Write the result as a ROS camera_info YAML (--rig: one file per camera, `PATH` with the
    /// camera's name before the extension; a stereo pair's with its rectification R and P).
    #[arg(long)]
    pub ros_yaml: Option<PathBuf>,
    /// Write the result as a Kalibr camchain YAML.
    #[arg(long)]
    pub kalibr_yaml: Option<PathBuf>,
    /// Write the result as an mrcal .cameramodel (--rig: one per camera, named as --ros-yaml's,
    /// extrinsics `rt_cam_ref` = camN_from_cam0).
    #[arg(long)]
    pub mrcal: Option<PathBuf>,
    /// Plot per-view errors and residual vectors to this PNG.
    #[arg(long)]
    pub plot: Option<PathBuf>,
    /// Write report.md, report.html (intrinsics, per-view errors, skipped inputs, the plot) and
    /// calibration.png into this folder.
    #[arg(long, value_name = "DIR")]
    pub report: Option<PathBuf>,
    /// Estimate the board's warp (mrcal's model: sags `kx`, `ky` at the centre along the board's x
    /// and y, a paraboloid over the board's points; JSON `board_warp_m`).
    #[arg(long)]
    pub board_warp: bool,
    /// Drop points whose residual exceeds this many robust standard deviations of the residuals,
    /// then fit again (listed per view in the JSON's `views[i].outliers`).
    #[arg(long, value_name = "K", default_value_t = synthcam::calib::DEFAULT_OUTLIER_THRESHOLD)]
    pub outlier_threshold: f64,
    /// Keep every point (no outlier rejection; what OpenCV's calibrateCamera does).
    #[arg(long, conflicts_with = "outlier_threshold")]
    pub keep_outliers: bool,
    /// The projection uncertainty map's cells, COLSxROWS (JSON `projection_uncertainty`, the
    /// report's map).
    #[arg(long, value_name = "COLSxROWS", default_value = "16x12", value_parser = parse_grid)]
    pub uncertainty_grid: (u32, u32),
    /// Range (metres from the camera) at which the projection uncertainty is evaluated; default
    /// at infinity (mrcal's default).
    #[arg(long, value_name = "M")]
    pub uncertainty_range: Option<f64>,
    /// A rig: each input is one camera (a folder of its images, or its detections JSON; the
    /// camera is named after it), frames matched by file name; every camera's intrinsics and
    /// `cam0_from_cam` estimated in one bundle adjustment (JSON `cameras[i]`).
    #[arg(long)]
    pub rig: bool,
    /// Cross-validate over K folds of the views (K >= 2; view i in fold i mod K): each fold
    /// calibrated on the rest, its held-out views' RMS and its projection's difference from the
    /// full calibration in the JSON's `cross_validation`.
    #[arg(long, value_name = "K")]
    pub cross_validate: Option<usize>,
}

/// `COLSxROWS`, both 1-1000.
fn parse_grid(s: &str) -> Result<(u32, u32), String> {
    let (c, r) = s.split_once('x').ok_or_else(|| format!("expected COLSxROWS, got {s:?}"))?;
    let parse = |v: &str| v.parse::<u32>().ok().filter(|n| (1..=1000).contains(n)).ok_or_else(|| format!("{v:?} is not a count of cells in 1-1000"));
    Ok((parse(c)?, parse(r)?))
}

#[derive(Debug, Serialize)]
struct ViewOut {
    file: String,
    /// Points given (a coded board's partial views hold fewer than the board), outliers included.
    points: usize,
    /// Indices (into the detection's `points_px`) of the points dropped as outliers.
    outliers: Vec<usize>,
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
    /// Parameters the data do not determine (their `std` is null): the views leave them free.
    undetermined: Vec<String>,
    /// `--board-warp`: the sags `[kx, ky]` at the board's centre, metres (+ along the board
    /// frame's z), and their standard deviations.
    #[serde(skip_serializing_if = "Option::is_none")]
    board_warp_m: Option<[f64; 2]>,
    #[serde(skip_serializing_if = "Option::is_none")]
    board_warp_std_m: Option<[f64; 2]>,
    views: Vec<ViewOut>,
    used: usize,
    /// Inputs not used, each with the reason (board not found, unreadable, other image size).
    skipped: Vec<Skipped>,
    iterations: usize,
    converged: bool,
    /// Time of the calibration itself (after detection or loading), milliseconds.
    time_ms: f64,
    /// How the optimum was searched for (starts, perturbed restarts).
    search: SearchOut,
    /// The outlier rejection.
    rejection: RejectionOut,
    projection_uncertainty: UncertaintyOut,
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

/// The `values` by their `names`, as a JSON object: NaN (a fixed parameter) left out, infinite
/// (a parameter the data do not determine) as null.
fn named(names: &[&str], values: &[f64]) -> serde_json::Value {
    serde_json::Value::Object(names.iter().zip(values).filter(|(_, v)| !v.is_nan()).map(|(n, v)| ((*n).to_string(), serde_json::json!(v))).collect())
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
            held_out: f.held_out.iter().map(|&i| found[i].file.clone()).collect(),
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

/// The options' checks that need no input read.
fn check_args(args: &CalibrateArgs) -> anyhow::Result<()> {
    anyhow::ensure!(args.square.is_finite() && args.square > 0.0, "--square must be a positive number of metres, got {}", args.square);
    anyhow::ensure!(
        args.outlier_threshold.is_finite() && args.outlier_threshold > 0.0,
        "--outlier-threshold must be a positive number of standard deviations, got {}",
        args.outlier_threshold
    );
    if let Some(r) = args.uncertainty_range {
        anyhow::ensure!(r.is_finite() && r > 0.0, "--uncertainty-range must be a positive number of metres, got {r}");
    }
    // before detecting any image (the library's views_from_detections refuses it too, afterwards)
    anyhow::ensure!(
        args.target.board_points_m(args.square).is_some(),
        "calibrate takes a chessboard, ChArUco or AprilGrid target (chessboard:COLSxROWS, charuco:NXxNY:DICT:RATIO, aprilgrid:NXxNY:tag36h11:SPACING)"
    );
    anyhow::ensure!(
        args.model.len() == 1 || (args.rig && args.model.len() == args.inputs.len()),
        "--model takes one model, or with --rig one per camera ({} inputs), got {}",
        args.inputs.len(),
        args.model.len()
    );
    Ok(())
}

impl CalibrateArgs {
    /// The model of camera `i` (the single camera's is `model(0)`).
    fn model(&self, i: usize) -> CalibModel {
        self.model.get(i).or(self.model.first()).copied().unwrap_or_default()
    }
}

/// The library's options from the command line's.
fn params_of(args: &CalibrateArgs) -> anyhow::Result<CalibParams> {
    let board_warp = if args.board_warp {
        let points = args.target.board_points_m(args.square).unwrap_or_default();
        Some(BoardExtent::of(points).context("the board's points span no area: no warp to estimate")?)
    } else {
        None
    };
    let outlier_threshold = (!args.keep_outliers).then_some(args.outlier_threshold);
    Ok(CalibParams { estimate_skew: args.skew, model: args.model(0), outlier_threshold, board_warp, ..Default::default() })
}

/// Each view's line of the JSON.
fn view_outs(found: &[Found], r: &CalibResult) -> Vec<ViewOut> {
    found
        .iter()
        .zip(&r.views)
        .map(|(f, v)| ViewOut {
            file: f.file.clone(),
            points: f.view.len(),
            outliers: v.outliers.iter().filter_map(|&j| f.point_index.get(j).copied()).collect(),
            rms_px: v.rms_px,
            max_px: v.max_px,
            rvec: v.rvec.into(),
            tvec: v.tvec.into(),
        })
        .collect()
}

/// Run `calibrate`.
pub fn run(args: &CalibrateArgs) -> anyhow::Result<()> {
    check_args(args)?;
    if args.rig {
        return rig::run_rig(args, &params_of(args)?);
    }
    let (found, skipped) = keep_first_size(load_detections(&args.inputs, args)?);
    let Some(first) = found.first() else { anyhow::bail!("the board was found in none of the inputs") };
    let size = ImageSize { width: first.width as u32, height: first.height as u32 };
    let views: Vec<View> = found.iter().map(|f| f.view.clone()).collect();
    let t0 = std::time::Instant::now();
    let params = params_of(args)?;
    let r = calibrate(&views, size, &params).context("calibrating")?;
    let time_ms = t0.elapsed().as_secs_f64() * 1e3;
    let (cols, rows) = args.uncertainty_grid;
    let map = r.uncertainty_map(&views, cols, rows, args.uncertainty_range);
    // Files the chosen formats cannot hold fail before anything is written.
    let files = export_files(args, &r.camera, r.rms_px)?;
    let k = r.camera.intrinsics;
    let n_lens = args.model(0).n_lens_params();
    let (dist, xi, alpha) = match r.camera.lens {
        Lens::DoubleSphere(d) => (None, Some(d.xi), Some(d.alpha)),
        l => (Some(l.params()[..n_lens].to_vec()), None, None),
    };
    let undetermined = undetermined_names(&r);
    print_result(args, &r, &map, &undetermined, (found.len(), skipped.len()));
    let out = Output {
        image_size: [size.width, size.height],
        rms_px: r.rms_px,
        model: args.model(0).name(),
        k: [[k.fx, k.skew, k.cx], [0.0, k.fy, k.cy], [0.0, 0.0, 1.0]],
        dist,
        xi,
        alpha,
        std: named(&intrinsic_names(r.camera.lens.kind()), &r.std),
        undetermined,
        board_warp_m: args.board_warp.then_some(r.board_warp.k),
        board_warp_std_m: args.board_warp.then_some(r.board_warp_std),
        views: view_outs(&found, &r),
        used: found.len(),
        skipped,
        iterations: r.iterations,
        converged: r.converged,
        time_ms,
        search: SearchOut::from(&r.search),
        rejection: RejectionOut::from(&r.rejection),
        projection_uncertainty: uncertainty_out(&map),
        cross_validation: cross_out(args, &views, size, &params, &r, &found)?,
    };
    if let Some(p) = &args.json {
        write_atomic(p, &serde_json::to_vec_pretty(&out)?)?;
    }
    for (p, text) in files {
        write_atomic(p, text.as_bytes())?;
    }
    let pts: Vec<Vec<Point2<f64>>> = found.iter().map(|f| f.view.iter().map(|(_, q)| *q).collect()).collect();
    if let Some(p) = &args.plot {
        write_atomic(p, &plot_png(&r, &pts)?)?;
    }
    if let Some(dir) = &args.report {
        let files: Vec<String> = found.iter().map(|f| f.file.clone()).collect();
        let skipped: Vec<(String, String)> = out.skipped.iter().map(|s| (s.file.clone(), s.reason.clone())).collect();
        let inputs =
            CalibInputs { model: args.model(0).name(), lens_params: n_lens, files: &files, points_px: &pts, skipped: &skipped, uncertainty: Some(&map) };
        write_report(dir, &document(&r, &inputs)?)?;
    }
    Ok(())
}

/// `--report DIR`: the plot, report.md and report.html.
fn write_report(dir: &std::path::Path, doc: &Document) -> anyhow::Result<()> {
    std::fs::create_dir_all(dir).with_context(|| format!("creating {}", dir.display()))?;
    for b in &doc.blocks {
        if let Block::Image { link: Some(link), png, .. } = b {
            write_atomic(&dir.join(link), png)?;
        }
    }
    super::write_document(dir, Some("report.md"), doc)
}
