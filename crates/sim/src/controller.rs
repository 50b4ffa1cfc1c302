//! Controllers in the loop: the [`Controller`] trait (what a user implements), synthcam's
//! eye-in-hand PBVS and IBVS for any arm ([`Pbvs`], [`Ibvs`]), and [`run_loop`], which closes the
//! loop over a [`Sim`] the same way for both.
//!
//! The laws are those of [`synthcam_geometry::servo`] (Chaumette & Hutchinson 2006), on the arm's Jacobian
//! from [`Robot::jacobian`]; a law's joint increment divided by the control period is the
//! commanded joint velocity.

use nalgebra::{DVector, Isometry3, Point2, Point3};

use super::observe::{pose_from_dots, pose_from_dots_cached, BiasCache, BiasRefresh, Dots};
use super::sensor::Feature;
use super::world::{Observation, Sim};
use super::SimError;
use synthcam_core::camera::CameraModel;
use synthcam_core::robot::Robot;
use synthcam_core::target::Target;
use synthcam_geometry::pnp::{pnp_general, pnp_planar, PnpResult};
use synthcam_geometry::servo::{
    cam_twist_jacobian_of, ibvs_increment, interaction_matrix, joint_image_jacobian, pbvs_error, pbvs_increment, IbvsParams, InteractionFrom, PbvsParams,
};
use synthcam_scene::{RenderSettings, Scene};

/// What a controller asks for after an observation.
#[derive(Debug, Clone, PartialEq)]
pub enum Command {
    /// Joint velocities for the next period.
    Velocities(Vec<f64>),
    /// The goal is reached: stop.
    Stop,
}

/// A controller: from an observation (and the arm's model, for its Jacobian) to a command.
pub trait Controller {
    /// The command for the period `dt_s` that follows `obs`.
    ///
    /// # Errors
    /// Whatever stops the controller (no features, a singular law...).
    fn command(&mut self, robot: &dyn Robot, obs: &Observation, dt_s: f64) -> Result<Command, SimError>;
}

/// What the eye-in-hand laws know of the cell: the camera model, the target's geometry and the
/// hand-eye estimate `tool_from_cam`.
#[derive(Debug, Clone, PartialEq)]
pub struct EyeInHand {
    /// The (calibrated) camera.
    pub camera: CameraModel,
    /// The target.
    pub target: Target,
    /// Hand-eye estimate.
    pub tool_from_cam: Isometry3<f64>,
}

impl EyeInHand {
    /// `cam_from_target` from the observed features (planar or general PnP).
    ///
    /// # Errors
    /// Too few or degenerate features.
    pub fn pose(&self, features: &[Feature]) -> Result<PnpResult, SimError> {
        self.solve(features, 1).map(|r| r.0)
    }

    /// `cam_from_target` from an observation: as [`EyeInHand::pose`] for a rendered one; an ideal
    /// one (no image: projected centres plus noise) needs no centroid correction.
    ///
    /// # Errors
    /// Too few or degenerate features.
    pub fn pose_from(&self, obs: &Observation) -> Result<PnpResult, SimError> {
        self.solve(&obs.features, usize::from(obs.image.is_some())).map(|r| r.0)
    }

    /// [`EyeInHand::pose_from`], refined further, and per feature the pixel it used: the
    /// detected one, or for the S-path's beads in a rendered image the detected one corrected for
    /// the blob-centroid bias (perspective and occlusion move a bead's blob off its projected
    /// centre; two rounds of the correction of [`super::observe::pose_from_dots`], for views
    /// where accuracy matters more than time, such as hand-eye views).
    ///
    /// # Errors
    /// Too few or degenerate features.
    pub fn pose_and_pixels(&self, obs: &Observation) -> Result<(PnpResult, Vec<Point2<f64>>), SimError> {
        self.solve(&obs.features, 2 * usize::from(obs.image.is_some()))
    }

