//! A pure description of one image to render: camera, target, pose and render settings.
//!
//! No wgpu and no file I/O here: [`mod@file`] parses scene text (TOML or JSON) that the CLI has read,
//! [`trace`] is the exact CPU ray caster (the twin of the shaders (`shaders/*.wgsl`)), [`mod@reference`] the
//! brute-force supersampling CPU renderer used to check the GPU, [`exact`] the exact (polygon-clipped)
//! box filter of planar targets, [`scanline`] a converged scan-line box filter of any target, and [`truth`] the labels written next
//! to every image.
//!
//! ```
//! use synthcam_core::{camera::CameraModel, target::Target};
//! use synthcam_scene::{truth_labels, Facing, Scene};
//! # fn main() -> Result<(), Box<dyn std::error::Error>> {
//! let scene = Scene::builder()
//!     .camera(CameraModel::pinhole(640, 480, 500.0))
//!     .target(Target::chessboard(8, 6, 0.03))
//!     .facing(Facing { distance_m: 0.5, tilt_x_deg: 20.0, tilt_y_deg: 0.0, roll_deg: 0.0 })
//!     .build()?;
//! let truth = truth_labels(&scene); // every inner corner's exact pixel and visibility
//! assert_eq!(truth.features.len(), 35);
//! # Ok(())
//! # }
//! ```

#![deny(missing_docs)]

pub mod area_light;
pub mod background;
pub mod blobs;
pub mod builder;
pub mod depth;
pub mod effect_fields;
pub mod effect_truth;
pub mod effects;
pub mod exact;
pub mod facing;
pub mod file;
pub mod gloss;
pub mod lighting;
pub mod motion;
pub mod objects;
pub mod reference;
pub mod scanline;
pub mod shadow;
pub mod trace;
pub mod truth;
pub mod views;

pub use builder::SceneBuilder;
pub use facing::Facing;
pub use truth::{truth_labels, TruthLabels};

use nalgebra::Isometry3;

use synthcam_core::camera::{CameraError, CameraModel};
use synthcam_core::target::{Target, TargetError};

/// Settings of the image formation after the geometry: anti-aliasing, blur, noise, bit depth.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct RenderSettings {
    /// Sub-samples per axis for pixels that need brute-force supersampling: planar targets whose
    /// squares or dots are about a pixel or smaller; for the S-path's dots where no single smooth
    /// boundary crosses the pixel, the first spacing (1 / samples px) of the adaptive integration
    /// across scan lines. Chessboard and dot-grid edges use exact closed-form coverage.
    pub samples: u32,
    /// Standard deviation of additive Gaussian noise, grey levels (0 = none).
    pub noise_sigma: f64,
    /// Standard deviation of the Gaussian point-spread function, pixels (0 = none).
    pub blur_sigma_px: f64,
    /// Seed of the noise generator; the same seed gives the same image.
    pub seed: u64,
    /// Output bit depth, 8 or 16.
    pub bit_depth: u8,
    /// Sensor, optics, motion and output format ([`effects`]); the default is the ideal camera.
    pub effects: effects::Effects,
    /// Lights and the ambient term ([`lighting`]); the default leaves the target as given.
    pub lighting: lighting::Lighting,
}

impl Default for RenderSettings {
    fn default() -> Self {
        Self {
            samples: 16,
            noise_sigma: 0.0,
            blur_sigma_px: 0.0,
            seed: 0,
            bit_depth: 8,
            effects: effects::Effects::default(),
            lighting: lighting::Lighting::default(),
        }
    }
}

