//! Experiments on rendered (or ideal) pixels. The open step API: [`Sim`] (a robot carrying a
//! camera in a cell with a target, any camera, target and [`synthcam_core::robot::Robot`]), observed
//! through a [`sensor::Sensor`] (the GPU renderer and detector, or ideal projections), driven by a
//! [`controller::Controller`] (a user's, or synthcam's PBVS and IBVS), described by a scenario
//! file ([`scenario`]); observing a target ([`observe`]: render, detect, PnP with the S-path's
//! bead correction), drawing hand-eye views ([`handeye_views`]), open-scenario runs ([`open_run`])
//! and the robustness experiment ([`robustness`]). The course's own experiments build on this in
//! `synthcam-course`.
//!
//! Pure of files: everything here returns values that `synthcam_io::report` formats and the CLI writes.
//!
//! ```no_run
//! use synthcam_render::Renderer;
//! use synthcam_sim::{controller::{run_loop, EyeInHand, Pbvs}, sensor::RenderedSensor, ScenarioSpec, Sim};
//! # fn main() -> Result<(), Box<dyn std::error::Error>> {
//! let spec = ScenarioSpec::parse(synthcam_sim::UR5E_CHESSBOARD)?;
//! let scenario = spec.to_scenario()?;
//! let robot = spec.robot.build(&|_| Err("no files".into()))?;
//! let renderer = Renderer::headless()?;
//! let goal = scenario.goal_cam_from_target;
//! let cell = EyeInHand { camera: scenario.camera, target: scenario.target.clone(), tool_from_cam: scenario.tool_from_cam };
//! let mut sim = Sim::new(scenario, robot, Box::new(RenderedSensor::new(&renderer)))?;
//! let mut pbvs = Pbvs { cell, goal_cam_from_target: goal, params: Default::default(), stop_mm_deg: (0.05, 0.005), base_from_target: None, bias: Default::default() };
//! let trace = run_loop(&mut sim, &mut pbvs, &goal, 1.0, 100)?;
//! println!("{:?}", trace.steps.last().map(|s| s.goal_error_mm_deg));
//! # Ok(()) }
//! ```

#![deny(missing_docs)]

pub mod controller;
pub mod handeye_views;
pub mod loop_bias;
pub mod observe;
pub mod open_run;
pub mod robustness;
pub mod scenario;
pub mod sensor;
pub mod world;

pub use scenario::{JointLimits, RobotSpec, ScenarioSpec, SimScenario};
pub use world::{Observation, Sim};

/// The worked non-course scenario: a UR5e, a 9 x 7-square chessboard, a 1920 x 1200 camera with
/// f = 1100 px and k1 = -0.2 (`assets/scenarios/ur5e_chessboard.toml`).
pub const UR5E_CHESSBOARD: &str = include_str!("../assets/scenarios/ur5e_chessboard.toml");

/// Errors of the simulator and its controllers.
#[derive(Debug, thiserror::Error)]
#[non_exhaustive]
pub enum SimError {
    /// A bad scenario (named field or reason).
    #[error("scenario: {0}")]
    Scenario(String),
    /// A scene part of the scenario is invalid.
    #[error(transparent)]
    Scene(#[from] synthcam_scene::SceneError),
    /// The robot model refused the joints or its URDF.
    #[error(transparent)]
    Robot(#[from] synthcam_core::robot::RobotError),
    /// A bad command (length, non-finite, dt).
    #[error("command: {0}")]
    Command(String),
    /// The controller could not compute a command.
    #[error("controller: {0}")]
    Control(String),
    /// The renderer failed, or the detector rejected the image buffer.
    #[error(transparent)]
    Observe(#[from] observe::ObserveError),
    /// The renderer failed.
    #[error(transparent)]
    Render(#[from] synthcam_render::RenderError),
    /// The detector rejected the image buffer.
    #[error(transparent)]
    Detect(#[from] synthcam_detect::DetectError),
}
