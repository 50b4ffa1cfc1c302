//! The views `calibrate` works on: detections from images (detected here) or from a `synthcam
//! detect` JSON file, made into views by the library's `views_from_detections` (each image's
//! points with their board points, minus the corners the detector says to leave out).

use std::path::PathBuf;

use anyhow::Context;
use nalgebra::Point2;
use synthcam::calib::{views_from_detections, CalibError, View};
use synthcam::dataset::load_grey;
use synthcam::detect::target::{detect, Detection, TargetSpec};

use super::super::skipped::Skipped;
use super::CalibrateArgs;

/// One image in which the board was found, as the calibration uses it.
#[derive(Debug)]
pub(super) struct Found {
    pub(super) file: String,
    pub(super) width: usize,
    pub(super) height: usize,
    /// Board points (the target's frame) and their detected pixels, without the corners the
    /// detector says to leave out ([`views_from_detections`]).
    pub(super) view: View,
    /// The index (into the detection's points) of each point of `view`.
    pub(super) point_index: Vec<usize>,
}

/// Detections and their images' names and sizes, in input order.
#[derive(Default)]
struct Inputs {
    images: Vec<(String, (usize, usize))>,
    detections: Vec<Detection>,
}

impl Inputs {
    fn push(&mut self, file: String, size: (usize, usize), det: Detection) {
        self.images.push((file, size));
        self.detections.push(det);
    }

    /// The views the library makes of them, each with its image (one rule for the CLI and Python).
    fn into_views(self, target: &TargetSpec, square_m: f64, mut skipped: Vec<Skipped>) -> anyhow::Result<Detections> {
        let v = views_from_detections(&self.detections, target, square_m).map_err(|e| match &e {
            CalibError::BadDetection { index, reason } => anyhow::anyhow!("{}: {reason}", self.images[*index].0),
            _ => anyhow::Error::new(e),
        })?;
        skipped.extend(v.skipped.into_iter().map(|s| Skipped::new(self.images[s.index].0.clone(), s.reason)));
        let found = v
            .used
            .into_iter()
            .zip(v.views)
            .zip(v.point_indices)
            .map(|((i, view), point_index)| {
                let (file, (width, height)) = self.images[i].clone();
                Found { file, width, height, view, point_index }
            })
            .collect();
        Ok((found, skipped))
    }
}

/// The images in which the board was found, and the skipped ones.
pub(super) type Detections = (Vec<Found>, Vec<Skipped>);

/// A number array of a detection JSON image entry (`None` when absent; non-numbers infinite).
fn numbers(im: &serde_json::Value, key: &str) -> Option<Vec<f64>> {
    im.get(key).and_then(|v| v.as_array()).map(|a| a.iter().map(|s| s.as_f64().unwrap_or(f64::INFINITY)).collect())
}

/// One image of a `synthcam detect` JSON file as the detection it records.
fn detection_of(im: &serde_json::Value, file: &str) -> anyhow::Result<Detection> {
    let pts = im["points_px"].as_array().with_context(|| format!("{file}: `points_px` missing"))?;
    let points_px = pts
        .iter()
        .map(|p| match (p[0].as_f64(), p[1].as_f64()) {
            (Some(u), Some(v)) => Ok(Point2::new(u, v)),
            _ => anyhow::bail!("{file}: a point is not [u, v]"),
        })
        .collect::<anyhow::Result<_>>()?;
    let ids = match im.get("ids").and_then(|v| v.as_array()) {
        Some(ids) => Some(
            ids.iter()
                .map(|i| i.as_u64().and_then(|i| u32::try_from(i).ok()).with_context(|| format!("{file}: an id is not a count")))
                .collect::<anyhow::Result<Vec<u32>>>()?,
        ),
        None => None,
    };
    let untrusted = numbers(im, "untrusted").unwrap_or_default().into_iter().filter(|k| k.is_finite() && *k >= 0.0).map(|k| k as usize).collect();
    Ok(Detection { found: true, points_px, ids, position_sigma_px: numbers(im, "position_sigma_px"), untrusted, ..Default::default() })
}

fn from_json(path: &PathBuf, args: &CalibrateArgs) -> anyhow::Result<Detections> {
    let text = std::fs::read_to_string(path).with_context(|| format!("reading {}", path.display()))?;
    let v: serde_json::Value = serde_json::from_str(&text).with_context(|| format!("{} is not JSON", path.display()))?;
    let images = v["images"].as_array().with_context(|| format!("{}: no `images` array (not a `synthcam detect` file)", path.display()))?;
    let mut inputs = Inputs::default();
    for (i, im) in images.iter().enumerate() {
        let file = im["file"].as_str().map_or_else(|| format!("#{i}"), str::to_string);
        let w = im["width"].as_u64().with_context(|| format!("{file}: `width` missing"))? as usize;
        let h = im["height"].as_u64().with_context(|| format!("{file}: `height` missing"))? as usize;
        let det = if im["found"].as_bool() == Some(true) { detection_of(im, &file)? } else { Detection::default() };
        inputs.push(file, (w, h), det);
    }
    inputs.into_views(&args.target, args.square, Vec::new())
}

/// The detections of the inputs: one detections JSON, or images detected here.
pub(super) fn load_detections(paths: &[PathBuf], args: &CalibrateArgs) -> anyhow::Result<Detections> {
    if paths.len() == 1 && paths[0].extension().is_some_and(|e| e == "json") {
        return from_json(&paths[0], args);
    }
    let (mut inputs, mut skipped) = (Inputs::default(), Vec::new());
    let files = super::super::detect::expand_images(paths)?;
    let bar = super::super::progress::bar(files.len() as u64, "detect", "images");
    for f in bar.wrap_iter(files.into_iter()) {
        let name = f.file_name().map_or_else(|| f.display().to_string(), |n| n.to_string_lossy().into_owned());
        match load_grey(&f) {
            Ok(img) => {
                let det = detect(&img, &args.target)?;
                inputs.push(name, (img.width, img.height), det);
            }
            Err(e) => {
                bar.suspend(|| eprintln!("error: {e}"));
                skipped.push(Skipped::new(name, e.to_string()));
            }
        }
    }
    bar.finish_and_clear();
    inputs.into_views(&args.target, args.square, skipped)
}

/// Keep the images of the first image's size; the others go to `skipped` with a warning (one
/// camera has one image size: a resized or cropped frame would bias the intrinsics).
pub(super) fn keep_first_size((found, mut skipped): Detections) -> Detections {
    let Some((w, h)) = found.first().map(|f| (f.width, f.height)) else { return (found, skipped) };
    let (same, other): (Vec<Found>, Vec<Found>) = found.into_iter().partition(|f| f.width == w && f.height == h);
    skipped.extend(other.into_iter().map(|f| Skipped::other_size(f.file, (f.width, f.height), (w, h), "")));
    (same, skipped)
}
