//! Scene files: TOML (or JSON) text into a validated [`Scene`].
//!
//! ```toml
//! [camera]
//! width = 1280
//! height = 1024
//! fx = 1500.0
//! fy = 1500.0
//! cx = 640.0
//! cy = 512.0
//! skew = 0.0                 # K[0][1], pixels
//! model = "opencv"           # or "fisheye", "double-sphere" (default "opencv")
//! dist = [-0.25, 0.0, 0.0, 0.0, 0.0]   # OpenCV order k1, k2, p1, p2, k3[, k4, k5, k6[, s1..s4[, tau_x, tau_y]]]
//! # fisheye: dist = [k1, k2, k3, k4]; double-sphere: xi = -0.2, alpha = 0.6 (no dist)
//!
//! [target]
//! kind = "chessboard"        # or "dot-grid", "s-path", "charuco" (squares, square_m, marker_m, dictionary = "DICT_5X5_100", legacy, first_id), "aprilgrid" (tags, tag_m, spacing, family, border_bits, first_id)
//! squares = [9, 7]
//! square_m = 0.03
//!
//! [pose]                     # cam_from_target: x_cam = R x_target + t_m
//! R = [[1, 0, 0], [0, 1, 0], [0, 0, 1]]   # or rvec = [rx, ry, rz] (radians, Rodrigues)
//! t_m = [-0.1, -0.1, 0.8]
//! # or, instead of [pose], the board's centre on the optical axis (super::Facing):
//! # [facing]
//! # distance_m = 0.8
//! # tilt_x_deg = 20.0        # then tilt_y_deg, then roll_deg (defaults 0)
//!
//! [render]
//! samples = 16               # sub-samples per axis where brute force is needed
//! noise_sigma = 0.0          # grey levels
//! blur_sigma_px = 0.0
//! seed = 0
//! ```
//!
//! Unknown fields are errors (a typo must not silently fall back to a default).

use nalgebra::{Isometry3, Matrix3, Rotation3, Translation3, UnitQuaternion, Vector3};
use serde::Deserialize;

pub mod background;
mod camera;
pub mod effects;
mod light;
pub mod object;
pub mod rig;
mod target;

pub use camera::{CameraSpec, ModelName};
pub use effects::RenderSpec;
pub use light::{with_lights, LightSpec};
pub use object::{AssetLoader, MeshLoader, ObjectFrame, ObjectSpec};
pub use target::TargetTable;

use super::{Scene, SceneError};
use synthcam_core::math::so3::rotation_from_rvec;

/// `[pose]` table: `cam_from_target`.
#[derive(Debug, Clone, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct PoseSpec {
    /// Rotation matrix, rows.
    #[serde(rename = "R")]
    pub r: Option<[[f64; 3]; 3]>,
    /// Rotation vector (Rodrigues), radians.
    pub rvec: Option<[f64; 3]>,
    /// Translation, metres.
    pub t_m: [f64; 3],
}

impl PoseSpec {
    /// The rigid transform this table describes.
    ///
    /// # Errors
    /// Neither or both of `R` and `rvec`, a non-finite number, or an `R` that is not a rotation.
    pub fn to_isometry(&self) -> Result<Isometry3<f64>, SceneError> {
        let invalid = |field: &str, reason: String| SceneError::InvalidField { field: field.into(), reason };
        if self.t_m.iter().any(|v| !v.is_finite()) {
            return Err(invalid("pose.t_m", format!("must be finite, got {:?}", self.t_m)));
        }
        let rot = match (&self.r, &self.rvec) {
            (Some(r), None) => {
                let m = Matrix3::from_fn(|i, j| r[i][j]);
                if m.iter().any(|v| !v.is_finite()) {
                    return Err(invalid("pose.R", "must be finite".into()));
                }
                let orth = (m.transpose() * m - Matrix3::identity()).abs().max();
                if orth > 1e-6 || m.determinant() < 0.0 {
                    return Err(invalid("pose.R", format!("is not a rotation (|R^T R - I|max = {orth:.2e}, det = {:.6})", m.determinant())));
                }
                Rotation3::from_matrix_unchecked(m)
            }
            (None, Some(v)) => {
                if v.iter().any(|x| !x.is_finite()) {
                    return Err(invalid("pose.rvec", format!("must be finite, got {v:?}")));
                }
                rotation_from_rvec(&Vector3::from(*v))
            }
            (None, None) => return Err(invalid("pose", "needs `R` or `rvec`".into())),
            (Some(_), Some(_)) => return Err(invalid("pose", "give `R` or `rvec`, not both".into())),
        };
        Ok(Isometry3::from_parts(Translation3::from(Vector3::from(self.t_m)), UnitQuaternion::from_rotation_matrix(&rot)))
    }
}

