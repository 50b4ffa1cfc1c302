//! [`Scene::builder`]: a scene in a few lines, with a preset camera ([`CameraModel::sxga_1500px`])
//! and a default chessboard until told otherwise, validated on [`SceneBuilder::build`].

use nalgebra::Isometry3;

use super::{Facing, RenderSettings, Scene, SceneError};
use synthcam_core::camera::CameraModel;
use synthcam_core::target::{Chessboard, Target};

/// Builds a [`Scene`].
///
/// ```
/// use synthcam_core::{camera::CameraModel, target::Target};
/// use synthcam_scene::{Facing, Scene};
/// let scene = Scene::builder()
///     .camera(CameraModel::pinhole(640, 480, 600.0).with_distortion([-0.2, 0.0, 0.0, 0.0, 0.0]))
///     .target(Target::chessboard(9, 7, 0.03))
///     .facing(Facing { distance_m: 0.5, tilt_x_deg: 20.0, tilt_y_deg: -10.0, roll_deg: 5.0 })
///     .noise(1.0)
///     .build()?;
/// assert!(scene.camera.sees_all(&scene.cam_from_target, &scene.target.feature_points_m(), 0.0));
/// # Ok::<(), synthcam_scene::SceneError>(())
/// ```
#[derive(Debug, Clone, PartialEq)]
pub struct SceneBuilder {
    camera: CameraModel,
    target: Target,
    cam_from_target: Option<Isometry3<f64>>,
    facing: Facing,
    render: RenderSettings,
}

impl Scene {
    /// A [`SceneBuilder`]: the preset camera [`CameraModel::sxga_1500px`], a default 9 x 7
    /// chessboard facing the camera at 0.5 m ([`Facing::default`]), noise-free 8-bit rendering.
    pub fn builder() -> SceneBuilder {
        SceneBuilder {
            camera: CameraModel::sxga_1500px(),
            target: Target::Chessboard(Chessboard::default()),
            cam_from_target: None,
            facing: Facing::default(),
            render: RenderSettings::default(),
        }
    }
}

impl SceneBuilder {
    /// The camera.
    pub fn camera(mut self, camera: CameraModel) -> Self {
        self.camera = camera;
        self
    }

    /// The target.
    pub fn target(mut self, target: Target) -> Self {
        self.target = target;
        self
    }

    /// The exact pose `cam_from_target` (overrides [`SceneBuilder::facing`]).
    pub fn cam_from_target(mut self, cam_from_target: Isometry3<f64>) -> Self {
        self.cam_from_target = Some(cam_from_target);
        self
    }

    /// The pose by distance and tilts ([`Facing`]; overrides [`SceneBuilder::cam_from_target`]).
    pub fn facing(mut self, facing: Facing) -> Self {
        self.facing = facing;
        self.cam_from_target = None;
        self
    }

    /// Gaussian noise, grey levels.
    pub fn noise(mut self, sigma: f64) -> Self {
        self.render.noise_sigma = sigma;
        self
    }

    /// Gaussian blur, pixels.
    pub fn blur(mut self, sigma_px: f64) -> Self {
        self.render.blur_sigma_px = sigma_px;
        self
    }

    /// All render settings at once.
    pub fn render(mut self, render: RenderSettings) -> Self {
        self.render = render;
        self
    }

    /// Validate and build.
    ///
    /// # Errors
    /// An invalid camera, target or setting, a non-finite pose, or a target behind the camera.
    pub fn build(self) -> Result<Scene, SceneError> {
        let cam_from_target = match self.cam_from_target {
            Some(pose) => pose,
            None => self.facing.cam_from_target(&self.target)?,
        };
        if !cam_from_target.to_homogeneous().iter().all(|v| v.is_finite()) {
            return Err(SceneError::InvalidField { field: "pose".into(), reason: "must be finite".into() });
        }
        let scene = Scene { camera: self.camera, target: self.target, cam_from_target, render: self.render, objects: Vec::new(), background: None };
        scene.validate()?;
        Ok(scene)
    }
}
