//! The closed loop: PBVS and IBVS on the IRB 1200 with the S-path rendered and detected at every
//! step (course-scenario 3.7 / 3.8), or on ideal projections plus noise for comparison.
//!
//! At step k, forward kinematics with the *true* hand-eye transforms gives the true camera pose;
//! the renderer draws the S-path from it and the detector returns the ordered dots. PBVS runs PnP
//! on them (with the bead-centroid correction of [`super::observe`]); IBVS uses the pixels
//! directly against the desired features, which are taught by showing: rendered and detected
//! once at the desired pose, so both sides carry the same blob-centroid bias. When too few dots
//! are detected the course's fallback applies: the pose comes from kinematics and the hand-eye
//! *estimate* (PBVS), or the features are predicted from it (IBVS). The loop never panics on a
//! lost target: it records why it stopped in [`ServoStatus`].
//!
//! References: F. Chaumette, S. Hutchinson, "Visual servo control, Part I", IEEE RAM 2006; ViSP's
//! `vpServo` (interaction matrix choices, adaptive gain); the course's PBVS/IBVS drivers.

use std::time::Instant;

use nalgebra::{DMatrix, Isometry3, Matrix3, Point2, Point3, Translation3, UnitQuaternion, Vector3};
use rand::SeedableRng;
use rand_chacha::ChaCha8Rng;
use rand_distr::{Distribution, Normal};

use super::handeye_run::{run_handeye, HandEyeRunError, Observation, PoseError};
use super::observe::{pose_from_dots, pose_from_dots_cached, render_and_detect, Dots};
use crate::camera::CameraModel;
use crate::render::{GreyImage, Renderer};
use crate::robot::{base_from_tool, check_limits, jacobian, wrap, Cell, Joints};
use crate::scene::{RenderSettings, Scene};
use crate::servo::{cam_twist_jacobian, ibvs_step, interaction_matrix, joint_image_jacobian, pbvs_error, pbvs_step, IbvsParams, InteractionFrom, PbvsParams};
use crate::target::{SPathDots, Target};

/// The control law.
#[derive(Debug, Clone, Copy, PartialEq, Eq, serde::Serialize)]
#[serde(rename_all = "lowercase")]
pub enum Law {
    /// Position-based: PnP pose, tool-pose error.
    Pbvs,
    /// Image-based: pixel error through the image Jacobian.
    Ibvs,
}

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
    pub observation: Observation,
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
    /// Seed of the hand-eye views, the render noise, the ideal noise and the start search.
    pub seed: u64,
}

impl ServoOptions {
    /// Defaults for `law`: PBVS up to 100 steps, IBVS up to 300, early stop on.
    pub fn new(law: Law) -> Self {
        Self {
            law,
            observation: Observation::Rendered,
            ideal_noise_px: 0.1,
            max_steps: if law == Law::Pbvs { 100 } else { 300 },
            stop: Some(StopCriteria::default()),
            pbvs: PbvsParams::default(),
            ibvs: IbvsParams::default(),
            singular_stop: 1e-6,
            stall_window: 25,
            min_dots: 10,
            handeye: HandEyeSource::Estimated { views: 5 },
            seed: 0,
        }
    }
}

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
    /// No start configuration shows the whole S-path.
    TargetNeverVisible {
        /// Start configurations tried.
        tries: usize,
    },
    /// The desired pose does not show the whole S-path (no desired features).
    GoalNotVisible {
        /// Why.
        reason: String,
    },
    /// The joints became non-finite.
    Diverged,
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
                format!("the S-path is not fully in view from the start configuration nor from {tries} perturbed ones")
            }
            ServoStatus::GoalNotVisible { reason } => format!("the desired pose does not show the S-path: {reason}"),
            ServoStatus::Diverged => "diverged: the joints became non-finite".into(),
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
    pub q_rad: [f64; 6],
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
    /// Whether the joints are inside the IRB 1200's limits (the course only wraps them; the loop
    /// reports, it does not clamp).
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
    /// Hand-eye estimate errors used by the loop: `tool_from_cam`, `world_from_base`.
    pub handeye_error: [PoseError; 2],
    /// Desired features per path index (`None`: not visible at the goal).
    pub desired_px: Vec<Option<[f64; 2]>>,
    /// Desired camera position, metres.
    pub goal_position_m: [f64; 3],
    /// Start configuration after the visibility search, radians.
    pub q_start_rad: [f64; 6],
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
}

/// Observations of one step, before the law.
struct Measured {
    dots: Option<Dots>,
    count: usize,
    render_ms: f64,
    detect_ms: f64,
}

