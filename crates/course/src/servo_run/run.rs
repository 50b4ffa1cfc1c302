//! The loop of [`run_servo_in`]: hand-eye estimate, desired features, start search, then per step
//! observe, estimate, record, decide, update.

use std::time::Instant;

use nalgebra::{DMatrix, Isometry3, Matrix6xX, Point2, Point3};
use rand::SeedableRng;
use rand_chacha::ChaCha8Rng;
use rand_distr::{Distribution, Normal};

use super::trace::{ServoStatus, ServoTrace, Source, StepRecord};
use super::{HandEyeSource, ServoOptions, ServoRunError};
use crate::controller::{EyeInHand, Law, PoseError};
use crate::handeye_views::estimate_hand_eye;
use crate::observe::{BiasCache, BiasRefresh};
use crate::sensor::ObservationKind;
use crate::{Sim, SimError};
use synthcam_geometry::servo::{cam_twist_jacobian_of, ibvs_increment, interaction_matrix, joint_image_jacobian, pbvs_error, pbvs_increment, InteractionFrom};
use synthcam_render::GreyImage;

/// What the controller knows during a run (the hand-eye estimate, the goal, the desired
/// features) and the scenario's geometry.
struct Plan {
    cell: EyeInHand,
    target_from_base: Isometry3<f64>,
    goal: Isometry3<f64>,
    pts: Vec<Point3<f64>>,
    desired: Desired,
}

impl Plan {
    /// `cam_from_target` from the encoders and the hand-eye estimate.
    fn fk(&self, base_from_tool: &Isometry3<f64>) -> Isometry3<f64> {
        (self.target_from_base * base_from_tool * self.cell.tool_from_cam).inverse()
    }

    /// The interaction matrix at `cam_from_target` for the features `ids`.
    fn interaction_at(&self, cam_from_target: &Isometry3<f64>, ids: &[usize]) -> DMatrix<f64> {
        let pc: Vec<Point3<f64>> = ids.iter().map(|i| cam_from_target * self.pts[*i]).collect();
        interaction_matrix(&self.cell.camera, &pc)
    }
}

/// The desired pixel of every feature id (`None`: not used).
type Desired = Vec<Option<Point2<f64>>>;

/// One step's measurement and what the law needs of it.
struct Step {
    rec: StepRecord,
    est_cam_from_target: Isometry3<f64>,
    j_robot: Matrix6xX<f64>,
    l: DMatrix<f64>,
    measured: Vec<Point2<f64>>,
    desired: Vec<Point2<f64>>,
}

/// Run the loop on `sim` (any camera, target and robot): estimate the hand-eye transforms from
/// views around the sim's current joints (or take the truth), teach the desired features at the
/// scenario's goal, move to the scenario's start and perturb it until the whole target is in
/// view (as the course does), then servo.
/// `frame` receives every rendered frame (step, image).
///
/// # Errors
/// Bad options, a failed hand-eye estimate, a sensor failure; servoing outcomes are the trace's
/// status.
pub fn run_servo_in(sim: &mut Sim<'_>, options: &ServoOptions, frame: &mut dyn FnMut(usize, &GreyImage)) -> Result<ServoTrace, ServoRunError> {
    if options.max_steps == 0 || options.stall_window == 0 || !options.ideal_noise_px.is_finite() || options.ideal_noise_px < 0.0 {
        return Err(ServoRunError::Scenario("max_steps and stall_window must be positive and the ideal noise finite and >= 0".into()));
    }
    let t_he = Instant::now();
    let (cell, target_from_base) = hand_eye(sim, options)?;
    let sc = sim.scenario().clone();
    let truth_target_from_base = sc.world_from_target.inverse() * sc.world_from_base;
    let mut trace = ServoTrace {
        law: options.law,
        observation: if options.observation == ObservationKind::Rendered { "rendered" } else { "ideal" },
        status: ServoStatus::MaxSteps,
        updates: 0,
        handeye_error: [PoseError::between(&cell.tool_from_cam, &sc.tool_from_cam), PoseError::between(&target_from_base, &truth_target_from_base)],
        desired_px: Vec::new(),
        goal_position_m: (sc.world_from_target * sc.goal_cam_from_target.inverse()).translation.vector.into(),
        q_start_rad: sc.q_start_rad.clone(),
        steps: Vec::new(),
        handeye_s: t_he.elapsed().as_secs_f64(),
        loop_s: 0.0,
    };
    let mut plan = Plan { cell, target_from_base, goal: sc.goal_cam_from_target, pts: sc.target.feature_points_m(), desired: Vec::new() };
    match teach(sim, &plan, options)? {
        Ok(desired) => plan.desired = desired,
        Err(status) => return Ok(ServoTrace { status, ..trace }),
    }
    trace.desired_px = plan.desired.iter().map(|d| d.map(|p| [p.x, p.y])).collect();
    sim.set_joints(&sc.q_start_rad)?;
    if let Some(status) = find_start(sim, &plan.pts, options.seed)? {
        return Ok(ServoTrace { status, ..trace });
    }
    trace.q_start_rad = sim.joints().to_vec();
    servo(sim, &plan, options, frame, &mut trace)?;
    Ok(trace)
}