/// A whole scene file.
#[derive(Debug, Clone, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct SceneSpec {
    /// `[camera]` (or `[[cameras]]`, not both).
    #[serde(default)]
    pub camera: Option<CameraSpec>,
    /// `[[cameras]]`: a rig ([`rig`]); `[pose]` is then `rig_from_target`.
    #[serde(default)]
    pub cameras: Vec<rig::RigCameraSpec>,
    /// `[target]`.
    pub target: TargetTable,
    /// `[pose]` (or `[facing]`, not both).
    #[serde(default)]
    pub pose: Option<PoseSpec>,
    /// `[facing]`: the pose by distance and tilts ([`super::Facing`]).
    #[serde(default)]
    pub facing: Option<super::Facing>,
    /// `[render]` (optional).
    #[serde(default)]
    pub render: RenderSpec,
    /// `[sensor]` (optional; [`effects`]).
    #[serde(default)]
    pub sensor: Option<synthcam_core::camera::sensor::SensorModel>,
    /// `[optics]` (optional).
    #[serde(default)]
    pub optics: Option<effects::OpticsSpec>,
    /// `[motion]` (optional).
    #[serde(default)]
    pub motion: Option<super::motion::Motion>,
    /// `[output]` (optional).
    #[serde(default)]
    pub output: Option<effects::OutputSpec>,
    /// `[[object]]` tables (optional; [`object`]).
    #[serde(default, rename = "object")]
    pub objects: Vec<ObjectSpec>,
    /// `[[light]]` tables (optional; [`crate::lighting`]).
    #[serde(default, rename = "light")]
    pub lights: Vec<LightSpec>,
    /// `[background]` (optional; [`crate::background`]).
    #[serde(default)]
    pub background: Option<background::BackgroundSpec>,
}

impl SceneSpec {
    /// Build and validate the scene.
    ///
    /// # Errors
    /// Any invalid field (named), or a target behind the camera.
    pub fn to_scene(&self) -> Result<Scene, SceneError> {
        self.to_scene_with(&|path: &str| {
            Err(synthcam_core::mesh::MeshError::Invalid {
                path: path.into(),
                reason: "this scene has objects: load it with a mesh loader (SceneSpec::to_scene_with)".into(),
            })
        })
    }

    /// [`SceneSpec::to_scene`], loading the `[[object]]` meshes with `load`.
    ///
    /// # Errors
    /// As [`SceneSpec::to_scene`], and a mesh that does not load ([`SceneError::Object`]).
    pub fn to_scene_with(&self, load: MeshLoader<'_>) -> Result<Scene, SceneError> {
        match (&self.camera, self.cameras.is_empty()) {
            (Some(camera), true) => self.scene_of(camera, &Isometry3::identity(), load),
            (None, false) => Err(SceneError::InvalidField {
                field: "cameras".into(),
                reason: "this scene is a rig (`[[cameras]]`): render it with SceneSpec::to_rig_scenes_with (`synthcam render` does)".into(),
            }),
            _ => Err(Self::one_camera_table()),
        }
    }

    /// A rig's scenes, one per `[[cameras]]` entry with its name (or the one `[camera]`, named
    /// `cam0`): each camera's `cam_from_target = cam_from_rig rig_from_target`.
    ///
    /// # Errors
    /// As [`SceneSpec::to_scene_with`] for each camera, and a bad `[[cameras]]` entry (named).
    pub fn to_rig_scenes_with(&self, load: MeshLoader<'_>) -> Result<Vec<(String, Scene)>, SceneError> {
        match (&self.camera, self.cameras.is_empty()) {
            (Some(camera), true) => Ok(vec![("cam0".into(), self.scene_of(camera, &Isometry3::identity(), load)?)]),
            (None, false) if !self.objects.is_empty() => Err(SceneError::InvalidField {
                field: "object".into(),
                reason: "objects are not placed in a rig's scenes yet (render each camera as its own scene)".into(),
            }),
            (None, false) => rig::rig_cameras(&self.cameras)?
                .into_iter()
                .map(|(name, camera, cam_from_rig)| {
                    let scene = self
                        .scene_of(&camera, &cam_from_rig, load)
                        .map_err(|e| SceneError::InvalidField { field: format!("cameras.{name}"), reason: e.to_string() })?;
                    Ok((name, scene))
                })
                .collect(),
            _ => Err(Self::one_camera_table()),
        }
    }

