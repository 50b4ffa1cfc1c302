//! The course's hand-eye experiment (course-scenario 1.7 / 3.6, variant A) on rendered and
//! detected pixels: robot configurations around q = (0, 1.6, 3, 3, 2, 0) (+-0.25 rad per joint)
//! are drawn until the whole S-path is in view; the S-path is rendered from the true camera pose,
//! its dots are detected and ordered, PnP (with the bead-centroid correction of
//! [`super::observe`]) gives `cam_from_world` per view, and both hand-eye solvers estimate
//! `tool_from_cam` and `world_from_base`.

use nalgebra::{Isometry3, Vector3};
use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;
use rand_distr::{Distribution, Normal};

use super::observe::{pose_from_dots, render_and_detect, Dots};
use crate::camera::CameraModel;
use crate::handeye::refine::{refine_joint, JointRefinement, Observations};
use crate::handeye::{course_linear, park_martin, HandEyeResult};
use crate::render::Renderer;
use crate::robot::{base_from_tool, Cell, Joints};
use crate::scene::{RenderSettings, Scene};
use crate::target::{SPathDots, Target};

/// How the dots are observed.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Observation {
    /// Ideal projections plus N(0, 0.1^2) px noise (the course's method).
    Ideal,
    /// Rendered (noise 1 grey level) and detected.
    Rendered,
}

/// Errors of one estimate against the truth.
#[derive(Debug, Clone, Copy, PartialEq, serde::Serialize)]
pub struct PoseError {
    /// Translation error, millimetres.
    pub mm: f64,
    /// Rotation error, degrees.
    pub deg: f64,
}

impl PoseError {
    /// The error of `est` against `truth`: translation distance and rotation angle between them.
    pub fn between(est: &Isometry3<f64>, truth: &Isometry3<f64>) -> Self {
        PoseError { mm: 1e3 * (est.translation.vector - truth.translation.vector).norm(), deg: (est.rotation * truth.rotation.inverse()).angle().to_degrees() }
    }
}

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
    /// No configuration shows the whole S.
    #[error("no configuration out of {0} draws shows the whole S-path: the scenario is unreachable")]
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
    HandEye(#[from] crate::handeye::HandEyeError),
}

/// Run the experiment with `views` views.
///
/// # Errors
/// Unreachable scenario, failed detection or PnP, degenerate motions.
pub fn run_handeye(renderer: Option<&Renderer>, obs: Observation, scenario: &Cell, views: usize, seed: u64) -> Result<HandEyeRun, HandEyeRunError> {
    let cam = CameraModel::course_default();
    let target = SPathDots::default();
    let pts = target.path.points_m.clone();
    let (x_true, wb_true) = scenario.truth();
    let mut rng = ChaCha8Rng::seed_from_u64(seed);
    let q0 = scenario.q0_rad;
    let spread = scenario.spread_rad.abs().max(1e-12);
    let (mut bt, mut wc, mut pnp_mm) = (Vec::new(), Vec::new(), Vec::new());
    let mut observations: Vec<Observations> = Vec::new();
    let mut drawn = 0;
    let max_draws = 400 * views.max(1);
    while bt.len() < views {
        if drawn >= max_draws {
            return Err(HandEyeRunError::Unreachable(drawn));
        }
        drawn += 1;
        let q = Joints::from_iterator(q0.iter().map(|v| v + rng.random_range(-spread..spread)));
        let base_from_tool_q = base_from_tool(&q);
        let world_from_cam = wb_true * base_from_tool_q * x_true;
        let cam_from_world = world_from_cam.inverse();
        if !cam.sees_all(&cam_from_world, &pts, 0.0) {
            continue;
        }
        let view = bt.len();
        let scene = Scene {
            camera: cam,
            target: Target::SPath(target.clone()),
            cam_from_target: cam_from_world,
            render: RenderSettings { noise_sigma: 1.0, samples: 8, seed: rng.random(), ..Default::default() },
        };
        // Path index and pixel of every observed dot.
        let dots = match obs {
            Observation::Ideal => {
                let n = Normal::new(0.0, 0.1).map_err(|e| HandEyeRunError::View { view, reason: e.to_string() })?;
                Dots {
                    ids: (0..pts.len()).collect(),
                    pixels_px: pts
                        .iter()
                        .map(|p| cam.project_unchecked(&(cam_from_world * p)) + Vector3::new(n.sample(&mut rng), n.sample(&mut rng), 0.0).xy())
                        .collect(),
                }
            }
            Observation::Rendered => {
                let r = renderer.ok_or_else(|| HandEyeRunError::View { view, reason: "no renderer".into() })?;
                let seen = render_and_detect(r, &scene).map_err(|e| HandEyeRunError::View { view, reason: e.to_string() })?;
                seen.dots.ok_or_else(|| HandEyeRunError::View { view, reason: seen.note.unwrap_or_else(|| "S-path not found".into()) })?
            }
        };
        let points: Vec<_> = dots.ids.iter().map(|i| pts[*i]).collect();
        // Rendered beads: two rounds of the centroid-bias correction.
        let rounds = if obs == Observation::Rendered { 2 } else { 0 };
        let (est, used_pixels) = pose_from_dots(&scene, &dots, rounds).map_err(|e| HandEyeRunError::View { view, reason: e.to_string() })?;
        observations.push(points.iter().copied().zip(used_pixels).collect());
        let wc_est = est.cam_from_target.inverse();
        pnp_mm.push(1e3 * (wc_est.translation.vector - world_from_cam.translation.vector).norm());
        bt.push(base_from_tool_q);
        wc.push(wc_est);
    }
    let r_tc = x_true.rotation.to_rotation_matrix().into_inner();
    let linear = course_linear(&bt, &wc, &r_tc)?;
    let pm = park_martin(&bt, &wc)?;
    let refined = refine_joint(&cam, &bt, &observations, &pm);
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