    /// [`EyeInHand::pose_from`] with the S-path's centroid correction cached across calls and
    /// recomputed only when the pose moved further than `refresh` allows
    /// ([`super::observe::pose_from_dots_cached`]): for loops, where most steps barely move.
    ///
    /// # Errors
    /// Too few or degenerate features.
    pub fn pose_from_cached(&self, obs: &Observation, cache: &mut BiasCache, refresh: &BiasRefresh) -> Result<PnpResult, SimError> {
        match (&self.target, obs.image.is_some()) {
            (Target::SPath(_), true) => {
                let (dots, scene) = self.dots_and_scene(&obs.features);
                pose_from_dots_cached(&scene, &dots, cache, refresh).map_err(|e| SimError::Control(format!("PnP on {} dots: {e}", dots.ids.len())))
            }
            _ => self.pose_from(obs),
        }
    }

    /// The S-path features as detected dots, and a scene of this cell (pose unused).
    fn dots_and_scene(&self, features: &[Feature]) -> (Dots, Scene) {
        let n = self.target.feature_points_m().len();
        let used = features.iter().filter(|f| f.id < n);
        let dots = Dots { ids: used.clone().map(|f| f.id).collect(), pixels_px: used.map(|f| f.pixel_px).collect() };
        (
            dots,
            Scene {
                camera: self.camera,
                target: self.target.clone(),
                cam_from_target: Isometry3::identity(),
                render: RenderSettings::default(),
                objects: Vec::new(),
                background: None,
            },
        )
    }

    /// PnP with `rounds` rounds of the S-path's centroid correction (0: plain PnP).
    fn solve(&self, features: &[Feature], rounds: usize) -> Result<(PnpResult, Vec<Point2<f64>>), SimError> {
        let model = self.target.feature_points_m();
        let used: Vec<&Feature> = features.iter().filter(|f| f.id < model.len()).collect();
        let fail = |e: synthcam_geometry::pnp::PnpError| SimError::Control(format!("PnP on {} features: {e}", used.len()));
        if let (Target::SPath(_), 1..) = (&self.target, rounds) {
            let (dots, scene) = self.dots_and_scene(features);
            return pose_from_dots(&scene, &dots, rounds).map_err(fail);
        }
        let (pts, px): (Vec<Point3<f64>>, Vec<Point2<f64>>) = used.iter().map(|f| (model[f.id], f.pixel_px)).unzip();
        let r = if self.target.is_planar() { pnp_planar(&self.camera, &pts, &px) } else { pnp_general(&self.camera, &pts, &px) };
        r.map(|r| (r, px)).map_err(fail)
    }
}

/// Eye-in-hand PBVS: the tool pose error in the base frame, from PnP and the encoders.
#[derive(Debug, Clone, PartialEq)]
pub struct Pbvs {
    /// Camera, target, hand-eye estimate.
    pub cell: EyeInHand,
    /// The desired `cam_from_target`.
    pub goal_cam_from_target: Isometry3<f64>,
    /// The law.
    pub params: PbvsParams,
    /// Stop when the estimated error is below (millimetres, degrees).
    pub stop_mm_deg: (f64, f64),
    /// The last `base_from_target` from PnP (kept by the controller for the steps where the
    /// target is lost; start with `None`).
    pub base_from_target: Option<Isometry3<f64>>,
    /// An S-path's bead-centroid bias, cached across steps ([`EyeInHand::pose_from_cached`];
    /// start with `BiasCache::default()`).
    pub bias: BiasCache,
}