/// Everything fixed during a run.
struct Setup<'a> {
    renderer: Option<&'a Renderer>,
    options: &'a ServoOptions,
    scene: Scene,
    pts: Vec<Point3<f64>>,
    world_from_base_est: Isometry3<f64>,
    tool_from_cam_est: Isometry3<f64>,
    goal: Isometry3<f64>,
}

impl Setup<'_> {
    fn observe(
        &self,
        cam_from_world: &Isometry3<f64>,
        rng: &mut ChaCha8Rng,
        frame: &mut dyn FnMut(usize, &GreyImage),
        step: usize,
    ) -> Result<Measured, ServoRunError> {
        match (self.options.observation, self.renderer) {
            (Observation::Rendered, Some(r)) => {
                let scene = Scene {
                    cam_from_target: *cam_from_world,
                    render: RenderSettings { seed: rand::Rng::random(rng), ..self.scene.render },
                    ..self.scene.clone()
                };
                let seen = render_and_detect(r, &scene)?;
                frame(step, &seen.image);
                let count = seen.dots.as_ref().map_or(0, |d| d.ids.len());
                Ok(Measured { dots: seen.dots, count, render_ms: seen.render_ms, detect_ms: seen.detect_ms })
            }
            (Observation::Rendered, None) => Err(ServoRunError::Scenario("rendered observation needs a renderer".into())),
            (Observation::Ideal, _) => {
                let n = Normal::new(0.0, self.options.ideal_noise_px.max(0.0)).map_err(|e| ServoRunError::Scenario(e.to_string()))?;
                let cam = &self.scene.camera;
                let mut dots = Dots::default();
                for (i, p) in self.pts.iter().enumerate() {
                    let pr = cam.project(&(cam_from_world * p));
                    if pr.visible() {
                        dots.ids.push(i);
                        dots.pixels_px.push(pr.pixel_px + Vector3::new(n.sample(rng), n.sample(rng), 0.0).xy());
                    }
                }
                Ok(Measured { count: dots.ids.len(), dots: Some(dots), render_ms: 0.0, detect_ms: 0.0 })
            }
        }
    }

    /// The camera pose from kinematics and the hand-eye estimate.
    fn world_from_cam_fk(&self, q: &Joints) -> Isometry3<f64> {
        self.world_from_base_est * base_from_tool(q) * self.tool_from_cam_est
    }

    /// d(pixels)/d(q) for the chosen interaction matrix.
    fn image_jacobian(&self, q: &Joints, ids: &[usize]) -> DMatrix<f64> {
        let cam = &self.scene.camera;
        let at = |cam_from_world: Isometry3<f64>| {
            let pc: Vec<Point3<f64>> = ids.iter().map(|i| cam_from_world * self.pts[*i]).collect();
            interaction_matrix(cam, &pc)
        };
        let l_cam = match self.options.ibvs.interaction {
            InteractionFrom::Current => at(self.world_from_cam_fk(q).inverse()),
            InteractionFrom::Desired => at(self.goal.inverse()),
            InteractionFrom::Mean => (at(self.world_from_cam_fk(q).inverse()) + at(self.goal.inverse())) * 0.5,
        };
        joint_image_jacobian(&l_cam, &cam_twist_jacobian(q, &self.tool_from_cam_est))
    }
}

