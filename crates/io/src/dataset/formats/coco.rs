//! COCO keypoints JSON (<https://cocodataset.org/#format-data>): one image per dataset image, one
//! annotation per image (the target), one category (the target kind) whose keypoints are the
//! target's features in their documented order.
//!
//! Keypoints are the truth's `pixel_px` unchanged, in synthcam's (OpenCV's) pixel convention:
//! the centre of the top-left pixel is (0, 0). Tools that put pixel centres at +0.5 (the top-left
//! pixel spans [0, 1]) must add `info.pixel_centre_offset_px` (0.5) to x and y. Visibility `v`:
//! 2 visible, 1 inside the image but hidden (by an object, or a dot by the target itself), 0
//! outside the image or behind the camera (then x = y = 0, as COCO requires). `bbox` and `area`
//! are the bounding box of the labelled (v > 0) keypoints.

use serde_json::{json, Value};

use super::FormatError;
use crate::dataset::DatasetError;
use synthcam_scene::truth::{FeatureLabel, TruthLabels};

/// The `info.pixel_convention` text.
pub const PIXEL_CONVENTION: &str =
    "opencv: keypoints are synthcam's pixel_px unchanged; the centre of the top-left pixel is (0, 0). Add pixel_centre_offset_px to x and y for the convention where it is (0.5, 0.5).";

/// COCO visibility of a feature: 2 visible, 1 in the image but hidden, 0 outside or behind.
pub fn visibility(f: &FeatureLabel) -> u8 {
    if f.visible {
        2
    } else if f.in_front && f.in_image {
        1
    } else {
        0
    }
}

/// The annotation of one image: flat keypoints, their count, bbox and area.
fn annotation(k: usize, truth: &TruthLabels) -> Value {
    let mut keypoints: Vec<Value> = Vec::with_capacity(3 * truth.features.len());
    let (mut lo, mut hi) = ([f64::INFINITY; 2], [f64::NEG_INFINITY; 2]);
    let mut labelled = 0u64;
    for f in &truth.features {
        let v = visibility(f);
        let [x, y] = if v > 0 { f.pixel_px } else { [0.0, 0.0] };
        if v > 0 {
            labelled += 1;
            lo = [lo[0].min(x), lo[1].min(y)];
            hi = [hi[0].max(x), hi[1].max(y)];
        }
        keypoints.extend([json!(x), json!(y), json!(v)]);
    }
    let bbox = if labelled > 0 { [lo[0], lo[1], hi[0] - lo[0], hi[1] - lo[1]] } else { [0.0; 4] };
    json!({
        "id": k + 1,
        "image_id": k,
        "category_id": 1,
        "iscrowd": 0,
        "keypoints": keypoints,
        "num_keypoints": labelled,
        "bbox": bbox,
        "area": bbox[2] * bbox[3],
    })
}

/// The COCO keypoints document of `truths` (image k's file name `image_names[k]`, relative to
/// the dataset folder) as JSON bytes.
///
/// # Errors
/// [`FormatError::Unsupported`] when the images disagree on the target (COCO's keypoint
/// category has one fixed keypoint list), [`DatasetError::Json`].
pub fn coco_json(truths: &[TruthLabels], image_names: &[String]) -> Result<Vec<u8>, FormatError> {
    let first = truths.first();
    let n = first.map_or(0, |t| t.features.len());
    if let Some(t) = truths.iter().find(|t| t.features.len() != n || Some(&t.target_kind) != first.map(|f| &f.target_kind)) {
        return Err(FormatError::Unsupported {
            format: "coco",
            reason: format!("images show different targets ({} with {} features)", t.target_kind, t.features.len()),
        });
    }
    let images: Vec<Value> = truths
        .iter()
        .zip(image_names)
        .enumerate()
        .map(|(k, (t, name))| json!({"id": k, "file_name": name, "width": t.camera.width, "height": t.camera.height}))
        .collect();
    let annotations: Vec<Value> = truths.iter().enumerate().map(|(k, t)| annotation(k, t)).collect();
    let names: Vec<String> = first.map_or_else(Vec::new, |t| t.features.iter().map(|f| format!("p{}", f.id)).collect());
    let category = json!({
        "id": 1,
        "name": first.map_or("target", |t| t.target_kind.as_str()),
        "supercategory": "calibration_target",
        "keypoints": names,
        "skeleton": [],
    });
    let doc = json!({
        "info": {
            "description": "synthcam dataset: exact keypoints of a calibration target",
            "version": "1.0",
            "pixel_convention": PIXEL_CONVENTION,
            "pixel_centre_offset_px": 0.5,
        },
        "licenses": [],
        "images": images,
        "annotations": annotations,
        "categories": [category],
    });
    serde_json::to_vec(&doc).map_err(|e| DatasetError::Json(e.to_string()).into())
}