    fn one_camera_table() -> SceneError {
        SceneError::InvalidField { field: "camera".into(), reason: "a scene needs `[camera]` or `[[cameras]]`, not both".into() }
    }

    /// The scene of `camera` at `cam_from_rig` (the identity for a single camera).
    fn scene_of(&self, camera: &CameraSpec, cam_from_rig: &Isometry3<f64>, load: MeshLoader<'_>) -> Result<Scene, SceneError> {
        let render = with_lights(effects::render_settings(&self.render, self.sensor, self.optics.as_ref(), self.motion, self.output.as_ref())?, &self.lights)?;
        if render.effects.motion.follow_robot {
            return Err(SceneError::InvalidField {
                field: "motion.follow_robot".into(),
                reason: "only a robot scenario moves the camera with its arm; give `twist` here".into(),
            });
        }
        let cam_from_target = cam_from_rig * self.cam_from_target()?;
        let objects = object::scene_objects(&self.objects, &cam_from_target, load)?;
        let background = self.background.as_ref().map(|b| b.to_background(cam_from_rig, &cam_from_target, load)).transpose()?;
        let scene = Scene { camera: camera.to_model()?, target: self.target.to_target(), cam_from_target, render, objects, background };
        scene.validate()?;
        Ok(scene)
    }
}

impl SceneSpec {
    /// `cam_from_target` from `[pose]` or `[facing]`.
    ///
    /// # Errors
    /// Neither or both given, or an invalid field.
    pub fn cam_from_target(&self) -> Result<Isometry3<f64>, SceneError> {
        match (&self.pose, &self.facing) {
            (Some(pose), None) => pose.to_isometry(),
            (None, Some(facing)) => facing.cam_from_target(&self.target.to_target()),
            (None, None) => Err(SceneError::InvalidField { field: "pose".into(), reason: "a scene needs `[pose]` or `[facing]`".into() }),
            (Some(_), Some(_)) => Err(SceneError::InvalidField { field: "pose".into(), reason: "give `[pose]` or `[facing]`, not both".into() }),
        }
    }
}

/// Parse scene text: JSON when it starts with `{`, TOML otherwise; then validate.
///
/// # Errors
/// [`SceneError::Parse`] with the parser's message (which names missing or unknown fields), or a
/// validation error.
pub fn parse_scene(text: &str) -> Result<Scene, SceneError> {
    parse_spec(text)?.to_scene()
}

/// [`parse_scene`], loading `[[object]]` meshes with `load`.
///
/// # Errors
/// As [`parse_scene`] and [`SceneSpec::to_scene_with`].
pub fn parse_scene_with(text: &str, load: MeshLoader<'_>) -> Result<Scene, SceneError> {
    parse_spec(text)?.to_scene_with(load)
}

/// A rig's scenes from scene text ([`SceneSpec::to_rig_scenes_with`]; a single `[camera]` gives
/// one scene named `cam0`).
///
/// # Errors
/// As [`parse_scene_with`].
pub fn parse_rig_scenes_with(text: &str, load: MeshLoader<'_>) -> Result<Vec<(String, Scene)>, SceneError> {
    parse_spec(text)?.to_rig_scenes_with(load)
}

