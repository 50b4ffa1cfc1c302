//! A finished dataset folder as a rerun recording: image k at `step` k, in the target's frame
//! (`world` is the target: `world/camera` is each image's `target_from_cam`; a rig's cameras are
//! `world/<name>`), with the true features over the image and the target's points in 3-D.

use std::path::Path;

use nalgebra::Point2;

use super::super::folder::DatasetFolder;
use super::super::series::{pose_of_label, DEFAULT_FRAME_PERIOD_NS};
use super::super::{FormatError, Tick};
use super::{Rrd, RrdCounts, TRUTH};
use crate::dataset::manifest::ManifestEntry;

/// Write the dataset in `folder` as a rerun recording at `path`: each image (its PNG or JPEG bytes
/// as stored), its truth's visible features (`world/camera/image/truth`, ids as keypoint ids),
/// the camera's pose against the target (`world/camera`) and the target's feature points
/// (`world/target/features`, static, from the first image's truth). A rig's cameras each have
/// their own entity, `world/<camera name>`.
///
/// # Errors
/// [`FormatError::Unsupported`] for an empty dataset; a read or decode error of the folder;
/// [`FormatError::Rerun`] or [`FormatError::Write`] when the file cannot be written (nothing is
/// left at `path`).
pub fn write_dataset_rrd(folder: &DatasetFolder, path: &Path, tick: Tick<'_>) -> Result<RrdCounts, FormatError> {
    if folder.entries.is_empty() {
        return Err(FormatError::Unsupported { format: "rerun", reason: "the dataset has no images".into() });
    }
    let rrd = Rrd::create(path, &format!("synthcam dataset {}", folder.dir.display()))?;
    let period_s = DEFAULT_FRAME_PERIOD_NS as f64 * 1e-9;
    let (mut cameras_logged, mut frames) = (Vec::<String>::new(), 0);
    for e in &folder.entries {
        tick();
        rrd.at_step(e.k, period_s);
        for (entity, shot) in shots(e) {
            let truth = folder.read_truth(&shot)?;
            if cameras_logged.is_empty() {
                rrd.camera_info(&format!("dataset {}", folder.dir.display()), &truth.camera)?;
                let points: Vec<[f32; 3]> = truth.features.iter().map(|f| f.point_target_m.map(|v| v as f32)).collect();
                rrd.log_static("world/target/features", &rerun::Points3D::new(points).with_radii([rerun::Radius::new_ui_points(2.0)]))?;
            }
            if !cameras_logged.contains(&entity) {
                rrd.camera(&format!("{entity}/image"), &truth.camera)?;
                cameras_logged.push(entity.clone());
            }
            rrd.pose(&entity, &pose_of_label(&truth.cam_from_target).inverse(), false)?;
            let bytes = folder.read_image(&shot)?;
            let media = if shot.file.ends_with(".png") { rerun::MediaType::PNG } else { rerun::MediaType::JPEG };
            rrd.log(&format!("{entity}/image"), &rerun::EncodedImage::from_file_contents(bytes).with_media_type(media))?;
            let visible: Vec<(usize, Point2<f64>)> = truth.features.iter().filter(|f| f.visible).map(|f| (f.id, Point2::from(f.pixel_px))).collect();
            rrd.points(&format!("{entity}/image/truth"), &visible, TRUTH)?;
            frames += 1;
        }
    }
    Ok(RrdCounts { frames, steps: folder.entries.len(), bytes: rrd.finish()? })
}

/// The images of entry `e` with their entities: `world/camera`, or a rig's `world/<name>` each
/// (as entries of their own, for the folder's readers).
fn shots(e: &ManifestEntry) -> Vec<(String, ManifestEntry)> {
    match &e.cameras {
        None => vec![("world/camera".to_owned(), e.clone())],
        Some(cams) => cams
            .iter()
            .map(|c| {
                let shot = ManifestEntry {
                    file: c.file.clone(),
                    sha256: c.sha256.clone(),
                    truth: c.truth.clone(),
                    seed: c.seed,
                    cam_from_target: c.cam_from_target.clone(),
                    joints_rad: None,
                    cameras: None,
                    ..e.clone()
                };
                (format!("world/{}", c.name), shot)
            })
            .collect(),
    }
}
