//! An open simulation scenario (TOML): any camera, any target, any robot, the cell's layout, the
//! start and the goal. `assets/scenarios/ur5e_chessboard.toml` is a worked example:
//!
//! ```toml
//! robot = "ur5e"                 # "irb1200", "ur5e", or { urdf = "path.urdf", base = "base_link", tip = "tool0" }
//! q_start_rad = [0.2, -1.6, 1.7, -1.7, -1.6, 0.1]
//!
//! [camera]                       # the scene file's [camera] table
//! width = 1920
//! height = 1200
//! fx = 1100.0
//! fy = 1100.0
//! cx = 959.5
//! cy = 599.5
//! dist = [-0.2, 0.0, 0.0, 0.0, 0.0]
//!
//! [target]                       # the scene file's [target] table
//! kind = "chessboard"
//! squares = [9, 7]
//! square_m = 0.04
//!
//! [render]                       # the scene file's [render] table
//! noise_sigma = 1.0
//!
//! [world_from_base]              # a pose table (R or rvec, t_m)
//! rvec = [0.0, 0.0, 0.0]
//! t_m = [0.0, 0.0, 0.0]
//!
//! [tool_from_cam]
//! rvec = [0.0, 0.0, 0.0]
//! t_m = [0.0, 0.05, 0.03]
//!
//! [world_from_target]
//! rvec = [0.0, 0.0, 0.0]
//! t_m = [-0.5, -0.2, -0.3]
//!
//! [goal_cam_from_target]         # where the camera should end up, seen from the target
//! rvec = [0.0, 0.0, 0.0]
//! t_m = [-0.16, -0.12, 0.45]
//! ```
//!
//! An optional top-level `joint_limits = "ignore"` lets the arm pass its joint limits (the
//! course's convention; `assets/scenarios/course_sim.toml`); the default is `"enforce"`.

use nalgebra::{Isometry3, Point2, Point3};
use serde::Deserialize;

use super::SimError;
use synthcam_core::camera::CameraModel;
use synthcam_core::robot::chain::{IRB1200_URDF, UR5E_URDF};
use synthcam_core::robot::{Irb1200, Robot, SerialChain};
use synthcam_core::target::Target;
use synthcam_scene::file::{CameraSpec, PoseSpec, RenderSpec, TargetTable};
use synthcam_scene::RenderSettings;

/// Which robot: a built-in name or a URDF file.
#[derive(Debug, Clone, PartialEq, Eq, Deserialize)]
#[serde(untagged)]
pub enum RobotSpec {
    /// `"irb1200"` (the course's product-of-exponentials model), `"irb1200-urdf"` or `"ur5e"`
    /// (the URDFs in `assets/robots/`).
    Named(String),
    /// A URDF file and the chain's end links.
    Urdf {
        /// Path of the URDF file (read by the caller: see [`RobotSpec::build`]).
        urdf: String,
        /// Base link.
        base: String,
        /// Tip (tool) link.
        tip: String,
    },
}

impl RobotSpec {
    /// The robot. `read` reads a URDF path (the CLI passes `std::fs::read_to_string`; the
    /// library itself touches no files).
    ///
    /// # Errors
    /// An unknown name, a file `read` cannot read, or a URDF that is not a serial chain.
    pub fn build(&self, read: &dyn Fn(&str) -> Result<String, String>) -> Result<Box<dyn Robot>, SimError> {
        match self {
            RobotSpec::Named(n) => match n.as_str() {
                "irb1200" => Ok(Box::new(Irb1200)),
                "irb1200-urdf" => Ok(Box::new(SerialChain::from_urdf(IRB1200_URDF, "base_link", "tool0")?)),
                "ur5e" => Ok(Box::new(SerialChain::from_urdf(UR5E_URDF, "base_link", "tool0")?)),
                other => Err(SimError::Scenario(format!("unknown robot `{other}` (irb1200, irb1200-urdf, ur5e, or {{ urdf, base, tip }})"))),
            },
            RobotSpec::Urdf { urdf, base, tip } => {
                let text = read(urdf).map_err(|e| SimError::Scenario(format!("cannot read URDF {urdf}: {e}")))?;
                Ok(Box::new(SerialChain::from_urdf(&text, base, tip)?))
            }
        }
    }
}

/// Whether the simulated arm stops at its joint limits.
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq, Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum JointLimits {
    /// A command or configuration past a limit is an error (a real arm's controller).
    #[default]
    Enforce,
    /// Limits are not checked (the course's convention: it wraps angles and only reports them).
    Ignore,
}

/// The scenario file.
#[derive(Debug, Clone, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct ScenarioSpec {
    /// The robot.
    pub robot: RobotSpec,
    /// Start joints.
    pub q_start_rad: Vec<f64>,
    /// The camera.
    pub camera: CameraSpec,
    /// The target.
    pub target: TargetTable,
    /// Image formation.
    #[serde(default)]
    pub render: RenderSpec,
    /// `[sensor]` (optional; as in scene files).
    #[serde(default)]
    pub sensor: Option<synthcam_core::camera::sensor::SensorModel>,
    /// `[optics]` (optional).
    #[serde(default)]
    pub optics: Option<synthcam_scene::file::effects::OpticsSpec>,
    /// `[motion]` (optional; `follow_robot = true`: the camera moves with the arm during each
    /// exposure).
    #[serde(default)]
    pub motion: Option<synthcam_scene::motion::Motion>,
    /// `[output]` (optional).
    #[serde(default)]
    pub output: Option<synthcam_scene::file::effects::OutputSpec>,
    /// The robot's base in the world.
    pub world_from_base: PoseSpec,
    /// The camera on the tool (the hand-eye truth).
    pub tool_from_cam: PoseSpec,
    /// The target in the world.
    pub world_from_target: PoseSpec,
    /// The desired camera pose, seen from the target.
    pub goal_cam_from_target: PoseSpec,
    /// `"enforce"` (default) or `"ignore"`.
    #[serde(default)]
    pub joint_limits: JointLimits,
    /// `[[object]]` tables: meshes in the world, carried by the tool, or fixed to the camera or
    /// the target (`frame`; [`synthcam_scene::file::object`]).
    #[serde(default, rename = "object")]
    pub objects: Vec<synthcam_scene::file::ObjectSpec>,
}