/// Run the loop. `frame` receives every rendered frame (step, image).
///
/// # Errors
/// A bad scenario, a failed hand-eye experiment or a renderer failure; servoing outcomes
/// (converged, stalled, singular, target never visible...) are in the trace's status.
pub fn run_servo(
    renderer: Option<&Renderer>,
    scenario: &ServoScenario,
    options: &ServoOptions,
    frame: &mut dyn FnMut(usize, &GreyImage),
) -> Result<ServoTrace, ServoRunError> {
    let goal = scenario.goal()?;
    if options.max_steps == 0 || options.stall_window == 0 || !options.ideal_noise_px.is_finite() || options.ideal_noise_px < 0.0 {
        return Err(ServoRunError::Scenario("max_steps and stall_window must be positive and the ideal noise finite and >= 0".into()));
    }
    let (tool_from_cam, world_from_base) = scenario.handeye.truth();
    let t_he = Instant::now();
    let (tool_from_cam_est, world_from_base_est) = match options.handeye {
        HandEyeSource::Truth => (tool_from_cam, world_from_base),
        HandEyeSource::Estimated { views } => {
            let he = run_handeye(renderer, options.observation, &scenario.handeye, views, options.seed)?;
            (he.refined.tool_from_cam, he.refined.world_from_base)
        }
    };
    let handeye_s = t_he.elapsed().as_secs_f64();
    let target = SPathDots::default();
    let setup = Setup {
        renderer,
        options,
        scene: Scene {
            camera: CameraModel::course_default(),
            target: Target::SPath(target.clone()),
            cam_from_target: goal.inverse(),
            render: RenderSettings { noise_sigma: 1.0, samples: 8, ..Default::default() },
        },
        pts: target.path.points_m.clone(),
        world_from_base_est,
        tool_from_cam_est,
        goal,
    };
    let cam = setup.scene.camera;
    let mut rng = ChaCha8Rng::seed_from_u64(options.seed ^ 0x5e70_5e70);
    let mut trace = ServoTrace {
        law: options.law,
        observation: if options.observation == Observation::Rendered { "rendered" } else { "ideal" },
        status: ServoStatus::MaxSteps,
        updates: 0,
        handeye_error: [PoseError::between(&tool_from_cam_est, &tool_from_cam), PoseError::between(&world_from_base_est, &world_from_base)],
        desired_px: vec![None; setup.pts.len()],
        goal_position_m: goal.translation.vector.into(),
        q_start_rad: scenario.q_start_rad,
        steps: Vec::new(),
        handeye_s,
        loop_s: 0.0,
    };
    // Desired features: taught by showing (rendered) or projected (ideal, the course).
    if !cam.sees_all(&goal.inverse(), &setup.pts, 0.0) {
        trace.status = ServoStatus::GoalNotVisible { reason: "some path points project outside the image or behind the camera".into() };
        return Ok(trace);
    }
    match options.observation {
        Observation::Ideal => {
            for (i, p) in setup.pts.iter().enumerate() {
                let u = cam.project_unchecked(&(goal.inverse() * p));
                trace.desired_px[i] = Some([u.x, u.y]);
            }
        }
        Observation::Rendered => {
            let seen = setup.observe(&goal.inverse(), &mut rng, &mut |_, _| {}, 0)?;
            let Some(d) = seen.dots.filter(|d| d.ids.len() == setup.pts.len()) else {
                trace.status = ServoStatus::GoalNotVisible { reason: format!("{} of {} dots detected at the desired pose", seen.count, setup.pts.len()) };
                return Ok(trace);
            };
            for (i, p) in d.ids.iter().zip(&d.pixels_px) {
                trace.desired_px[*i] = Some([p.x, p.y]);
            }
        }
    }
    // Start: the course perturbs q multiplicatively until the whole S is in view.
    let mut q = Joints::from_row_slice(&scenario.q_start_rad).map(wrap);
    let unit = Normal::new(0.0, 1.0).map_err(|e| ServoRunError::Scenario(e.to_string()))?;
    let tries = 1000;
    let mut tried = 0;
    while !cam.sees_all(&(world_from_base * base_from_tool(&q) * tool_from_cam).inverse(), &setup.pts, 0.0) {
        if tried == tries {
            trace.status = ServoStatus::TargetNeverVisible { tries };
            return Ok(trace);
        }
        tried += 1;
        q = Joints::from_iterator(scenario.q_start_rad.iter().map(|v| wrap(v * (1.0 + 0.01 * unit.sample(&mut rng)))));
    }
    trace.q_start_rad = [q[0], q[1], q[2], q[3], q[4], q[5]];
    let goal_tool_est = world_from_base_est.inverse() * goal * tool_from_cam_est.inverse();
    let mut bias_cache = None;
    // Ideal features carry N(0, sigma^2) per coordinate: their RMS distance to noise-free desired
    // features cannot fall below sigma sqrt(2); the IBVS stop is raised to 2 sigma there.
    let pixel_floor = if options.observation == Observation::Ideal { 2.0 * options.ideal_noise_px } else { 0.0 };
    let t_loop = Instant::now();
    for step in 0..=options.max_steps {
        let world_from_cam = world_from_base * base_from_tool(&q) * tool_from_cam;
        let m = setup.observe(&world_from_cam.inverse(), &mut rng, frame, step)?;
        let t_law = Instant::now();
        let usable = m.dots.filter(|d| d.ids.len() >= options.min_dots);
        let source = match (&usable, options.observation) {
            (None, _) => Source::Fallback,
            (Some(_), Observation::Ideal) => Source::Ideal,
            (Some(_), Observation::Rendered) => Source::Detected,
        };
        // The controller's pose estimate: PnP on the dots (PBVS), else kinematics + hand-eye.
        let fk_est = setup.world_from_cam_fk(&q);
        let mut world_from_cam_est = fk_est;
        if let (Law::Pbvs, Some(d)) = (options.law, &usable) {
            let est = match options.observation {
                Observation::Rendered => pose_from_dots_cached(&setup.scene, d, &mut bias_cache),
                Observation::Ideal => pose_from_dots(&setup.scene, d, 0).map(|r| r.0),
            };
            if let Ok(est) = est {
                world_from_cam_est = est.cam_from_target.inverse();
            }
        }
        // Features: detected, or predicted from the estimate when the target is lost.
        let (ids, measured): (Vec<usize>, Vec<Point2<f64>>) = match &usable {
            Some(d) => d.ids.iter().zip(&d.pixels_px).filter(|(i, _)| trace.desired_px[**i].is_some()).map(|(i, p)| (*i, *p)).unzip(),
            None => (0..setup.pts.len()).map(|i| (i, cam.project_unchecked(&(fk_est.inverse() * setup.pts[i])))).unzip(),
        };
        let desired: Vec<Point2<f64>> = ids.iter().filter_map(|i| trace.desired_px[*i].map(|d| Point2::new(d[0], d[1]))).collect();
        let dist: Vec<f64> = measured.iter().zip(&desired).map(|(a, b)| (a - b).norm()).collect();
        let pixel_rms_px = (dist.iter().map(|d| d * d).sum::<f64>() / dist.len().max(1) as f64).sqrt();
        let pixel_max_px = dist.iter().copied().fold(0.0, f64::max);
        let l = setup.image_jacobian(&q, &ids);
        let sigma_min_image = l.clone().singular_values().min();
        let sigma_min_robot = jacobian(&q).singular_values().min();
        let est = PoseError::between(&world_from_cam_est, &goal);
        let truth = PoseError::between(&world_from_cam, &goal);
        let mut rec = StepRecord {
            step,
            q_rad: [q[0], q[1], q[2], q[3], q[4], q[5]],
            cam_position_m: world_from_cam.translation.vector.into(),
            pose_error_mm: truth.mm,
            pose_error_deg: truth.deg,
            est_error_mm: est.mm,
            est_error_deg: est.deg,
            pixel_rms_px,
            pixel_max_px,
            sigma_min_robot,
            sigma_min_image,
            dots: m.count,
            within_limits: check_limits(&q).is_ok(),
            source,
            gain: 0.0,
            render_ms: m.render_ms,
            detect_ms: m.detect_ms,
            law_ms: 0.0,
            features_px: ids.iter().zip(&measured).map(|(i, p)| [*i as f64, p.x, p.y]).collect(),
        };
        // The controller's error, for the stop and stall tests.
        let stall_ref = options.stop.unwrap_or_default();
        let (error, threshold) = match options.law {
            Law::Pbvs => (est.mm, stall_ref.translation_mm),
            Law::Ibvs => (pixel_rms_px, stall_ref.pixel_rms_px),
        };
        let converged = options.stop.is_some_and(|s| match options.law {
            Law::Pbvs => est.mm < s.translation_mm && est.deg < s.rotation_deg && source != Source::Fallback,
            Law::Ibvs => pixel_rms_px < s.pixel_rms_px.max(pixel_floor) && source != Source::Fallback,
        });
        let stalled = step >= options.stall_window && {
            let old = &trace.steps[step - options.stall_window];
            let old_error = if options.law == Law::Pbvs { old.est_error_mm } else { old.pixel_rms_px };
            error > 0.99 * old_error && error > 10.0 * threshold
        };
        let status = if converged {
            Some(ServoStatus::Converged)
        } else if sigma_min_robot < options.singular_stop {
            Some(ServoStatus::Singular { sigma_min: sigma_min_robot })
        } else if stalled {
            Some(ServoStatus::Stalled)
        } else if step == options.max_steps {
            Some(ServoStatus::MaxSteps)
        } else {
            None
        };
        if let Some(s) = status {
            rec.law_ms = t_law.elapsed().as_secs_f64() * 1e3;
            trace.steps.push(rec);
            trace.status = s;
            break;
        }
        let next = match options.law {
            Law::Pbvs => {
                let tool_est = world_from_base_est.inverse() * world_from_cam_est * tool_from_cam_est.inverse();
                pbvs_step(&q, &pbvs_error(&tool_est, &goal_tool_est), &options.pbvs).map(|n| (n, options.pbvs.gain))
            }
            Law::Ibvs => ibvs_step(&q, &l, &measured, &desired, &options.ibvs),
        };
        rec.law_ms = t_law.elapsed().as_secs_f64() * 1e3;
        let Some((next, gain)) = next.filter(|(n, _)| n.iter().all(|v| v.is_finite())) else {
            trace.steps.push(rec);
            trace.status = ServoStatus::Diverged;
            break;
        };
        rec.gain = gain;
        trace.steps.push(rec);
        trace.updates += 1;
        q = next;
    }
    trace.loop_s = t_loop.elapsed().as_secs_f64();
    Ok(trace)
}