/// The hand-eye estimate the loop uses: `(cell with tool_from_cam, target_from_base)`.
fn hand_eye(sim: &mut Sim<'_>, options: &ServoOptions) -> Result<(EyeInHand, Isometry3<f64>), ServoRunError> {
    let sc = sim.scenario().clone();
    let truth = EyeInHand { camera: sc.camera, target: sc.target.clone(), tool_from_cam: sc.tool_from_cam };
    match options.handeye {
        HandEyeSource::Truth => Ok((truth, sc.world_from_target.inverse() * sc.world_from_base)),
        HandEyeSource::Estimated { views } => {
            let he = estimate_hand_eye(sim, &truth, views, options.handeye_spread_rad, 20.0, options.seed)?;
            Ok((EyeInHand { tool_from_cam: he.tool_from_cam, ..truth }, he.target_from_base))
        }
    }
}

/// The desired features, taught by showing (rendered) or projected without noise (ideal, the
/// course), or the status when the goal does not show the whole target.
fn teach(sim: &mut Sim<'_>, plan: &Plan, options: &ServoOptions) -> Result<Result<Desired, ServoStatus>, ServoRunError> {
    if !plan.cell.camera.sees_all(&plan.goal, &plan.pts, 0.0) {
        return Ok(Err(ServoStatus::GoalNotVisible { reason: "some target points project outside the image or behind the camera".into() }));
    }
    let obs = sim.observe_from(plan.goal)?;
    if options.observation == ObservationKind::Ideal {
        return Ok(Ok(obs.truth.projected_px));
    }
    if obs.features.len() != plan.pts.len() {
        return Ok(Err(ServoStatus::GoalNotVisible { reason: format!("{} of {} features detected at the desired pose", obs.features.len(), plan.pts.len()) }));
    }
    let mut desired = vec![None; plan.pts.len()];
    for f in &obs.features {
        if let Some(d) = desired.get_mut(f.id) {
            *d = Some(f.pixel_px);
        }
    }
    Ok(Ok(desired))
}

/// The course's start: q perturbed multiplicatively (1 % Gaussian per joint) until the whole
/// target is in view; the sim is left there. `Some(status)` when 1000 tries fail.
fn find_start(sim: &mut Sim<'_>, pts: &[Point3<f64>], seed: u64) -> Result<Option<ServoStatus>, ServoRunError> {
    let q0 = sim.joints().to_vec();
    let camera = sim.scenario().camera;
    let mut rng = ChaCha8Rng::seed_from_u64(seed ^ 0x5e70_5e70);
    let unit = Normal::new(0.0, 1.0).map_err(|e| ServoRunError::Scenario(e.to_string()))?;
    let tries = 1000;
    let mut q = q0.clone();
    for _ in 0..tries {
        if camera.sees_all(&sim.cam_from_target_at(&q)?, pts, 0.0) && sim.admits(&q).is_ok() {
            sim.set_joints(&q)?;
            return Ok(None);
        }
        q = q0.iter().map(|v| v * (1.0 + 0.01 * unit.sample(&mut rng))).collect();
    }
    Ok(Some(ServoStatus::TargetNeverVisible { tries }))
}

