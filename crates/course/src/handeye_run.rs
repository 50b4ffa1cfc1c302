//! The hand-eye experiment on rendered and detected pixels, in any [`Sim`] ([`run_handeye_in`]);
//! the course's (course-scenario 1.7 / 3.6, variant A) is [`run_handeye`]: robot configurations
//! around q = (0, 1.6, 3, 3, 2, 0) (+-0.25 rad per joint) are drawn until the whole S-path is in
//! view; the S-path is rendered from the true camera pose, its dots are detected and ordered, PnP
//! (with the bead-centroid correction of [`super::observe`]) gives `cam_from_world` per view, and
//! the hand-eye solvers estimate `tool_from_cam` and `world_from_base`.

use nalgebra::Isometry3;

use super::controller::{EyeInHand, PoseError};
use super::handeye_views::{draw_views, Draw, DrawFailure, Views};
use super::scenario::SimScenario;
use super::sensor::sensor_for;
use super::sensor::ObservationKind;
use super::{Sim, SimError};
use crate::world;
use synthcam_core::robot::{Cell, Irb1200, Robot};
use synthcam_geometry::handeye::refine::{refine_joint, JointRefinement};
use synthcam_geometry::handeye::{linear_known_rotations, park_martin, HandEyeResult};
use synthcam_render::Renderer;

/// Result of one hand-eye run.
#[derive(Debug, Clone, PartialEq)]
pub struct HandEyeRun {
    /// The course's linear solver (rotations known).
    pub linear: HandEyeResult,
    /// Park-Martin (rotations unknown).
    pub park_martin: HandEyeResult,
    /// Park-Martin refined jointly on the reprojection error of all views.
    pub refined: JointRefinement,
    /// Errors: linear `tool_from_cam`, linear `world_from_base`, Park-Martin `tool_from_cam`,
    /// Park-Martin `world_from_base`, refined `tool_from_cam`, refined `world_from_base`.
    pub errors: [PoseError; 6],
    /// Per view: PnP camera-position error, millimetres.
    pub pnp_mm: Vec<f64>,
    /// Robot configurations drawn to get the views (acceptance rate).
    pub drawn: usize,
}

/// Errors of the experiment.
#[derive(Debug, thiserror::Error)]
#[non_exhaustive]
pub enum HandEyeRunError {
    /// Too few configurations show the whole target (and have it detected).
    #[error("too few of {0} drawn configurations show the whole target and have it detected: the scenario is unreachable")]
    Unreachable(usize),
    /// A view could not be measured.
    #[error("view {view}: {reason}")]
    View {
        /// View index.
        view: usize,
        /// Why.
        reason: String,
    },
    /// The solvers failed.
    #[error(transparent)]
    HandEye(#[from] synthcam_geometry::handeye::HandEyeError),
    /// The simulator refused the scenario or joints, or a sensor failed.
    #[error(transparent)]
    Sim(#[from] SimError),
}

/// Run the course's experiment with `views` views: the course's world (course camera, S-path,
/// IRB 1200, the hand-eye truth of `scenario`), configurations around `scenario.q0_rad`.
///
/// # Errors
/// Unreachable scenario, failed detection or PnP, degenerate motions.
pub fn run_handeye(renderer: Option<&Renderer>, obs: ObservationKind, scenario: &Cell, views: usize, seed: u64) -> Result<HandEyeRun, HandEyeRunError> {
    let sc = world(scenario, &scenario.q0_rad, Isometry3::identity(), seed);
    run_handeye_on(renderer, obs, sc, Box::new(Irb1200), views, scenario.spread_rad, seed)
}

/// The experiment in any scenario (an open scenario file's [`SimScenario`] and robot), views
/// drawn around its start joints, observed as `obs` says (ideal: 0.1 px noise).
///
/// # Errors
/// As [`run_handeye_in`], and a scenario the simulator refuses.
pub fn run_handeye_on(
    renderer: Option<&Renderer>,
    obs: ObservationKind,
    scenario: SimScenario,
    robot: Box<dyn Robot>,
    views: usize,
    spread_rad: f64,
    seed: u64,
) -> Result<HandEyeRun, HandEyeRunError> {
    let sensor = sensor_for(obs, renderer, 0.1, seed)?;
    let mut sim = Sim::new(scenario, robot, sensor)?;
    run_handeye_in(&mut sim, views, spread_rad, seed)
}

/// Fewest detected features a hand-eye view may have.
const MIN_VIEW_FEATURES: usize = 10;

/// The hand-eye experiment in any [`Sim`]: configurations drawn uniformly within `spread_rad` of
/// the current joints until `views` show the whole target and the detector finds at least 10
/// features in them; each is observed, PnP (for the
/// S-path's rendered beads with two rounds of the centroid correction) gives `cam_from_target`,
/// and the course's linear solver, Park-Martin and the joint refinement estimate
/// `tool_from_cam` and `target_from_base` (the course's `world_from_base`: its target frame is
/// the world). The arm is returned to its joints afterwards.
///
/// # Errors
/// Fewer than `views` usable views (the whole target predicted in the image and at least 10
/// features detected) in 400 draws per view, failed PnP, degenerate motions.
pub fn run_handeye_in(sim: &mut Sim<'_>, views: usize, spread_rad: f64, seed: u64) -> Result<HandEyeRun, HandEyeRunError> {
    let sc = sim.scenario().clone();
    let (x_true, wb_true) = (sc.tool_from_cam, sc.world_from_target.inverse() * sc.world_from_base);
    let cell = EyeInHand { camera: sc.camera, target: sc.target.clone(), tool_from_cam: x_true };
    // A partial detection (dots hidden at the sphere's rim) still gives a pose; a view the
    // detector cannot use (too few features: a board not found whole) is drawn again.
    let draw = Draw { views, spread_rad, margin_px: 0.0, min_features: MIN_VIEW_FEATURES, seed };
    let Views { base_from_tool: bt, target_from_cam: wc, truth_target_from_cam, observations, drawn } = draw_views(sim, &cell, &draw).map_err(|f| match f {
        DrawFailure::Unreachable(drawn) => HandEyeRunError::Unreachable(drawn),
        DrawFailure::View { view, error } => HandEyeRunError::View { view, reason: error.to_string() },
        DrawFailure::Sim(e) => HandEyeRunError::Sim(e),
    })?;
    let pnp_mm = wc.iter().zip(&truth_target_from_cam).map(|(e, t)| 1e3 * (e.translation.vector - t.translation.vector).norm()).collect();
    let r_tc = x_true.rotation.to_rotation_matrix().into_inner();
    let linear = linear_known_rotations(&bt, &wc, &r_tc, &wb_true.rotation.to_rotation_matrix().into_inner())?;
    let pm = park_martin(&bt, &wc)?;
    let refined = refine_joint(&sc.camera, &bt, &observations, &pm);
    let errors = [
        PoseError::between(&linear.tool_from_cam, &x_true),
        PoseError::between(&linear.world_from_base, &wb_true),
        PoseError::between(&pm.tool_from_cam, &x_true),
        PoseError::between(&pm.world_from_base, &wb_true),
        PoseError::between(&refined.tool_from_cam, &x_true),
        PoseError::between(&refined.world_from_base, &wb_true),
    ];
    Ok(HandEyeRun { linear, park_martin: pm, refined, errors, pnp_mm, drawn })
}
