//! `[[cameras]]` in a dataset spec: the rig's cameras, checked, posed relative to the first.

use super::{invalid, DatasetSpec};
use crate::dataset::error::SpecError;
use synthcam_core::camera::CameraModel;
use synthcam_scene::SceneError;

/// One camera of a rig dataset.
#[derive(Debug, Clone, PartialEq)]
pub struct RigMember {
    /// Its name (its images' folder).
    pub name: String,
    /// The camera.
    pub camera: CameraModel,
    /// Its pose relative to the first camera, `cam_from_cam0`.
    pub cam_from_cam0: nalgebra::Isometry3<f64>,
}

impl DatasetSpec {
    /// The camera poses are sampled for, and the rig (empty for one `[camera]`), each camera
    /// checked.
    pub(super) fn cameras_of(&self) -> Result<(CameraModel, Vec<RigMember>), SpecError> {
        match (&self.camera, self.cameras.as_slice()) {
            (Some(c), []) => Ok((c.to_model().map_err(SceneError::from)?, Vec::new())),
            (None, []) => Err(invalid("camera", "a dataset needs a [camera] table or a [[cameras]] rig")),
            (Some(_), _) => Err(invalid("cameras", "give [camera] or [[cameras]], not both")),
            (None, cams) => {
                let checked = synthcam_scene::file::rig::rig_cameras(cams)?;
                let cam0_from_rig = checked[0].2;
                let rig = checked
                    .into_iter()
                    .map(|(name, spec, cam_from_rig)| {
                        let camera = spec.to_model().map_err(|e| invalid(&format!("cameras.{name}"), e.to_string()))?;
                        Ok(RigMember { name, camera, cam_from_cam0: cam_from_rig * cam0_from_rig.inverse() })
                    })
                    .collect::<Result<Vec<_>, SpecError>>()?;
                Ok((rig[0].camera, rig))
            }
        }
    }
}
