//! `[background]` in scene and dataset files ([`crate::background`]).
//!
//! ```toml
//! [background]
//! kind = "panorama"            # an equirectangular image around the camera, or "plane"
//! image = "hall.png"           # a file (grey, or colour taken as its luma) ...
//! # procedural = "clutter"     # ... or an image made here from `seed`, `size_px` texels
//! # seed = 7
//! # size_px = [2048, 1024]
//! frame = "camera"             # the pose's reference: "camera" (a rig's frame; default) or "target"
//! rvec = [0.0, 0.5, 0.0]       # or R: the panorama's (plane's) frame in that frame (default: none)
//! t_m = [0.0, 0.0, 2.5]        # plane: its centre
//! size_m = [4.0, 3.0]          # plane: the image's width and height on it
//! ```
//!
//! In a dataset spec two more keys draw per image: `folder = "dir"` (one of its images, instead
//! of `image`; a procedural image takes a fresh seed per image) and `yaw_deg = [lo, hi]` (the
//! background turned about the camera's y axis).

use std::sync::Arc;

use nalgebra::Isometry3;
use serde::Deserialize;

use super::{MeshLoader, ObjectFrame, PoseSpec};
use crate::background::{clutter, Background};
use crate::SceneError;
use synthcam_core::mesh::Texture;

/// The kind of a background.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Deserialize, serde::Serialize)]
#[serde(rename_all = "kebab-case")]
pub enum BackgroundKind {
    /// An equirectangular panorama at infinity.
    Panorama,
    /// An image on a plane.
    Plane,
}

/// The `[background]` table.
#[derive(Debug, Clone, PartialEq, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct BackgroundSpec {
    /// Panorama or plane.
    pub kind: BackgroundKind,
    /// The image file (give this or `procedural`).
    pub image: Option<String>,
    /// A procedural image: `"clutter"` ([`crate::background::clutter`]).
    pub procedural: Option<String>,
    /// The procedural image's seed (default 0).
    pub seed: Option<u64>,
    /// The procedural image's size, texels (default 2048 x 1024).
    pub size_px: Option<[u32; 2]>,
    /// The frame the pose is given in.
    #[serde(default)]
    pub frame: ObjectFrame,
    /// Rotation matrix, rows.
    #[serde(rename = "R")]
    pub r: Option<[[f64; 3]; 3]>,
    /// Rotation vector (Rodrigues), radians.
    pub rvec: Option<[f64; 3]>,
    /// Plane: its centre, metres.
    pub t_m: Option<[f64; 3]>,
    /// Plane: the image's width and height, metres.
    pub size_m: Option<[f64; 2]>,
    /// Datasets: a folder of images, one drawn per image.
    pub folder: Option<String>,
    /// Datasets: a turn about the camera's y axis drawn per image, degrees `[lo, hi]`.
    pub yaw_deg: Option<[f64; 2]>,
}

fn invalid(field: &str, reason: &str) -> SceneError {
    SceneError::InvalidField { field: format!("background.{field}"), reason: reason.into() }
}

impl BackgroundSpec {
    /// The image: the file through `load`, or the procedural one.
    ///
    /// # Errors
    /// Both or neither of `image` and `procedural`, an unknown procedure or size, a file that
    /// does not load.
    pub fn texture(&self, load: MeshLoader<'_>) -> Result<Arc<Texture>, SceneError> {
        match (&self.image, self.procedural.as_deref()) {
            (Some(path), None) => load.texture(path).map_err(|e| invalid("image", &e.to_string())),
            (None, Some("clutter")) => {
                let [w, h] = self.clutter_size()?;
                Ok(Arc::new(clutter(self.seed.unwrap_or(0), w, h)))
            }
            (None, Some(p)) => Err(invalid("procedural", &format!("unknown procedure {p:?} (known: \"clutter\")"))),
            _ => Err(invalid("image", "give `image` (a file) or `procedural`, one of them")),
        }
    }

    /// The procedural image's size, texels (`size_px`, default 2048 x 1024).
    ///
    /// # Errors
    /// [`SceneError::InvalidField`] (`background.size_px`) outside 1..=16384 per axis.
    pub fn clutter_size(&self) -> Result<[u32; 2], SceneError> {
        let [w, h] = self.size_px.unwrap_or([2048, 1024]);
        if !(1..=16384).contains(&w) || !(1..=16384).contains(&h) {
            return Err(invalid("size_px", &format!("must be in 1..=16384 each, got [{w}, {h}]")));
        }
        Ok([w, h])
    }

    /// The background, its pose in `frame`: the camera's (a rig's frame for a rig camera at
    /// `cam_from_rig`; the identity otherwise) or the target's.
    ///
    /// # Errors
    /// As [`BackgroundSpec::texture`]; a plane without `t_m` or `size_m`, a panorama with them,
    /// a bad rotation, a `world` or `tool` frame.
    pub fn to_background(&self, cam_from_rig: &Isometry3<f64>, cam_from_target: &Isometry3<f64>, load: MeshLoader<'_>) -> Result<Background, SceneError> {
        if self.folder.is_some() || self.yaw_deg.is_some() {
            return Err(invalid(
                if self.folder.is_some() { "folder" } else { "yaw_deg" },
                "draws per image: dataset specs only (a scene takes `image` and a rotation)",
            ));
        }
        self.placed(self.texture(load)?, cam_from_rig, cam_from_target)
    }

    /// The background of `texture` placed as this table says (`yaw_deg`, `folder` and the image
    /// keys aside).
    ///
    /// # Errors
    /// As [`BackgroundSpec::to_background`], the image aside.
    pub fn placed(&self, texture: Arc<Texture>, cam_from_rig: &Isometry3<f64>, cam_from_target: &Isometry3<f64>) -> Result<Background, SceneError> {
        let frame = match self.frame {
            ObjectFrame::Camera => *cam_from_rig,
            ObjectFrame::Target => *cam_from_target,
            f => return Err(invalid("frame", &format!("{f:?} is for robot scenarios; a scene or dataset takes \"camera\" or \"target\""))),
        };
        let pose = |t_m: [f64; 3]| {
            PoseSpec { r: self.r, rvec: self.rvec.or(self.r.is_none().then_some([0.0; 3])), t_m }.to_isometry().map_err(|e| match e {
                SceneError::InvalidField { field, reason } => invalid(field.trim_start_matches("pose."), &reason),
                e => e,
            })
        };
        let bg = match (self.kind, self.t_m, self.size_m) {
            (BackgroundKind::Panorama, None, None) => Background::panorama(texture, (frame * pose([0.0; 3])?).rotation),
            (BackgroundKind::Panorama, ..) => return Err(invalid("t_m", "a panorama is at infinity: give only its rotation")),
            (BackgroundKind::Plane, Some(t), Some(size)) => Background::plane(texture, frame * pose(t)?, size),
            (BackgroundKind::Plane, t, _) => return Err(invalid(if t.is_none() { "t_m" } else { "size_m" }, "is required for a plane")),
        };
        bg.validate_placement()?;
        Ok(bg)
    }
}