/// Scene text (JSON when it starts with `{`, TOML otherwise) into its spec, unvalidated.
///
/// # Errors
/// [`SceneError::Parse`].
pub fn parse_spec(text: &str) -> Result<SceneSpec, SceneError> {
    if text.trim_start().starts_with('{') {
        serde_json::from_str(text).map_err(|e| SceneError::Parse(e.to_string()))
    } else {
        toml::from_str(text).map_err(|e| SceneError::Parse(e.to_string()))
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use synthcam_core::target::{DotGrid, Target};

    const GOOD: &str = r#"
[camera]
width = 64
height = 48
fx = 60.0
fy = 60.0
cx = 31.5
cy = 23.5
dist = [-0.1, 0.0, 0.0, 0.0, 0.0]
[target]
kind = "chessboard"
squares = [5, 4]
square_m = 0.02
[pose]
rvec = [0.1, 0.0, 0.0]
t_m = [-0.05, -0.04, 0.3]
"#;

    #[test]
    fn parses_good_scene() {
        let s = parse_scene(GOOD).unwrap();
        assert_eq!(s.camera.size.width, 64);
        assert!(matches!(s.target, Target::Chessboard(_)));
    }

    #[test]
    fn facing_table_poses_the_board_as_the_builder_does() {
        let pose = "[pose]\nrvec = [0.1, 0.0, 0.0]\nt_m = [-0.05, -0.04, 0.3]\n";
        let facing = "[facing]\ndistance_m = 0.3\ntilt_x_deg = 10.0\nroll_deg = -5.0\n";
        let s = parse_scene(&GOOD.replace(pose, facing)).unwrap();
        let b = Scene::builder()
            .camera(s.camera)
            .target(s.target.clone())
            .facing(super::super::Facing { distance_m: 0.3, tilt_x_deg: 10.0, roll_deg: -5.0, ..Default::default() })
            .build()
            .unwrap();
        assert_eq!(s.cam_from_target, b.cam_from_target);
        let both = parse_scene(&GOOD.replace(pose, &format!("{pose}{facing}"))).unwrap_err().to_string();
        assert!(both.contains("not both"), "{both}");
        let neither = parse_scene(&GOOD.replace(pose, "")).unwrap_err().to_string();
        assert!(neither.contains("[facing]"), "{neither}");
        let typo = parse_scene(&GOOD.replace(pose, "[facing]\ndistance = 0.3\n")).unwrap_err().to_string();
        assert!(typo.contains("distance"), "{typo}");
    }

    #[test]
    fn json_scene_is_accepted() {
        let json = r#"{"camera": {"width": 64, "height": 48, "fx": 60.0, "fy": 60.0, "cx": 31.5, "cy": 23.5},
            "target": {"kind": "dot-grid", "n": 3},
            "pose": {"rvec": [0.0, 0.0, 0.0], "t_m": [0.0, 0.0, 2.0]}}"#;
        let s = parse_scene(json).unwrap();
        assert!(matches!(s.target, Target::DotGrid(DotGrid { n: 3, .. })));
        assert_eq!(s.render, crate::RenderSettings::default());
    }

    #[test]
    fn missing_field_is_named() {
        let e = parse_scene(&GOOD.replace("fx = 60.0\n", "")).unwrap_err().to_string();
        assert!(e.contains("fx"), "{e}");
    }

    #[test]
    fn nan_is_rejected_with_field() {
        let e = parse_scene(&GOOD.replace("fy = 60.0", "fy = nan")).unwrap_err().to_string();
        assert!(e.contains("fy"), "{e}");
    }

    #[test]
    fn zero_size_and_unknown_kind_and_behind() {
        let e = parse_scene(&GOOD.replace("width = 64", "width = 0")).unwrap_err().to_string();
        assert!(e.contains("width"), "{e}");
        let e = parse_scene(&GOOD.replace("\"chessboard\"", "\"hexboard\"")).unwrap_err().to_string();
        assert!(e.contains("hexboard"), "{e}");
        let e = parse_scene(&GOOD.replace("0.3]", "-0.3]")).unwrap_err();
        assert!(matches!(e, SceneError::TargetBehindCamera { .. }), "{e}");
        let e = parse_scene(&GOOD.replace("square_m = 0.02", "square_m = -0.02")).unwrap_err().to_string();
        assert!(e.contains("square_m"), "{e}");
    }

    #[test]
    fn a_fisheye_beyond_180_degrees_sees_a_board_behind_its_camera_plane() {
        let text = include_str!("../assets/scenes/fisheye_wide_chessboard.toml");
        let s = parse_scene(text).expect("wide fisheye scene");
        let centre = s.cam_from_target * nalgebra::Point3::new(0.27, 0.21, 0.0);
        assert!(centre.z < 0.0, "{centre}");
        // The same pose through a pinhole model, or a fisheye that folds at 57 degrees: behind.
        let pinhole = text.replace("model = \"fisheye\"\ndist = [0.02, -0.005, 0.0, 0.0]", "dist = [0.0, 0.0, 0.0, 0.0, 0.0]");
        assert!(matches!(parse_scene(&pinhole).unwrap_err(), SceneError::TargetBehindCamera { .. }));
        let folding = text.replace("dist = [0.02, -0.005, 0.0, 0.0]", "dist = [-0.3, 0.0, 0.0, 0.0]");
        assert!(matches!(parse_scene(&folding).unwrap_err(), SceneError::TargetBehindCamera { .. }));
    }
}
