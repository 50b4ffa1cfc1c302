//! [`Scene::builder`]: a scene in a few lines, with the course's camera and a default chessboard
//! until told otherwise, validated on [`SceneBuilder::build`].

use nalgebra::{Isometry3, Translation3, UnitQuaternion, Vector3};

use super::{RenderSettings, Scene, SceneError};
use crate::camera::CameraModel;
use crate::target::{Chessboard, Target};

/// Builds a [`Scene`].
///
/// ```
/// use synthcam::{camera::CameraModel, scene::Scene, target::Target};
/// let scene = Scene::builder()
///     .camera(CameraModel::pinhole(640, 480, 600.0).with_distortion([-0.2, 0.0, 0.0, 0.0, 0.0]))
///     .target(Target::chessboard(9, 7, 0.03))
///     .facing(0.5, 20.0, -10.0, 5.0)
///     .noise(1.0)
///     .build()?;
/// assert!(scene.camera.sees_all(&scene.cam_from_target, &scene.target.feature_points_m(), 0.0));
/// # Ok::<(), synthcam::scene::SceneError>(())
/// ```
#[derive(Debug, Clone, PartialEq)]
pub struct SceneBuilder {
    camera: CameraModel,
    target: Target,
    cam_from_target: Option<Isometry3<f64>>,
    facing: Option<[f64; 4]>,
    render: RenderSettings,
}

impl Scene {
    /// A [`SceneBuilder`]: the course camera, a default 9 x 7 chessboard facing the camera at
    /// 0.5 m, noise-free 8-bit rendering.
    pub fn builder() -> SceneBuilder {
        SceneBuilder {
            camera: CameraModel::course(),
            target: Target::Chessboard(Chessboard::default()),
            cam_from_target: None,
            facing: None,
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
        self.facing = None;
        self
    }

    /// The target's centre (the mean of its feature points) on the optical axis at `distance_m`,
    /// turned by `tilt_x_deg` about the camera's x axis, then `tilt_y_deg` about y, then
    /// `roll_deg` about the optical axis.
    pub fn facing(mut self, distance_m: f64, tilt_x_deg: f64, tilt_y_deg: f64, roll_deg: f64) -> Self {
        self.facing = Some([distance_m, tilt_x_deg, tilt_y_deg, roll_deg]);
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
        let [d, tx, ty, roll] = self.facing.unwrap_or([0.5, 0.0, 0.0, 0.0]);
        let pts = self.target.feature_points_m();
        let centre = pts.iter().fold(Vector3::zeros(), |a, p| a + p.coords) / pts.len().max(1) as f64;
        let rot = UnitQuaternion::from_axis_angle(&Vector3::z_axis(), roll.to_radians())
            * UnitQuaternion::from_axis_angle(&Vector3::y_axis(), ty.to_radians())
            * UnitQuaternion::from_axis_angle(&Vector3::x_axis(), tx.to_radians());
        let facing = Isometry3::from_parts(Translation3::new(0.0, 0.0, d), rot) * Translation3::from(-centre);
        let cam_from_target = self.cam_from_target.unwrap_or(facing);
        if !cam_from_target.to_homogeneous().iter().all(|v| v.is_finite()) {
            return Err(SceneError::InvalidField { field: "pose".into(), reason: "must be finite".into() });
        }
        let scene = Scene { camera: self.camera, target: self.target, cam_from_target, render: self.render, objects: Vec::new() };
        scene.validate()?;
        Ok(scene)
    }
}
