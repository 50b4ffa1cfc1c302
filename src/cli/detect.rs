//! `synthcam detect <IMAGES>... --target chessboard:COLSxROWS | dot-grid:NxN | s-path |
//! charuco:NXxNY:DICT:MARKER_OVER_SQUARE[:legacy][:first_id=N]`.

use std::path::{Path, PathBuf};

use anyhow::Context;
use serde::Serialize;
use synthcam::dataset::{load_grey_u8, write_atomic};
use synthcam::detect::target::{detect_u8_with_camera, Detection, TargetSpec};
use synthcam::report::overlay::draw_points;

/// Arguments of `detect`.
#[derive(Debug, clap::Args)]
pub struct DetectArgs {
    /// Image files or folders (PNG, JPEG; folders are read in name order).
    #[arg(required = true)]
    pub images: Vec<PathBuf>,
    /// Target: chessboard:COLSxROWS (inner corners), dot-grid:NxN, s-path, or
    /// charuco:NXxNY:DICT:MARKER_OVER_SQUARE[:legacy][:first_id=N] (squares, OpenCV dictionary,
    /// e.g. charuco:11x8:DICT_5X5_100:0.733).
    #[arg(long, value_parser = |s: &str| s.parse::<TargetSpec>())]
    pub target: TargetSpec,
    /// Write the detections as JSON here.
    #[arg(long)]
    pub json: Option<PathBuf>,
    /// Write each image with its points and their order drawn into this folder.
    #[arg(long)]
    pub draw: Option<PathBuf>,
    /// The camera that took the images (any camera file `calibrate` writes: OpenCV, ROS,
    /// Kalibr, mrcal). S-path only: its dots are then placed by the camera's pose, which tells
    /// apart shifts along the path that dots strayed from their nominal points make ambiguous.
    #[arg(long)]
    pub camera: Option<PathBuf>,
    /// Accepted for old scripts and ignored: `detect` takes every image on its own, whatever its
    /// size (only `calibrate` needs one size, and skips the others).
    #[arg(long, hide = true)]
    pub any_size: bool,
}

/// One image's result, as written to JSON.
#[derive(Debug, Serialize)]
struct ImageResult {
    file: String,
    #[serde(skip_serializing_if = "Option::is_none")]
    width: Option<usize>,
    #[serde(skip_serializing_if = "Option::is_none")]
    height: Option<usize>,
    found: bool,
    #[serde(skip_serializing_if = "Vec::is_empty")]
    points_px: Vec<[f64; 2]>,
    #[serde(skip_serializing_if = "Option::is_none")]
    indices: Option<Vec<usize>>,
    /// Coded boards: the id of each point (ChArUco: OpenCV's chessboard-corner id).
    #[serde(skip_serializing_if = "Option::is_none")]
    ids: Option<Vec<u32>>,
    /// Chessboards: each point's position sigma from its own fit, px (null: the fit failed).
    #[serde(skip_serializing_if = "Option::is_none")]
    position_sigma_px: Option<Vec<Option<f64>>>,
    /// Chessboards: indices of points not placed within 0.1 px (left out by `calibrate`).
    #[serde(skip_serializing_if = "Vec::is_empty")]
    untrusted: Vec<usize>,
    /// S-path: each dot's residual against the fit of the whole nominal path, px.
    #[serde(skip_serializing_if = "Option::is_none")]
    path_residuals_px: Option<Vec<[f64; 2]>>,
    /// S-path: each dot's apparent deviation from its nominal place on the target, mm.
    #[serde(skip_serializing_if = "Option::is_none")]
    path_deviation_mm: Option<Vec<f64>>,
    /// S-path: RMS of `path_residuals_px`.
    #[serde(skip_serializing_if = "Option::is_none")]
    path_residual_rms_px: Option<f64>,
    /// S-path: indices of dots placed but not reported (touching a neighbour: no measurement).
    #[serde(skip_serializing_if = "Option::is_none")]
    unmeasured_indices: Option<Vec<usize>>,
    #[serde(skip_serializing_if = "Option::is_none")]
    time_ms: Option<f64>,
    #[serde(skip_serializing_if = "Option::is_none")]
    note: Option<String>,
    #[serde(skip_serializing_if = "Option::is_none")]
    error: Option<String>,
}

#[derive(Debug, Serialize)]
struct Output {
    target: TargetSpec,
    pixel_convention: &'static str,
    images: Vec<ImageResult>,
}

/// Expand folders into their image files, in name order.
pub fn expand_images(inputs: &[PathBuf]) -> anyhow::Result<Vec<PathBuf>> {
    let mut out = Vec::new();
    for p in inputs {
        if p.is_dir() {
            let mut files: Vec<PathBuf> = std::fs::read_dir(p)
                .with_context(|| format!("reading folder {}", p.display()))?
                .filter_map(|e| e.ok().map(|e| e.path()))
                .filter(|f| f.extension().and_then(|e| e.to_str()).is_some_and(|e| matches!(e.to_ascii_lowercase().as_str(), "png" | "jpg" | "jpeg")))
                .collect();
            files.sort();
            out.extend(files);
        } else {
            out.push(p.clone());
        }
    }
    Ok(out)
}

fn file_name(p: &Path) -> String {
    p.file_name().map(|n| n.to_string_lossy().into_owned()).unwrap_or_else(|| p.display().to_string())
}

