//! The closed loop with its full record: PBVS and IBVS on any [`Sim`] (camera, target, robot of
//! an open scenario), rendered and detected at every step, or on ideal projections plus noise for
//! comparison. The course (course-scenario 3.7 / 3.8: IRB 1200, S-path, course camera) is the
//! default scenario ([`ServoScenario`], `assets/scenarios/servo_course.toml`) and is built into a
//! [`Sim`] like any other ([`ServoScenario::to_sim_scenario`]).
//!
//! At step k the sim's true joints give the true camera pose; the sensor renders the target from
//! it and the detector returns the features with their ids. PBVS runs PnP on them (for the
//! S-path's beads with the blob-centroid correction of [`super::observe`]); IBVS uses the pixels
//! directly against the desired features, which are taught by showing: observed once at the
//! desired pose, so both sides carry the same detector bias. When too few features are detected
//! the course's fallback applies: the pose comes from kinematics and the hand-eye *estimate*
//! (PBVS), or the features are predicted from it (IBVS). The loop never panics on a lost target:
//! it records why it stopped in [`ServoStatus`].
//!
//! References: F. Chaumette, S. Hutchinson, "Visual servo control, Part I", IEEE RAM 2006; ViSP's
//! `vpServo` (interaction matrix choices, adaptive gain); the course's PBVS/IBVS drivers.

use nalgebra::{Isometry3, Matrix3, Translation3, UnitQuaternion, Vector3};

use super::handeye_run::HandEyeRunError;
use super::scenario::SimScenario;
use super::sensor::sensor_for;
use super::{Sim, SimError};
use crate::controller::Law;
use crate::sensor::ObservationKind;
use crate::world;
use synthcam_core::robot::{Cell, Irb1200, Robot};
use synthcam_geometry::servo::{IbvsParams, PbvsParams};
use synthcam_render::{GreyImage, Renderer};

mod run;
mod trace;

pub use run::run_servo_in;
pub use trace::{ServoStatus, ServoTrace, Source, StepRecord};

/// A servoing scenario (TOML, `assets/scenarios/servo_course.toml`): where the robot starts,
/// where the camera should go, and the hand-eye truth (with the sampling of the hand-eye views).
#[derive(Debug, Clone, PartialEq, serde::Deserialize)]
#[serde(deny_unknown_fields)]
pub struct ServoScenario {
    /// Start configuration, radians.
    pub q_start_rad: [f64; 6],
    /// Desired camera position in the world, metres.
    pub goal_cam_t_m: [f64; 3],
    /// Desired camera rotation `world_from_cam`, rows.
    #[serde(rename = "goal_cam_R")]
    pub goal_cam_r: [[f64; 3]; 3],
    /// Hand-eye truth and the hand-eye experiment's sampling.
    pub handeye: Cell,
}

impl Default for ServoScenario {
    /// The course: q0 = (0.1, 1.6, 3.5, 3, 2, 0), T_0C* = [(-e_y, e_z, -e_x), (1.8, 0, 0.55)],
    /// hand-eye variant A.
    fn default() -> Self {
        Self {
            q_start_rad: [0.1, 1.6, 3.5, 3.0, 2.0, 0.0],
            goal_cam_t_m: [1.8, 0.0, 0.55],
            goal_cam_r: [[0.0, 0.0, -1.0], [-1.0, 0.0, 0.0], [0.0, 1.0, 0.0]],
            handeye: Cell::default(),
        }
    }
}

impl ServoScenario {
    /// The desired `world_from_cam`.
    ///
    /// # Errors
    /// A non-finite value or a rotation that is not one.
    pub fn goal(&self) -> Result<Isometry3<f64>, ServoRunError> {
        let r = Matrix3::from_fn(|i, j| self.goal_cam_r[i][j]);
        let all = self.q_start_rad.iter().chain(&self.goal_cam_t_m).chain(r.iter());
        if all.into_iter().any(|v| !v.is_finite()) {
            return Err(ServoRunError::Scenario("q_start_rad, goal_cam_t_m and goal_cam_R must be finite".into()));
        }
        if (r.transpose() * r - Matrix3::identity()).abs().max() > 1e-6 || r.determinant() < 0.0 {
            return Err(ServoRunError::Scenario("goal_cam_R is not a rotation (R^T R != I or det < 0)".into()));
        }
        Ok(Isometry3::from_parts(Translation3::from(Vector3::from(self.goal_cam_t_m)), UnitQuaternion::from_matrix(&r)))
    }

    /// The course's world as a [`SimScenario`]: the course camera, the S-path of beads (defined
    /// in the world frame, so `world_from_target` is the identity), render noise 1 grey level
    /// with 8 x 8 samples (render seeds from `seed`), the hand-eye truth, and the course's
    /// convention of unchecked joint limits.
    ///
    /// # Errors
    /// A bad goal (see [`ServoScenario::goal`]).
    pub fn to_sim_scenario(&self, seed: u64) -> Result<SimScenario, ServoRunError> {
        Ok(world(&self.handeye, &self.q_start_rad, self.goal()?.inverse(), seed))
    }
}

/// Where the loop's hand-eye estimate comes from.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum HandEyeSource {
    /// The hand-eye experiment (refined Park-Martin) with this many views, observed like the loop.
    Estimated {
        /// Views.
        views: usize,
    },
    /// The true transforms.
    Truth,
}