/// The steps, until a status ends the run.
fn servo(
    sim: &mut Sim<'_>,
    plan: &Plan,
    options: &ServoOptions,
    frame: &mut dyn FnMut(usize, &GreyImage),
    trace: &mut ServoTrace,
) -> Result<(), ServoRunError> {
    // Ideal features carry N(0, sigma^2) per coordinate: their RMS distance to noise-free desired
    // features cannot fall below sigma sqrt(2); the IBVS stop is raised to 2 sigma there.
    let pixel_floor = if options.observation == ObservationKind::Ideal { 2.0 * options.ideal_noise_px } else { 0.0 };
    let t_loop = Instant::now();
    let mut bias = BiasCache::default();
    for step in 0..=options.max_steps {
        let mut s = measure(sim, plan, options, frame, step, &mut bias)?;
        let t_law = Instant::now();
        if let Some(status) = decide(&s.rec, &trace.steps, options, pixel_floor) {
            s.rec.law_ms += t_law.elapsed().as_secs_f64() * 1e3;
            trace.steps.push(s.rec);
            trace.status = status;
            break;
        }
        let next = increment(plan, &s, options).map(|(dq, gain)| (s.rec.q_rad.iter().zip(dq.iter()).map(|(q, d)| q + d).collect::<Vec<f64>>(), gain));
        s.rec.law_ms += t_law.elapsed().as_secs_f64() * 1e3;
        let Some((next, gain)) = next.filter(|(n, _)| n.iter().all(|v| v.is_finite())) else {
            trace.steps.push(s.rec);
            trace.status = ServoStatus::Diverged;
            break;
        };
        s.rec.gain = gain;
        trace.steps.push(s.rec);
        if let Err(e) = sim.set_joints(&next) {
            trace.status = ServoStatus::JointLimit { reason: e.to_string() };
            break;
        }
        trace.updates += 1;
    }
    trace.loop_s = t_loop.elapsed().as_secs_f64();
    Ok(())
}

/// Observe at the sim's joints and record the step: truth, the controller's estimate, features,
/// Jacobians.
fn measure(
    sim: &mut Sim<'_>,
    plan: &Plan,
    options: &ServoOptions,
    frame: &mut dyn FnMut(usize, &GreyImage),
    step: usize,
    bias: &mut BiasCache,
) -> Result<Step, ServoRunError> {
    let q = sim.joints().to_vec();
    let obs = sim.observe()?;
    if let Some(img) = &obs.image {
        frame(step, img);
    }
    let t_law = Instant::now();
    let usable = obs.features.len() >= options.min_dots;
    let source = match (usable, options.observation) {
        (false, _) => Source::Fallback,
        (true, ObservationKind::Ideal) => Source::Ideal,
        (true, ObservationKind::Rendered) => Source::Detected,
    };
    let base_from_tool = sim.robot().base_from_tool(&q).map_err(SimError::from)?;
    let fk = plan.fk(&base_from_tool);
    // The controller's pose estimate: PnP on the features (PBVS), else kinematics + hand-eye.
    let est_cam_from_target = match (options.law, usable) {
        (Law::Pbvs, true) => plan.cell.pose_from_cached(&obs, bias, &BiasRefresh::towards(plan.goal)).map_or(fk, |p| p.cam_from_target),
        _ => fk,
    };
    // Features: detected, or predicted from the estimate when the target is lost.
    let camera = &plan.cell.camera;
    let (ids, measured): (Vec<usize>, Vec<Point2<f64>>) = if usable {
        obs.features.iter().filter(|f| plan.desired.get(f.id).is_some_and(Option::is_some)).map(|f| (f.id, f.pixel_px)).unzip()
    } else {
        (0..plan.pts.len()).map(|i| (i, camera.project_unchecked(&(fk * plan.pts[i])))).unzip()
    };
    let desired: Vec<Point2<f64>> = ids.iter().filter_map(|i| plan.desired.get(*i).copied().flatten()).collect();
    let dist: Vec<f64> = measured.iter().zip(&desired).map(|(a, b)| (a - b).norm()).collect();
    let l_cam = match options.ibvs.interaction {
        InteractionFrom::Current => plan.interaction_at(&fk, &ids),
        InteractionFrom::Desired => plan.interaction_at(&plan.goal, &ids),
        InteractionFrom::Mean => (plan.interaction_at(&fk, &ids) + plan.interaction_at(&plan.goal, &ids)) * 0.5,
    };
    let j_robot = sim.robot().jacobian(&q).map_err(SimError::from)?;
    let l = joint_image_jacobian(&l_cam, &cam_twist_jacobian_of(&base_from_tool, &j_robot, &plan.cell.tool_from_cam));
    let est = PoseError::between(&est_cam_from_target.inverse(), &plan.goal.inverse());
    let truth = PoseError::between(&obs.truth.cam_from_target.inverse(), &plan.goal.inverse());
    let rec = StepRecord {
        step,
        q_rad: q.clone(),
        cam_position_m: obs.truth.world_from_cam.translation.vector.into(),
        pose_error_mm: truth.mm,
        pose_error_deg: truth.deg,
        est_error_mm: est.mm,
        est_error_deg: est.deg,
        pixel_rms_px: (dist.iter().map(|d| d * d).sum::<f64>() / dist.len().max(1) as f64).sqrt(),
        pixel_max_px: dist.iter().copied().fold(0.0, f64::max),
        sigma_min_robot: j_robot.clone().singular_values().min(),
        sigma_min_image: sigma_min(&l),
        dots: obs.features.len(),
        within_limits: sim.robot().check_limits(&q).is_ok(),
        source,
        gain: 0.0,
        render_ms: obs.render_ms,
        detect_ms: obs.detect_ms,
        law_ms: t_law.elapsed().as_secs_f64() * 1e3,
        features_px: ids.iter().zip(&measured).map(|(i, p)| [*i as f64, p.x, p.y]).collect(),
    };
    Ok(Step { rec, est_cam_from_target, j_robot, l, measured, desired })
}