impl Controller for Pbvs {
    fn command(&mut self, robot: &dyn Robot, obs: &Observation, dt_s: f64) -> Result<Command, SimError> {
        let base_from_tool = robot.base_from_tool(&obs.q_rad)?;
        let x = self.cell.tool_from_cam;
        // Where the target is in the base frame: from PnP, or, while the target is lost, the
        // last such estimate moved by the encoders (kinematics and the hand-eye estimate, the
        // course's fallback).
        let refresh = BiasRefresh::towards(self.goal_cam_from_target);
        let seen = self.cell.pose_from_cached(obs, &mut self.bias, &refresh).map(|p| base_from_tool * x * p.cam_from_target);
        let lost = seen.is_err();
        let base_from_target = match (seen, self.base_from_target) {
            (Ok(b), _) => {
                self.base_from_target = Some(b);
                b
            }
            (Err(_), Some(b)) => b,
            (Err(e), None) => return Err(e),
        };
        let goal = base_from_target * self.goal_cam_from_target.inverse() * x.inverse();
        let e = pbvs_error(&base_from_tool, &goal);
        let PoseError { mm, deg } = PoseError::between(&base_from_tool, &goal);
        if !lost && mm < self.stop_mm_deg.0 && deg < self.stop_mm_deg.1 {
            return Ok(Command::Stop);
        }
        let dq = pbvs_increment(&robot.jacobian(&obs.q_rad)?, &e, &self.params).ok_or_else(|| SimError::Control("PBVS: J J^T + D is singular".into()))?;
        Ok(Command::Velocities(dq.iter().map(|v| v / dt_s).collect()))
    }
}

/// Eye-in-hand IBVS on the target's features against desired pixels (taught by showing).
#[derive(Debug, Clone, PartialEq)]
pub struct Ibvs {
    /// Camera, target, hand-eye estimate.
    pub cell: EyeInHand,
    /// Desired pixel of every feature id (`None`: not used).
    pub desired_px: Vec<Option<Point2<f64>>>,
    /// The desired `cam_from_target` (for the depths of the desired interaction matrix).
    pub goal_cam_from_target: Isometry3<f64>,
    /// The law.
    pub params: IbvsParams,
    /// Stop when the RMS pixel error is below this.
    pub stop_px: f64,
    /// An S-path's bead-centroid bias for the current pose's interaction matrix, cached across
    /// steps ([`EyeInHand::pose_from_cached`]; start with `BiasCache::default()`).
    pub bias: BiasCache,
}

impl Ibvs {
    /// The desired features from an observation at the goal (teaching by showing).
    pub fn desired_from(obs: &Observation, count: usize) -> Vec<Option<Point2<f64>>> {
        let mut d = vec![None; count];
        for f in obs.features.iter().filter(|f| f.id < count) {
            d[f.id] = Some(f.pixel_px);
        }
        d
    }
}

/// RMS distance of matched features to their desired pixels.
pub fn pixel_rms(features: &[Feature], desired: &[Option<Point2<f64>>]) -> Option<f64> {
    let d: Vec<f64> = features.iter().filter_map(|f| desired.get(f.id).copied().flatten().map(|p| (p - f.pixel_px).norm_squared())).collect();
    (!d.is_empty()).then(|| (d.iter().sum::<f64>() / d.len() as f64).sqrt())
}

impl Controller for Ibvs {
    fn command(&mut self, robot: &dyn Robot, obs: &Observation, dt_s: f64) -> Result<Command, SimError> {
        let matched: Vec<(usize, Point2<f64>, Point2<f64>)> =
            obs.features.iter().filter_map(|f| self.desired_px.get(f.id).copied().flatten().map(|d| (f.id, f.pixel_px, d))).collect();
        let ids: Vec<usize> = matched.iter().map(|m| m.0).collect();
        let measured: Vec<Point2<f64>> = matched.iter().map(|m| m.1).collect();
        let desired: Vec<Point2<f64>> = matched.iter().map(|m| m.2).collect();
        if ids.len() < 4 {
            return Err(SimError::Control(format!("IBVS: {} matched features (need 4)", ids.len())));
        }
        let rms = pixel_rms(&obs.features, &self.desired_px).unwrap_or(f64::INFINITY);
        if rms < self.stop_px {
            return Ok(Command::Stop);
        }
        let model = self.cell.target.feature_points_m();
        let at = |cam_from_target: &Isometry3<f64>| {
            let pc: Vec<Point3<f64>> = ids.iter().map(|i| cam_from_target * model[*i]).collect();
            interaction_matrix(&self.cell.camera, &pc)
        };
        let refresh = BiasRefresh::towards(self.goal_cam_from_target);
        let mut current = || self.cell.pose_from_cached(obs, &mut self.bias, &refresh).map(|r| r.cam_from_target);
        let l_cam = match self.params.interaction {
            InteractionFrom::Current => at(&current()?),
            InteractionFrom::Desired => at(&self.goal_cam_from_target),
            InteractionFrom::Mean => (at(&current()?) + at(&self.goal_cam_from_target)) * 0.5,
        };
        let j = robot.jacobian(&obs.q_rad)?;
        let twist = cam_twist_jacobian_of(&robot.base_from_tool(&obs.q_rad)?, &j, &self.cell.tool_from_cam);
        let l = joint_image_jacobian(&l_cam, &twist);
        let smin = j.clone().singular_values().min();
        let (dq, _) = ibvs_increment(smin, &l, &measured, &desired, &self.params).ok_or_else(|| SimError::Control("IBVS: singular system".into()))?;
        Ok(Command::Velocities(dq.iter().map(|v| v / dt_s).collect()))
    }
}