/// When the loop stops early (errors as the controller sees them, not the truth).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct StopCriteria {
    /// PBVS: estimated translation error, millimetres.
    pub translation_mm: f64,
    /// PBVS: estimated rotation error, degrees.
    pub rotation_deg: f64,
    /// IBVS: RMS pixel error (detected vs desired), pixels; on ideal projections at least twice
    /// their noise (the noise floor is sigma sqrt(2)).
    pub pixel_rms_px: f64,
}

impl Default for StopCriteria {
    fn default() -> Self {
        Self { translation_mm: 0.1, rotation_deg: 0.01, pixel_rms_px: 0.05 }
    }
}

/// Options of one run.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct ServoOptions {
    /// The law.
    pub law: Law,
    /// Rendered and detected, or ideal projections plus noise.
    pub observation: ObservationKind,
    /// Noise of the ideal projections, pixels (course: 0.1).
    pub ideal_noise_px: f64,
    /// Maximum number of control steps.
    pub max_steps: usize,
    /// Early stop; `None` runs every step.
    pub stop: Option<StopCriteria>,
    /// PBVS law.
    pub pbvs: PbvsParams,
    /// IBVS law.
    pub ibvs: IbvsParams,
    /// The run stops with [`ServoStatus::Singular`] when sigma_min of the robot Jacobian falls
    /// below this.
    pub singular_stop: f64,
    /// The run stops with [`ServoStatus::Stalled`] when the controller's error fell by less than
    /// 1 % over this many steps while still 10 x above the stop criterion (the default one when
    /// no stop is asked for).
    pub stall_window: usize,
    /// Fewer dots than this count as a lost target (fallback).
    pub min_dots: usize,
    /// Hand-eye estimate.
    pub handeye: HandEyeSource,
    /// Hand-eye views: joints drawn uniformly within this of the start, radians.
    pub handeye_spread_rad: f64,
    /// Seed of the hand-eye views, the render noise, the ideal noise and the start search.
    pub seed: u64,
}

impl ServoOptions {
    /// Defaults for `law`: PBVS up to 100 steps, IBVS up to 300, early stop on.
    pub fn new(law: Law) -> Self {
        Self {
            law,
            observation: ObservationKind::Rendered,
            ideal_noise_px: 0.1,
            max_steps: if law == Law::Pbvs { 100 } else { 300 },
            stop: Some(StopCriteria::default()),
            pbvs: PbvsParams::default(),
            ibvs: IbvsParams::default(),
            singular_stop: 1e-6,
            stall_window: 25,
            min_dots: 10,
            handeye: HandEyeSource::Estimated { views: 5 },
            handeye_spread_rad: 0.25,
            seed: 0,
        }
    }
}

/// Errors that prevent a run from starting (outcomes of a run are [`ServoStatus`]).
#[derive(Debug, thiserror::Error)]
#[non_exhaustive]
pub enum ServoRunError {
    /// Bad scenario or options.
    #[error("scenario: {0}")]
    Scenario(String),
    /// The hand-eye experiment failed.
    #[error("hand-eye estimate: {0}")]
    HandEye(#[from] HandEyeRunError),
    /// Rendering or detection failed for a reason other than a lost target.
    #[error(transparent)]
    Observe(#[from] super::observe::ObserveError),
    /// The simulator refused the scenario, a sensor failed, or the hand-eye estimate failed.
    #[error(transparent)]
    Sim(#[from] SimError),
}

/// Run the loop in the course's world (`scenario`, see [`ServoScenario::to_sim_scenario`]) on
/// the renderer (`options.observation` rendered) or on ideal projections. `frame` receives
/// every rendered frame (step, image).
///
/// # Errors
/// A bad scenario or options, a failed hand-eye estimate or a renderer failure; servoing outcomes
/// (converged, stalled, singular, target never visible...) are in the trace's status.
pub fn run_servo(
    renderer: Option<&Renderer>,
    scenario: &ServoScenario,
    options: &ServoOptions,
    frame: &mut dyn FnMut(usize, &GreyImage),
) -> Result<ServoTrace, ServoRunError> {
    run_servo_on(renderer, scenario.to_sim_scenario(options.seed)?, Box::new(Irb1200), Some(&scenario.handeye.q0_rad), options, frame)
}

/// Run the loop in any scenario (an open scenario file's [`SimScenario`] and robot) on the
/// renderer or on ideal projections plus `options.ideal_noise_px`, as `options.observation` says.
/// The hand-eye views are drawn around `handeye_around_rad` (default: the start joints).
///
/// # Errors
/// As [`run_servo`].
pub fn run_servo_on(
    renderer: Option<&Renderer>,
    scenario: SimScenario,
    robot: Box<dyn Robot>,
    handeye_around_rad: Option<&[f64]>,
    options: &ServoOptions,
    frame: &mut dyn FnMut(usize, &GreyImage),
) -> Result<ServoTrace, ServoRunError> {
    let sensor = sensor_for(options.observation, renderer, options.ideal_noise_px, options.seed ^ 0x1dea)?;
    let mut sim = Sim::new(scenario, robot, sensor)?;
    if let Some(q) = handeye_around_rad {
        sim.set_joints(q)?;
    }
    run_servo_in(&mut sim, options, frame)
}
