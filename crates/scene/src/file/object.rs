//! `[[object]]` tables: the user's meshes in a scene.
//!
//! ```toml
//! [[object]]
//! mesh = "assets/meshes/gripper.obj"   # Wavefront OBJ (+ MTL, albedo texture)
//! frame = "camera"                     # the pose's reference: "camera" (default) or "target"
//! rvec = [0.0, 0.3, 0.0]               # or R = [[...], [...], [...]]
//! t_m = [0.02, -0.01, 0.35]
//! scale = 1.0                          # uniform, applied to the mesh before the pose
//! albedo = 160.0                       # grey where the OBJ has no material
//! shading = "unlit"                    # "head-light" (Lambert, light at the camera) or "lit" (the scene's light, shadows)
//! ```

use std::sync::Arc;

use nalgebra::Isometry3;
use serde::Deserialize;

use super::PoseSpec;
use crate::objects::{MeshAsset, SceneObject, Shading};
use crate::SceneError;
use synthcam_core::mesh::{MeshError, Texture};

/// What an object's pose is relative to.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, Deserialize, serde::Serialize)]
#[serde(rename_all = "kebab-case")]
pub enum ObjectFrame {
    /// `cam_from_object` (the default).
    #[default]
    Camera,
    /// `target_from_object`: the object moves with the target.
    Target,
    /// `world_from_object` (robot scenarios).
    World,
    /// `tool_from_object`: carried by the robot's tool (robot scenarios).
    Tool,
}

/// One `[[object]]` table.
#[derive(Debug, Clone, PartialEq, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct ObjectSpec {
    /// The OBJ file.
    pub mesh: String,
    /// The pose's reference frame.
    #[serde(default)]
    pub frame: ObjectFrame,
    /// Rotation matrix, rows.
    #[serde(rename = "R")]
    pub r: Option<[[f64; 3]; 3]>,
    /// Rotation vector (Rodrigues), radians.
    pub rvec: Option<[f64; 3]>,
    /// Translation, metres.
    pub t_m: [f64; 3],
    /// Uniform scale (default 1).
    pub scale: Option<f64>,
    /// Grey level where the OBJ has no material (default 160).
    pub albedo: Option<f64>,
    /// Lighting (default unlit).
    #[serde(default)]
    pub shading: Shading,
}

/// Loads the files a scene file names (meshes, background images) by the path written there: the
/// CLI's and Python's read files and cache them (`synthcam_io::dataset::meshes::MeshLibrary`). A
/// closure over paths is a loader of meshes alone.
pub trait AssetLoader {
    /// The mesh at `path`.
    ///
    /// # Errors
    /// The file does not load.
    fn mesh(&self, path: &str) -> Result<Arc<MeshAsset>, MeshError>;

    /// The image at `path` as a grey texture.
    ///
    /// # Errors
    /// The file does not load; this default reads no images.
    fn texture(&self, path: &str) -> Result<Arc<Texture>, MeshError> {
        Err(MeshError::Invalid {
            path: path.into(),
            reason: "this loader reads meshes only: load the scene with one that reads images (synthcam's CLI and Python do)".into(),
        })
    }
}

impl<F: Fn(&str) -> Result<Arc<MeshAsset>, MeshError>> AssetLoader for F {
    fn mesh(&self, path: &str) -> Result<Arc<MeshAsset>, MeshError> {
        self(path)
    }
}

/// The loader a scene's parsing takes ([`AssetLoader`]).
pub type MeshLoader<'a> = &'a dyn AssetLoader;

impl ObjectSpec {
    /// The pose as written (in [`ObjectSpec::frame`]); `i` names the table in errors.
    ///
    /// # Errors
    /// As [`PoseSpec::to_isometry`], the field renamed `object[i].…`.
    pub fn pose(&self, i: usize) -> Result<Isometry3<f64>, SceneError> {
        PoseSpec { r: self.r, rvec: self.rvec, t_m: self.t_m }.to_isometry().map_err(|e| match e {
            SceneError::InvalidField { field, reason } => {
                SceneError::InvalidField { field: format!("object[{i}].{}", field.trim_start_matches("pose.")), reason }
            }
            e => e,
        })
    }

    /// The object, its mesh from `load`, placed by `frame_pose` (the camera's pose of the frame the
    /// spec names: identity for `camera`, `cam_from_target` for `target`).
    ///
    /// # Errors
    /// [`SceneError::Object`] when the mesh does not load; invalid pose fields.
    pub fn to_object(&self, i: usize, frame_pose: &Isometry3<f64>, load: MeshLoader<'_>) -> Result<SceneObject, SceneError> {
        let asset = load.mesh(&self.mesh).map_err(|source| SceneError::Object { index: i, source })?;
        Ok(self.place(asset, frame_pose * self.pose(i)?))
    }

    /// The object of this table with its mesh `asset` at `cam_from_object` (its scale, albedo
    /// and shading as written, or their defaults).
    pub fn place(&self, asset: Arc<MeshAsset>, cam_from_object: Isometry3<f64>) -> SceneObject {
        let mut o = SceneObject::new(asset, cam_from_object);
        o.scale = self.scale.unwrap_or(o.scale);
        o.albedo = self.albedo.unwrap_or(o.albedo);
        o.shading = self.shading;
        o
    }
}

/// The objects of a scene file: `camera` and `target` frames (`cam_from_target` given).
///
/// # Errors
/// As [`ObjectSpec::to_object`]; a `world` or `tool` frame (robot scenarios only).
pub fn scene_objects(specs: &[ObjectSpec], cam_from_target: &Isometry3<f64>, load: MeshLoader<'_>) -> Result<Vec<SceneObject>, SceneError> {
    specs
        .iter()
        .enumerate()
        .map(|(i, s)| {
            let frame = match s.frame {
                ObjectFrame::Camera => Isometry3::identity(),
                ObjectFrame::Target => *cam_from_target,
                f => {
                    return Err(SceneError::InvalidField {
                        field: format!("object[{i}].frame"),
                        reason: format!("{f:?} is for robot scenarios; a scene or dataset takes \"camera\" or \"target\""),
                    })
                }
            };
            s.to_object(i, &frame, load)
        })
        .collect()
}