/// One step of [`run_loop`].
#[derive(Debug, Clone, PartialEq, serde::Serialize)]
pub struct LoopStep {
    /// Frame.
    pub frame: u64,
    /// Joints, radians.
    pub q_rad: Vec<f64>,
    /// Features detected.
    pub features: usize,
    /// True camera pose vs the goal: millimetres and degrees.
    pub goal_error_mm_deg: (f64, f64),
    /// The command's joint velocities (empty on stop).
    pub qdot: Vec<f64>,
    /// The features observed (ids resolved), for recordings (`synthcam sim --rerun`); not in the
    /// JSON.
    #[serde(skip)]
    pub observed: Vec<Feature>,
    /// Render + readback and detection, milliseconds; not in the JSON.
    #[serde(skip)]
    pub render_detect_ms: (f64, f64),
}

/// A closed-loop run.
#[derive(Debug, Clone, PartialEq, serde::Serialize)]
pub struct LoopTrace {
    /// Every step.
    pub steps: Vec<LoopStep>,
    /// Whether the controller stopped (goal reached) before `max_steps`.
    pub stopped: bool,
}

/// Close the loop: observe, command, move, `max_steps` times or until the controller stops.
/// `goal_cam_from_target` is only used to report the true error per step.
///
/// # Errors
/// A sensor, controller or command error (the trace so far is lost; run step by step with
/// [`Sim`] to keep it).
pub fn run_loop(
    sim: &mut Sim<'_>,
    controller: &mut dyn Controller,
    goal_cam_from_target: &Isometry3<f64>,
    dt_s: f64,
    max_steps: usize,
) -> Result<LoopTrace, SimError> {
    let mut trace = LoopTrace { steps: Vec::new(), stopped: false };
    for _ in 0..max_steps {
        let obs = sim.observe()?;
        let cmd = controller.command(sim.robot(), &obs, dt_s)?;
        let t = obs.truth.cam_from_target * goal_cam_from_target.inverse();
        let err = (1e3 * t.translation.vector.norm(), t.rotation.angle().to_degrees());
        let qdot = match &cmd {
            Command::Velocities(v) => v.clone(),
            Command::Stop => Vec::new(),
        };
        trace.steps.push(LoopStep {
            frame: obs.frame,
            q_rad: obs.q_rad.clone(),
            features: obs.features.len(),
            goal_error_mm_deg: err,
            qdot: qdot.clone(),
            observed: obs.features.clone(),
            render_detect_ms: (obs.render_ms, obs.detect_ms),
        });
        if cmd == Command::Stop {
            trace.stopped = true;
            break;
        }
        sim.command_joint_velocities(&qdot, dt_s)?;
    }
    Ok(trace)
}

/// A joint vector as nalgebra's dynamic vector (for user laws written with nalgebra).
pub fn dvector(q: &[f64]) -> DVector<f64> {
    DVector::from_column_slice(q)
}

/// The control law.
#[derive(Debug, Clone, Copy, PartialEq, Eq, serde::Serialize)]
#[serde(rename_all = "lowercase")]
pub enum Law {
    /// Position-based: PnP pose, tool-pose error.
    Pbvs,
    /// Image-based: pixel error through the image Jacobian.
    Ibvs,
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