/// A validated scenario, everything a [`super::Sim`] needs but the robot model.
#[derive(Debug, Clone, PartialEq)]
pub struct SimScenario {
    /// The camera.
    pub camera: CameraModel,
    /// The target.
    pub target: Target,
    /// Image formation (the seed is advanced per frame).
    pub render: RenderSettings,
    /// The robot's base in the world.
    pub world_from_base: Isometry3<f64>,
    /// The camera on the tool.
    pub tool_from_cam: Isometry3<f64>,
    /// The target in the world.
    pub world_from_target: Isometry3<f64>,
    /// Desired `cam_from_target`.
    pub goal_cam_from_target: Isometry3<f64>,
    /// Start joints.
    pub q_start_rad: Vec<f64>,
    /// Joint limits enforced or not.
    pub joint_limits: JointLimits,
    /// Objects, each with the frame its pose is given in (`cam_from_object` holds
    /// `frame_from_object`; [`super::world`] places them every frame).
    pub objects: Vec<(synthcam_scene::file::ObjectFrame, synthcam_scene::objects::SceneObject)>,
}

impl SimScenario {
    /// Every feature's exact pixel with the camera at `cam_from_target` (`None` where it is not
    /// visible), from the camera model: no rendering.
    pub fn projected_px(&self, cam_from_target: &Isometry3<f64>) -> Vec<Option<Point2<f64>>> {
        let project = |p: &Point3<f64>| {
            let pr = self.camera.project(&(cam_from_target * p));
            pr.visible().then_some(pr.pixel_px)
        };
        self.target.feature_points_m().iter().map(project).collect()
    }
}

impl ScenarioSpec {
    /// Parse TOML text.
    ///
    /// # Errors
    /// [`SimError::Scenario`] with the parser's message (it names missing and unknown fields).
    pub fn parse(text: &str) -> Result<Self, SimError> {
        toml::from_str(text).map_err(|e| SimError::Scenario(e.to_string()))
    }

    /// Validate into a [`SimScenario`].
    ///
    /// # Errors
    /// An invalid camera, target or pose (named).
    pub fn to_scenario(&self) -> Result<SimScenario, SimError> {
        self.to_scenario_with(&|path: &str| {
            Err(synthcam_core::mesh::MeshError::Invalid {
                path: path.into(),
                reason: "this scenario has objects: load it with a mesh loader (ScenarioSpec::to_scenario_with)".into(),
            })
        })
    }

    /// [`ScenarioSpec::to_scenario`], loading `[[object]]` meshes with `load`.
    ///
    /// # Errors
    /// As [`ScenarioSpec::to_scenario`], and a mesh that does not load or an invalid object field.
    pub fn to_scenario_with(&self, load: synthcam_scene::file::MeshLoader<'_>) -> Result<SimScenario, SimError> {
        let camera = self.camera.to_model().map_err(synthcam_scene::SceneError::from)?;
        camera.validate().map_err(synthcam_scene::SceneError::from)?;
        let target = self.target.to_target();
        target.validate().map_err(synthcam_scene::SceneError::from)?;
        if self.q_start_rad.iter().any(|v| !v.is_finite()) {
            return Err(SimError::Scenario(format!("q_start_rad must be finite, got {:?}", self.q_start_rad)));
        }
        let render = synthcam_scene::file::effects::render_settings(&self.render, self.sensor, self.optics.as_ref(), self.motion, self.output.as_ref())?;
        let moving = render.effects.motion.follow_robot && (render.effects.motion.exposure_s > 0.0 || render.effects.motion.line_delay_s > 0.0);
        if (moving || render.effects.optics.thin_lens.is_some()) && matches!(target, Target::SPath(_)) {
            return Err(SimError::Scenario(
                "[motion] follow_robot and [optics] f_number render planar targets only (chessboard, dot grid, ChArUco, AprilGrid), not the S-path".into(),
            ));
        }
        if !self.objects.is_empty() && (matches!(target, Target::SPath(_)) || render.effects.needs_views()) {
            return Err(SimError::Scenario("[[object]] renders with planar targets and without defocus, motion blur or a rolling shutter".into()));
        }
        Ok(SimScenario {
            camera,
            target,
            render,
            world_from_base: self.world_from_base.to_isometry()?,
            tool_from_cam: self.tool_from_cam.to_isometry()?,
            world_from_target: self.world_from_target.to_isometry()?,
            goal_cam_from_target: self.goal_cam_from_target.to_isometry()?,
            q_start_rad: self.q_start_rad.clone(),
            joint_limits: self.joint_limits,
            objects: self
                .objects
                .iter()
                .enumerate()
                .map(|(i, o)| Ok((o.frame, o.to_object(i, &Isometry3::identity(), load)?)))
                .collect::<Result<_, synthcam_scene::SceneError>>()?,
        })
    }
}
