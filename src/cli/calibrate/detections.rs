//! The views `calibrate` works on: detections from images (detected here) or from a `synthcam
//! detect` JSON file, each image's points with their board ids, minus the corners the detector
//! says a calibration should leave out.

use std::path::PathBuf;

use anyhow::Context;
use nalgebra::Point2;
use synthcam::dataset::load_grey;
use synthcam::detect::chessboard::corners_to_leave_out;
use synthcam::detect::target::detect;

use super::super::skipped::Skipped;
use super::CalibrateArgs;

/// One image in which the board was found.
#[derive(Debug)]
pub(super) struct Found {
    pub(super) file: String,
    pub(super) width: usize,
    pub(super) height: usize,
    /// Detected points, pixels.
    pub(super) points: Vec<Point2<f64>>,
    /// The board point of each (an index into [`board_points`]).
    pub(super) ids: Vec<u32>,
}

/// Fewest points a view of a coded board needs (a homography, with some to spare).
const MIN_VIEW_POINTS: usize = 8;

impl Found {
    /// A detection of a target with `n` board points: ids given (coded boards) or the whole
    /// board in order; `Err` with the reason to skip it.
    /// Points in `leave_out` (the detector's fit failed there, or it is far less certain than the
    /// rest of its view: [`corners_to_leave_out`]) are left out.
    fn new(
        file: String,
        (width, height): (usize, usize),
        points: Vec<Point2<f64>>,
        ids: Option<Vec<u32>>,
        leave_out: &[usize],
        n: usize,
    ) -> Result<Self, String> {
        let ids = match ids {
            Some(ids) => ids,
            None if points.len() == n => (0..n as u32).collect(),
            None => return Err(format!("{} points, the target has {n}", points.len())),
        };
        if ids.len() != points.len() || ids.iter().any(|&i| i as usize >= n) {
            return Err(format!("{} ids for {} points, or an id beyond the board's {n}", ids.len(), points.len()));
        }
        let (points, ids): (Vec<Point2<f64>>, Vec<u32>) =
            points.into_iter().zip(ids).enumerate().filter(|(k, _)| !leave_out.contains(k)).map(|(_, pi)| pi).unzip();
        if points.len() < MIN_VIEW_POINTS.min(n) {
            return Err(format!("only {} points (a view needs {MIN_VIEW_POINTS})", points.len()));
        }
        Ok(Self { file, width, height, points, ids })
    }
}

/// The images in which the board was found, and the skipped ones.
pub(super) type Detections = (Vec<Found>, Vec<Skipped>);

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
        let ids = match im.get("ids").and_then(|v| v.as_array()) {
            Some(ids) => Some(
                ids.iter()
                    .map(|i| i.as_u64().and_then(|i| u32::try_from(i).ok()).with_context(|| format!("{file}: an id is not a count")))
                    .collect::<anyhow::Result<Vec<u32>>>()?,
            ),
            None => None,
        };
        let w = im["width"].as_u64().with_context(|| format!("{file}: `width` missing"))? as usize;
        let h = im["height"].as_u64().with_context(|| format!("{file}: `height` missing"))? as usize;
        let untrusted: Vec<usize> =
            im.get("untrusted").and_then(|v| v.as_array()).map_or_else(Vec::new, |a| a.iter().filter_map(|k| k.as_u64()).map(|k| k as usize).collect());
        let sigma: Vec<f64> =
            im.get("position_sigma_px").and_then(|v| v.as_array()).map_or_else(Vec::new, |a| a.iter().map(|s| s.as_f64().unwrap_or(f64::INFINITY)).collect());
        match Found::new(file.clone(), (w, h), pts, ids, &corners_to_leave_out(&sigma, &untrusted), n) {
            Ok(f) => found.push(f),
            Err(why) if matches!(v["target"]["kind"].as_str(), Some("charuco" | "aprilgrid")) => skipped.push(Skipped::new(file, why)),
            Err(why) => anyhow::bail!("{file}: {why}"),
        }
    }
    Ok((found, skipped))
}

/// The detections of the inputs: one detections JSON, or images detected here.
pub(super) fn load_detections(args: &CalibrateArgs, n: usize) -> anyhow::Result<Detections> {
    if args.inputs.len() == 1 && args.inputs[0].extension().is_some_and(|e| e == "json") {
        return from_json(&args.inputs[0], n);
    }
    let (mut found, mut skipped) = (Vec::new(), Vec::new());
    let files = super::super::detect::expand_images(&args.inputs)?;
    let bar = super::super::progress::bar(files.len() as u64, "detect", "images");
    for f in bar.wrap_iter(files.into_iter()) {
        let name = f.file_name().map_or_else(|| f.display().to_string(), |n| n.to_string_lossy().into_owned());
        match load_grey(&f) {
            Ok(img) => {
                let det = detect(&img, &args.target)?;
                if !det.found {
                    skipped.push(Skipped::new(name, "board not found"));
                    continue;
                }
                let leave_out = corners_to_leave_out(det.position_sigma_px.as_deref().unwrap_or_default(), &det.untrusted);
                match Found::new(name.clone(), (img.width, img.height), det.points_px, det.ids, &leave_out, n) {
                    Ok(f) => found.push(f),
                    Err(why) => skipped.push(Skipped::new(name, why)),
                }
            }
            Err(e) => {
                bar.suspend(|| eprintln!("error: {e}"));
                skipped.push(Skipped::new(name, e.to_string()));
            }
        }
    }
    bar.finish_and_clear();
    Ok((found, skipped))
}

/// Keep the images of the first image's size; the others go to `skipped` with a warning (one
/// camera has one image size: a resized or cropped frame would bias the intrinsics).
pub(super) fn keep_first_size((found, mut skipped): Detections) -> Detections {
    let Some((w, h)) = found.first().map(|f| (f.width, f.height)) else { return (found, skipped) };
    let (same, other): (Vec<Found>, Vec<Found>) = found.into_iter().partition(|f| f.width == w && f.height == h);
    skipped.extend(other.into_iter().map(|f| Skipped::other_size(f.file, (f.width, f.height), (w, h), "")));
    (same, skipped)
}
