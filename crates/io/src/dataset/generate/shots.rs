//! The images of a shard ("shots": a view through the one camera or through one camera of a
//! rig), their files, and the manifest entries assembled from what was written.

use std::path::{Path, PathBuf};

use super::super::manifest::{ManifestCamera, ManifestEntry, ManifestPose};
use super::super::poses::{rig_scene_of, rig_view, scene_of, SampledView};
use super::super::spec::DatasetPlan;
use super::image_file_as;
use synthcam_core::math::so3::rvec_from_rotation;
use synthcam_scene::Scene;

/// Image k of camera `cam` of a rig (`None`: the one camera), relative to the dataset folder.
pub(super) fn shot_file(plan: &DatasetPlan, k: u64, cam: Option<usize>) -> String {
    let encoding = plan.render.effects.output.encoding;
    match cam.and_then(|i| plan.rig.get(i)) {
        Some(m) => image_file_as(k, encoding).replacen("images/", &format!("images/{}/", m.name), 1),
        None => image_file_as(k, encoding),
    }
}

/// The image folders: `images`, or a rig's `images/<camera>`.
pub(super) fn image_dirs(plan: &DatasetPlan, dir: &Path) -> Vec<PathBuf> {
    if plan.rig.is_empty() {
        vec![dir.join("images")]
    } else {
        plan.rig.iter().map(|m| dir.join("images").join(&m.name)).collect()
    }
}

/// One image to make: a view through the one camera (`cam` None) or through rig camera `cam`.
#[derive(Debug, Clone, Copy)]
pub(super) struct Shot<'v> {
    pub(super) view: &'v SampledView,
    pub(super) cam: Option<usize>,
}

impl Shot<'_> {
    pub(super) fn scene(&self, plan: &DatasetPlan) -> Scene {
        match self.cam {
            Some(i) => rig_scene_of(plan, self.view, i).unwrap_or_else(|| scene_of(plan, self.view)),
            None => scene_of(plan, self.view),
        }
    }
}

/// An image on disk: its shot, its file and the hash of its bytes.
#[derive(Debug, Clone)]
pub(super) struct Written {
    pub(super) k: u64,
    pub(super) cam: Option<usize>,
    pub(super) file: String,
    pub(super) sha256: String,
}

fn pose_of(p: &nalgebra::Isometry3<f64>) -> ManifestPose {
    ManifestPose { rvec: rvec_from_rotation(&p.rotation.to_rotation_matrix()).into(), t_m: p.translation.vector.into() }
}

fn truth_file(file: &str) -> String {
    Path::new(file).with_extension("json").to_string_lossy().into_owned()
}

/// The manifest's entries from the written images, one per view (a rig's lists its cameras; the
/// entry's own fields are the first camera's).
pub(super) fn entries_of(plan: &DatasetPlan, views: &[SampledView], written: &[Written]) -> Vec<ManifestEntry> {
    let mut by_k: std::collections::BTreeMap<u64, Vec<&Written>> = Default::default();
    for w in written {
        by_k.entry(w.k).or_default().push(w);
    }
    views
        .iter()
        .filter_map(|v| {
            let mut ws = by_k.remove(&v.k)?;
            ws.sort_by_key(|w| w.cam);
            let first = ws.first()?;
            let cameras = (!plan.rig.is_empty()).then(|| {
                ws.iter()
                    .filter_map(|w| {
                        let i = w.cam?;
                        let (seed, cam_from_target) = rig_view(plan, v, i)?;
                        Some(ManifestCamera {
                            name: plan.rig.get(i)?.name.clone(),
                            file: w.file.clone(),
                            sha256: w.sha256.clone(),
                            truth: truth_file(&w.file),
                            seed,
                            cam_from_target: pose_of(&cam_from_target),
                        })
                    })
                    .collect()
            });
            Some(ManifestEntry {
                k: v.k,
                file: first.file.clone(),
                sha256: first.sha256.clone(),
                truth: truth_file(&first.file),
                seed: v.render_seed,
                cam_from_target: pose_of(&v.cam_from_target),
                joints_rad: v.joints_rad,
                cameras,
            })
        })
        .collect()
}