impl ImageResult {
    /// A file that could not be read.
    fn unreadable(file: String, e: &dyn std::fmt::Display) -> Self {
        Self {
            file,
            width: None,
            height: None,
            found: false,
            points_px: Vec::new(),
            indices: None,
            ids: None,
            position_sigma_px: None,
            untrusted: Vec::new(),
            path_residuals_px: None,
            path_deviation_mm: None,
            path_residual_rms_px: None,
            unmeasured_indices: None,
            time_ms: None,
            note: None,
            error: Some(e.to_string()),
        }
    }

    /// A detection (found or not) on an image of `size`.
    fn detected(file: String, size: (usize, usize), det: Detection, time_ms: f64) -> Self {
        let residuals = det.path_residuals.as_ref();
        Self {
            file,
            width: Some(size.0),
            height: Some(size.1),
            found: det.found,
            points_px: det.points_px.iter().map(|p| [p.x, p.y]).collect(),
            path_residuals_px: residuals.map(|r| r.iter().map(|p| [p.residual_px.x, p.residual_px.y]).collect()),
            path_deviation_mm: residuals.map(|r| r.iter().map(|p| 1e3 * p.deviation_m).collect()),
            path_residual_rms_px: residuals.map(|r| (r.iter().map(|p| p.residual_px.norm_squared()).sum::<f64>() / r.len().max(1) as f64).sqrt()),
            indices: det.indices,
            ids: det.ids,
            position_sigma_px: det.position_sigma_px.map(|v| v.into_iter().map(|s| s.is_finite().then_some(s)).collect()),
            untrusted: det.untrusted,
            unmeasured_indices: det.unmeasured,
            time_ms: Some(time_ms),
            note: det.note,
            error: None,
        }
    }
}

/// The detected points drawn on the image, as `dir/<stem>.png`.
fn write_overlay(dir: &Path, file: &Path, img: &synthcam::detect::ImageU8, points: &[nalgebra::Point2<f64>]) -> anyhow::Result<()> {
    let overlay = draw_points(&img.to_f32(), points);
    let mut png = Vec::new();
    image::DynamicImage::ImageRgb8(overlay).write_to(&mut std::io::Cursor::new(&mut png), image::ImageFormat::Png).context("encoding overlay")?;
    let stem = file.file_stem().map(|s| s.to_string_lossy().into_owned()).unwrap_or_else(|| "image".into());
    Ok(write_atomic(&dir.join(format!("{stem}.png")), &png)?)
}

/// The camera of `--camera`, refused for targets that do not use it.
fn read_camera(args: &DetectArgs) -> anyhow::Result<Option<synthcam::camera::CameraModel>> {
    let Some(path) = &args.camera else { return Ok(None) };
    if !matches!(args.target, TargetSpec::SPath { .. }) {
        anyhow::bail!("--camera is used by --target s-path only");
    }
    let text = std::fs::read_to_string(path).with_context(|| format!("reading camera file {}", path.display()))?;
    Ok(Some(synthcam::camera::formats::read(&text).with_context(|| format!("reading camera file {}", path.display()))?))
}

/// Run `detect`.
pub fn run(args: &DetectArgs) -> anyhow::Result<()> {
    let files = expand_images(&args.images)?;
    if files.is_empty() {
        anyhow::bail!("no images found in {:?}", args.images);
    }
    if let Some(dir) = &args.draw {
        std::fs::create_dir_all(dir).with_context(|| format!("creating {}", dir.display()))?;
    }
    let camera = read_camera(args)?;
    let mut results = Vec::new();
    let mut errors = 0;
    for f in &files {
        let name = file_name(f);
        let img = match load_grey_u8(f) {
            Ok(i) => i,
            Err(e) => {
                eprintln!("error: {e}");
                errors += 1;
                results.push(ImageResult::unreadable(name, &e));
                continue;
            }
        };
        // time_ms: detection on the decoded 8-bit image (as OpenCV's call on a uint8 array); any
        // conversion to f32 the detector needs is included
        let t0 = std::time::Instant::now();
        let det = detect_u8_with_camera(&img, &args.target, camera.as_ref()).with_context(|| format!("detecting in {}", f.display()))?;
        let time_ms = t0.elapsed().as_secs_f64() * 1e3;
        if args.json.is_none() {
            println!(
                "{name}: {} ({} points, {time_ms:.2} ms){}",
                if det.found { "found" } else { "not found" },
                det.points_px.len(),
                det.note.as_ref().map(|n| format!(": {n}")).unwrap_or_default()
            );
        }
        if let Some(dir) = &args.draw {
            write_overlay(dir, f, &img, &det.points_px)?;
        }
        results.push(ImageResult::detected(name, (img.width, img.height), det, time_ms));
    }
    let found = results.iter().filter(|r| r.found).count();
    if let Some(path) = &args.json {
        let out = Output { target: args.target, pixel_convention: "OpenCV: the centre of the top-left pixel is (0, 0)", images: results };
        let bytes = serde_json::to_vec_pretty(&out).context("serialising JSON")?;
        write_atomic(path, &bytes)?;
        println!("{found} of {} images found; wrote {}", files.len(), path.display());
    } else {
        println!("{found} of {} images found", files.len());
    }
    if errors > 0 {
        anyhow::bail!("{errors} of {} files could not be read", files.len());
    }
    Ok(())
}