/// Whether the run ends at this step: converged, singular, stalled or out of steps.
fn decide(rec: &StepRecord, previous: &[StepRecord], options: &ServoOptions, pixel_floor: f64) -> Option<ServoStatus> {
    let stall_ref = options.stop.unwrap_or_default();
    let (error, threshold) = match options.law {
        Law::Pbvs => (rec.est_error_mm, stall_ref.translation_mm),
        Law::Ibvs => (rec.pixel_rms_px, stall_ref.pixel_rms_px),
    };
    let converged = rec.source != Source::Fallback
        && options.stop.is_some_and(|s| match options.law {
            Law::Pbvs => rec.est_error_mm < s.translation_mm && rec.est_error_deg < s.rotation_deg,
            Law::Ibvs => rec.pixel_rms_px < s.pixel_rms_px.max(pixel_floor),
        });
    let stalled = rec.step >= options.stall_window
        && previous.get(rec.step - options.stall_window).is_some_and(|old| {
            let old_error = if options.law == Law::Pbvs { old.est_error_mm } else { old.pixel_rms_px };
            error > 0.99 * old_error && error > 10.0 * threshold
        });
    if converged {
        Some(ServoStatus::Converged)
    } else if rec.sigma_min_robot < options.singular_stop {
        Some(ServoStatus::Singular { sigma_min: rec.sigma_min_robot })
    } else if stalled {
        Some(ServoStatus::Stalled)
    } else if rec.step == options.max_steps {
        Some(ServoStatus::MaxSteps)
    } else {
        None
    }
}

/// The law's joint increment and gain.
fn increment(plan: &Plan, s: &Step, options: &ServoOptions) -> Option<(nalgebra::DVector<f64>, f64)> {
    match options.law {
        Law::Pbvs => {
            let x_inv = plan.cell.tool_from_cam.inverse();
            let base_from_target = plan.target_from_base.inverse();
            let tool_est = base_from_target * s.est_cam_from_target.inverse() * x_inv;
            let goal_tool = base_from_target * plan.goal.inverse() * x_inv;
            pbvs_increment(&s.j_robot, &pbvs_error(&tool_est, &goal_tool), &options.pbvs).map(|dq| (dq, options.pbvs.gain))
        }
        Law::Ibvs => ibvs_increment(s.rec.sigma_min_robot, &s.l, &s.measured, &s.desired, &options.ibvs),
    }
}

/// Smallest singular value of the image Jacobian; 0 when it has no rows (no detected feature
/// matches a desired one: nalgebra's SVD panics on an empty matrix).
fn sigma_min(l: &nalgebra::DMatrix<f64>) -> f64 {
    if l.is_empty() {
        0.0
    } else {
        l.clone().singular_values().min()
    }
}