/// Errors raised by scene parsing and validation.
#[derive(Debug, thiserror::Error)]
#[non_exhaustive]
pub enum SceneError {
    /// The scene text does not parse, or a field is missing or of the wrong type.
    #[error("scene file does not parse: {0}")]
    Parse(String),
    /// A field has an invalid value.
    #[error("scene field `{field}` is invalid: {reason}")]
    InvalidField {
        /// Dotted path of the field, e.g. `camera.fx`.
        field: String,
        /// What is wrong with it.
        reason: String,
    },
    /// The camera is invalid.
    #[error("[camera]: {0}")]
    Camera(#[from] CameraError),
    /// The target is invalid.
    #[error("[target]: {0}")]
    Target(#[from] TargetError),
    /// The sensor is invalid.
    #[error(transparent)]
    Sensor(#[from] synthcam_core::camera::sensor::SensorError),
    /// An object's mesh does not load (the mesh error, naming the file, is the source).
    #[error("[[object]] {index}")]
    Object {
        /// The object's index (its `[[object]]` table, from 0).
        index: usize,
        /// Why.
        source: synthcam_core::mesh::MeshError,
    },
    /// The pose puts the target behind the camera (outside a fisheye's reach, for one whose
    /// reach passes 90 degrees).
    #[error("[pose]: the target is behind the camera (mean depth of its features {mean_depth_m:.4} m <= 0, outside the lens's reach)")]
    TargetBehindCamera {
        /// Mean z of the feature points in the camera frame.
        mean_depth_m: f64,
    },
}

/// One image to render.
#[derive(Debug, Clone, PartialEq)]
pub struct Scene {
    /// The camera model (intrinsics, distortion, image size).
    pub camera: CameraModel,
    /// The target and its appearance.
    pub target: Target,
    /// Rigid transform mapping target coordinates into camera coordinates.
    pub cam_from_target: Isometry3<f64>,
    /// Anti-aliasing, blur, noise and output settings.
    pub render: RenderSettings,
    /// The user's objects (meshes) in front of, around or behind the target ([`objects`]).
    pub objects: Vec<objects::SceneObject>,
    /// What rays that miss the target and the objects see ([`background`]); `None`: the
    /// target's uniform background grey.
    pub background: Option<background::Background>,
}

impl Scene {
    /// Validate the whole scene.
    ///
    /// # Errors
    /// The first invalid field, or [`SceneError::TargetBehindCamera`].
    pub fn validate(&self) -> Result<(), SceneError> {
        self.camera.validate()?;
        lighting::check(self)?;
        let (w, h) = (self.camera.size.width, self.camera.size.height);
        if w > 16384 || h > 16384 {
            return Err(SceneError::InvalidField { field: "camera.width/height".into(), reason: format!("{w}x{h} exceeds 16384") });
        }
        self.target.validate()?;
        let r = self.cam_from_target.rotation.to_rotation_matrix();
        let t = self.cam_from_target.translation.vector;
        if r.matrix().iter().chain(t.iter()).any(|v| !v.is_finite()) {
            return Err(SceneError::InvalidField { field: "pose".into(), reason: "contains a non-finite number".into() });
        }
        let rs = &self.render;
        if rs.samples == 0 || rs.samples > 64 {
            return Err(SceneError::InvalidField { field: "render.samples".into(), reason: format!("must be in 1..=64, got {}", rs.samples) });
        }
        if !rs.noise_sigma.is_finite() || rs.noise_sigma < 0.0 {
            return Err(SceneError::InvalidField { field: "render.noise_sigma".into(), reason: format!("must be finite and >= 0, got {}", rs.noise_sigma) });
        }
        if !rs.blur_sigma_px.is_finite() || rs.blur_sigma_px < 0.0 || rs.blur_sigma_px > 50.0 {
            return Err(SceneError::InvalidField { field: "render.blur_sigma_px".into(), reason: format!("must be in [0, 50], got {}", rs.blur_sigma_px) });
        }
        if rs.bit_depth != 8 && rs.bit_depth != 16 {
            return Err(SceneError::InvalidField { field: "render.bit_depth".into(), reason: format!("must be 8 or 16, got {}", rs.bit_depth) });
        }
        rs.effects.validate()?;
        if rs.effects.needs_views() && matches!(self.target, Target::SPath(_)) {
            return Err(SceneError::InvalidField {
                field: "optics.f_number / motion".into(),
                reason: "defocus and motion are rendered for planar targets (chessboard, dot grid, ChArUco, AprilGrid); the S-path is not supported yet".into(),
            });
        }
        if self.target.warp().is_some() && (rs.effects.needs_views() || !self.objects.is_empty()) {
            return Err(SceneError::InvalidField {
                field: "target.warp_m".into(),
                reason: "a warped board is rendered sharp and alone: defocus, motion, a rolling shutter and objects are not rendered on a curved board yet"
                    .into(),
            });
        }
        self.validate_objects()?;
        self.validate_background()?;
        target_in_reach(&self.camera, &self.cam_from_target, &self.target.feature_points_m())
    }
}

/// Whether `camera` can see a target whose feature points are `pts` (target frame) at
/// `cam_from_target`: their mean in front of the camera, or within the reach of a fisheye that
/// sees beyond 90 degrees (behind the camera plane).
///
/// # Errors
/// [`SceneError::TargetBehindCamera`] with the mean depth.
pub fn target_in_reach(camera: &synthcam_core::camera::CameraModel, cam_from_target: &Isometry3<f64>, pts: &[nalgebra::Point3<f64>]) -> Result<(), SceneError> {
    let n = pts.len().max(1) as f64;
    let mean_cam = pts.iter().map(|p| (cam_from_target * p).coords).sum::<nalgebra::Vector3<f64>>() / n;
    let seen = mean_cam.z > 0.0 || mean_cam.xy().norm().atan2(mean_cam.z) < camera.lens.max_angle_rad();
    if seen {
        Ok(())
    } else {
        Err(SceneError::TargetBehindCamera { mean_depth_m: mean_cam.z })
    }
}

impl Scene {
    /// A background's placement, behind a planar target (its texels are checked when the renderer
    /// uploads them: [`background::Background::validate_texels`]).
    fn validate_background(&self) -> Result<(), SceneError> {
        let Some(bg) = &self.background else { return Ok(()) };
        bg.validate_placement()?;
        background::check_target(&self.target)
    }

    /// Objects are rendered with planar targets and sharp views (the renderer's object pass).
    fn validate_objects(&self) -> Result<(), SceneError> {
        if self.objects.is_empty() {
            return Ok(());
        }
        for (i, o) in self.objects.iter().enumerate() {
            o.validate(i, self.camera.lens.max_angle_rad())?;
        }
        if matches!(self.target, Target::SPath(_)) {
            return Err(SceneError::InvalidField {
                field: "object".into(),
                reason: "objects are rendered with planar targets (chessboard, dot grid, ChArUco, AprilGrid); the S-path is not supported yet".into(),
            });
        }
        if self.render.effects.needs_views() {
            return Err(SceneError::InvalidField {
                field: "object".into(),
                reason: "objects are not rendered under defocus, motion blur or a rolling shutter yet".into(),
            });
        }
        Ok(())
    }
}
