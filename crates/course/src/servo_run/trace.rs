//! The trace of a servo run: how it ended, and every step's truth, estimate and timing.

use crate::controller::{Law, PoseError};

/// How a run ended.
#[derive(Debug, Clone, PartialEq, serde::Serialize)]
#[serde(tag = "status", rename_all = "snake_case")]
pub enum ServoStatus {
    /// The stop criterion was met.
    Converged,
    /// All steps ran (no stop criterion, or it was not met).
    MaxSteps,
    /// The controller's error stopped decreasing far from the goal: the desired pose is probably
    /// unreachable (or a local minimum).
    Stalled,
    /// The robot Jacobian became singular.
    Singular {
        /// Its smallest singular value.
        sigma_min: f64,
    },
    /// No start configuration shows the whole target.
    TargetNeverVisible {
        /// Start configurations tried.
        tries: usize,
    },
    /// The desired pose does not show the whole target (no desired features).
    GoalNotVisible {
        /// Why.
        reason: String,
    },
    /// The joints became non-finite.
    Diverged,
    /// The next joints were refused (a joint limit, with the scenario's `joint_limits = "enforce"`).
    JointLimit {
        /// The robot's reason.
        reason: String,
    },
}

impl ServoStatus {
    /// Whether this is a success (the run reached its goal or ran its steps as asked).
    pub fn is_success(&self, stop_requested: bool) -> bool {
        matches!(self, ServoStatus::Converged) || (!stop_requested && matches!(self, ServoStatus::MaxSteps))
    }

    /// One line for people.
    pub fn describe(&self) -> String {
        match self {
            ServoStatus::Converged => "converged (stop criterion met)".into(),
            ServoStatus::MaxSteps => "ran all steps".into(),
            ServoStatus::Stalled => "stalled: the error stopped decreasing far from the goal (unreachable desired pose?)".into(),
            ServoStatus::Singular { sigma_min } => format!("stopped at a singular configuration (sigma_min(J) = {sigma_min:.2e})"),
            ServoStatus::TargetNeverVisible { tries } => {
                format!("the target is not fully in view from the start configuration nor from {tries} perturbed ones")
            }
            ServoStatus::GoalNotVisible { reason } => format!("the desired pose does not show the target: {reason}"),
            ServoStatus::Diverged => "diverged: the joints became non-finite".into(),
            ServoStatus::JointLimit { reason } => format!("stopped at a joint limit: {reason}"),
        }
    }
}

/// Where a step's measurement came from.
#[derive(Debug, Clone, Copy, PartialEq, Eq, serde::Serialize)]
#[serde(rename_all = "lowercase")]
pub enum Source {
    /// Rendered and detected dots.
    Detected,
    /// Ideal projections plus noise.
    Ideal,
    /// Too few dots: kinematics and the hand-eye estimate.
    Fallback,
}

/// One step of the trace (measured before the step's update).
#[derive(Debug, Clone, PartialEq, serde::Serialize)]
pub struct StepRecord {
    /// Step index (0: the start).
    pub step: usize,
    /// Joints, radians.
    pub q_rad: Vec<f64>,
    /// True camera position in the world, metres.
    pub cam_position_m: [f64; 3],
    /// True camera pose vs the desired pose.
    pub pose_error_mm: f64,
    /// True camera rotation vs the desired rotation, degrees.
    pub pose_error_deg: f64,
    /// The controller's own estimate of the translation error, millimetres.
    pub est_error_mm: f64,
    /// The controller's own estimate of the rotation error, degrees.
    pub est_error_deg: f64,
    /// Measured vs desired features over the matched dots, RMS of the point distances, pixels.
    pub pixel_rms_px: f64,
    /// Largest point distance, pixels.
    pub pixel_max_px: f64,
    /// Smallest singular value of the robot Jacobian.
    pub sigma_min_robot: f64,
    /// Smallest singular value of the image Jacobian d(pixels)/d(q).
    pub sigma_min_image: f64,
    /// Dots detected (ideal: visible).
    pub dots: usize,
    /// Whether the joints are inside the robot's limits (with `joint_limits = "ignore"`, as in
    /// the course, the loop reports them and does not stop).
    pub within_limits: bool,
    /// Where the measurement came from.
    pub source: Source,
    /// Gain used for this step's update.
    pub gain: f64,
    /// Render + readback, milliseconds.
    pub render_ms: f64,
    /// Detection, milliseconds.
    pub detect_ms: f64,
    /// Pose estimation, Jacobians and the law, milliseconds.
    pub law_ms: f64,
    /// Measured features `[id, u, v]`.
    pub features_px: Vec<[f64; 3]>,
}

/// A whole run.
#[derive(Debug, Clone, PartialEq, serde::Serialize)]
pub struct ServoTrace {
    /// The law.
    pub law: Law,
    /// "rendered" or "ideal".
    pub observation: &'static str,
    /// How it ended.
    pub status: ServoStatus,
    /// Control updates applied.
    pub updates: usize,
    /// Hand-eye estimate errors used by the loop: `tool_from_cam` and `target_from_base` (for the
    /// course the target frame is the world: `world_from_base`).
    pub handeye_error: [PoseError; 2],
    /// Desired features per path index (`None`: not visible at the goal).
    pub desired_px: Vec<Option<[f64; 2]>>,
    /// Desired camera position, metres.
    pub goal_position_m: [f64; 3],
    /// Start configuration after the visibility search, radians.
    pub q_start_rad: Vec<f64>,
    /// The steps.
    pub steps: Vec<StepRecord>,
    /// Hand-eye experiment wall time, seconds.
    pub handeye_s: f64,
    /// Loop wall time (steps only), seconds.
    pub loop_s: f64,
}

impl ServoTrace {
    /// The last step.
    pub fn last(&self) -> Option<&StepRecord> {
        self.steps.last()
    }

    /// Total (render, detect, law) milliseconds over the steps.
    pub fn time_split_ms(&self) -> (f64, f64, f64) {
        self.steps.iter().fold((0.0, 0.0, 0.0), |a, s| (a.0 + s.render_ms, a.1 + s.detect_ms, a.2 + s.law_ms))
    }
}
