//! The step API: a robot carrying a camera in a cell with a target. A user's code observes
//! (image, detected features, truth), commands joint velocities, and repeats; synthcam's PBVS
//! and IBVS ([`super::controller`]) run through the same calls.
//!
//! Feature ids: the S-path's come from the detector; planar grids (chessboard, dot grid) are
//! symmetric, so the detector's order is the target's up to a rotation or mirror of the grid.
//! The simulator picks, among those few orderings, the one closest to the features predicted
//! from the joint encoders and the scenario's nominal cell layout: a discrete choice that a
//! layout error of centimetres or degrees does not change (a real cell resolves it the same way,
//! or with a coded board).

use nalgebra::{Isometry3, Point2};

use super::scenario::JointLimits;
use super::sensor::{Capture, Feature, Sensor};
use super::{SimError, SimScenario};
use synthcam_core::robot::Robot;
use synthcam_core::target::Target;
use synthcam_render::GreyImage;
use synthcam_scene::file::ObjectFrame;
use synthcam_scene::objects::SceneObject;
use synthcam_scene::{RenderSettings, Scene};

/// The truth of one frame.
#[derive(Debug, Clone, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct FrameTruth {
    /// The camera in the world.
    pub world_from_cam: Isometry3<f64>,
    /// The target in the camera.
    pub cam_from_target: Isometry3<f64>,
    /// Projection of every target feature (`None`: behind the camera or outside the image).
    pub projected_px: Vec<Option<Point2<f64>>>,
}

/// One observation.
#[derive(Debug, Clone)]
pub struct Observation {
    /// Frame counter (0 for the first observation).
    pub frame: u64,
    /// Simulated time, seconds.
    pub time_s: f64,
    /// Joint encoders at the frame.
    pub q_rad: Vec<f64>,
    /// The image (`None` for an ideal sensor).
    pub image: Option<GreyImage>,
    /// Detected features, ids into [`Target::feature_points_m`].
    pub features: Vec<Feature>,
    /// Why nothing was detected, when nothing was.
    pub note: Option<String>,
    /// Render + readback time, milliseconds.
    pub render_ms: f64,
    /// Detection time, milliseconds.
    pub detect_ms: f64,
    /// Truth.
    pub truth: FrameTruth,
}

/// The simulator.
pub struct Sim<'s> {
    scenario: SimScenario,
    robot: Box<dyn Robot>,
    sensor: Box<dyn Sensor + 's>,
    q: Vec<f64>,
    /// The joint velocities last applied (after saturation); zero after `set_joints`.
    qdot: Vec<f64>,
    time_s: f64,
    frame: u64,
}

impl std::fmt::Debug for Sim<'_> {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("Sim").field("robot", &self.robot.name()).field("q", &self.q).field("time_s", &self.time_s).field("frame", &self.frame).finish()
    }
}

impl<'s> Sim<'s> {
    /// A simulator at the scenario's start joints.
    ///
    /// # Errors
    /// Start joints of the wrong length or outside the robot's limits.
    pub fn new(scenario: SimScenario, robot: Box<dyn Robot>, sensor: Box<dyn Sensor + 's>) -> Result<Self, SimError> {
        let q = scenario.q_start_rad.clone();
        let qdot = vec![0.0; q.len()];
        let sim = Self { scenario, robot, sensor, q, qdot, time_s: 0.0, frame: 0 };
        sim.admits(&sim.q)?;
        Ok(sim)
    }

    /// Whether the arm can take joints `q`: the right length, finite, and within the limits
    /// unless the scenario ignores them.
    ///
    /// # Errors
    /// The first rule `q` breaks.
    pub fn admits(&self, q: &[f64]) -> Result<(), SimError> {
        match self.scenario.joint_limits {
            JointLimits::Enforce => self.robot.check_limits(q)?,
            JointLimits::Ignore => {
                if q.len() != self.robot.dof() || q.iter().any(|v| !v.is_finite()) {
                    return Err(SimError::Command(format!("need {} finite joints, got {q:?}", self.robot.dof())));
                }
            }
        }
        Ok(())
    }

    /// The robot.
    pub fn robot(&self) -> &dyn Robot {
        self.robot.as_ref()
    }

    /// The scenario.
    pub fn scenario(&self) -> &SimScenario {
        &self.scenario
    }

    /// Joint positions.
    pub fn joints(&self) -> &[f64] {
        &self.q
    }

    /// Simulated time, seconds.
    pub fn time_s(&self) -> f64 {
        self.time_s
    }

    /// Move the joints to `q` at once (to sample views, or restart).
    ///
    /// # Errors
    /// Wrong length, non-finite or out of limits.
    pub fn set_joints(&mut self, q: &[f64]) -> Result<(), SimError> {
        self.admits(q)?;
        self.q = q.to_vec();
        self.qdot = vec![0.0; q.len()];
        Ok(())
    }

    /// Start an episode again: the joints at `q`, time and frame counter at 0, and with `seed`
    /// the image noise (every frame's render seed and an ideal sensor's stream) drawn afresh
    /// from it, so two restarts with the same `q` and `seed` observe the same frames
    /// (Gymnasium's `reset(seed=)`).
    ///
    /// # Errors
    /// Wrong length, non-finite or out of limits (nothing changes then).
    pub fn restart(&mut self, q: &[f64], seed: Option<u64>) -> Result<(), SimError> {
        self.set_joints(q)?;
        self.time_s = 0.0;
        self.frame = 0;
        if let Some(seed) = seed {
            self.scenario.render.seed = seed;
            self.sensor.reseed(seed);
        }
        Ok(())
    }

    /// The camera's body twist `[wx, wy, wz, vx, vy, vz]` (its own frame, rad/s and m/s) while
    /// the joints move at the last applied velocities: `cam(q)_from_cam(q + qdot h) / h` for
    /// h = 1 us (the twist's first-order error is ~1e-6 relative).
    ///
    /// # Errors
    /// A joint vector of the wrong length.
    pub fn camera_twist(&self) -> Result<[f64; 6], SimError> {
        let h = 1e-6;
        let ahead: Vec<f64> = self.q.iter().zip(&self.qdot).map(|(q, v)| q + v * h).collect();
        let step = self.world_from_cam_at(&self.q)?.inverse() * self.world_from_cam_at(&ahead)?;
        let w = synthcam_core::math::so3::rvec_from_rotation(&step.rotation.to_rotation_matrix()) / h;
        let v = step.translation.vector / h;
        Ok([w.x, w.y, w.z, v.x, v.y, v.z])
    }

    /// The true camera pose in the world at joints `q`.
    ///
    /// # Errors
    /// A joint vector of the wrong length.
    pub fn world_from_cam_at(&self, q: &[f64]) -> Result<Isometry3<f64>, SimError> {
        Ok(self.scenario.world_from_base * self.robot.base_from_tool(q)? * self.scenario.tool_from_cam)
    }

    /// The true `cam_from_target` at joints `q`.
    ///
    /// # Errors
    /// A joint vector of the wrong length.
    pub fn cam_from_target_at(&self, q: &[f64]) -> Result<Isometry3<f64>, SimError> {
        Ok(self.world_from_cam_at(q)?.inverse() * self.scenario.world_from_target)
    }

    /// Apply joint velocities `qdot` for `dt_s` seconds: `q += qdot dt`. A command above a
    /// joint's velocity limit is scaled down as a whole (direction kept), as a robot controller
    /// saturates; the result must stay within the position limits.
    ///
    /// # Errors
    /// Wrong length, a non-finite value, `dt_s` not positive, or a position limit crossed (the
    /// joints are then left unchanged).
    pub fn command_joint_velocities(&mut self, qdot: &[f64], dt_s: f64) -> Result<(), SimError> {
        if !(dt_s > 0.0) || !dt_s.is_finite() {
            return Err(SimError::Command(format!("dt_s must be positive and finite, got {dt_s}")));
        }
        if qdot.len() != self.q.len() || qdot.iter().any(|v| !v.is_finite()) {
            return Err(SimError::Command(format!("need {} finite joint velocities, got {qdot:?}", self.q.len())));
        }
        let scale = qdot.iter().zip(self.robot.velocity_limits()).map(|(v, l)| if v.abs() > l { l / v.abs() } else { 1.0 }).fold(1.0, f64::min);
        let next: Vec<f64> = self.q.iter().zip(qdot).map(|(q, v)| q + scale * v * dt_s).collect();
        self.admits(&next)?;
        self.q = next;
        self.qdot = qdot.iter().map(|v| scale * v).collect();
        self.time_s += dt_s;
        Ok(())
    }

    /// The scene this simulation renders with the camera at `cam_from_target`: the scenario's
    /// camera, target and render settings (this frame's seed), and its objects placed in the
    /// camera frame (world objects through the target's world pose, tool objects through the
    /// hand-eye transform).
    pub fn scene_at(&self, cam_from_target: Isometry3<f64>) -> Scene {
        let render = RenderSettings { seed: self.scenario.render.seed.wrapping_add(self.frame), ..self.scenario.render };
        let sc = &self.scenario;
        let objects = sc
            .objects
            .iter()
            .map(|(frame, o)| {
                let cam_from_frame = match frame {
                    ObjectFrame::Camera => Isometry3::identity(),
                    ObjectFrame::Target => cam_from_target,
                    ObjectFrame::World => cam_from_target * sc.world_from_target.inverse(),
                    ObjectFrame::Tool => sc.tool_from_cam.inverse(),
                };
                SceneObject { cam_from_object: cam_from_frame * o.cam_from_object, ..o.clone() }
            })
            .collect();
        Scene { camera: sc.camera, target: sc.target.clone(), cam_from_target, render, objects, background: None }
    }

    /// Every feature's exact pixel with the camera at `cam_from_target` (`None` where it is not
    /// visible), from the scenario's camera model: no rendering.
    pub fn projected_px(&self, cam_from_target: &Isometry3<f64>) -> Vec<Option<Point2<f64>>> {
        self.scenario.projected_px(cam_from_target)
    }

    /// [`Sim::projected_px`] with the robot at joints `q` (the model's prediction a controller
    /// may use).
    ///
    /// # Errors
    /// A joint vector of the wrong length.
    pub fn projected_px_at(&self, q: &[f64]) -> Result<Vec<Option<Point2<f64>>>, SimError> {
        Ok(self.projected_px(&self.cam_from_target_at(q)?))
    }

    fn truth(&self, cam_from_target: Isometry3<f64>) -> FrameTruth {
        let projected_px = self.projected_px(&cam_from_target);
        FrameTruth { world_from_cam: self.scenario.world_from_target * cam_from_target.inverse(), cam_from_target, projected_px }
    }

    /// Observe from the robot's current joints.
    ///
    /// # Errors
    /// A sensor failure (renderer, detector); a target not found is an observation without
    /// features.
    pub fn observe(&mut self) -> Result<Observation, SimError> {
        let cam_from_target = self.cam_from_target_at(&self.q)?;
        // A scenario whose `[motion]` follows the robot exposes while the arm keeps moving at its
        // last joint velocities (motion blur, rolling shutter).
        let twist = if self.scenario.render.effects.motion.follow_robot { Some(self.camera_twist()?) } else { None };
        self.observe_with(cam_from_target, twist)
    }

    /// Observe with the camera placed at `cam_from_target` (off the robot: teaching the desired
    /// features by showing, or a fixed camera). Ids are resolved against this pose's prediction.
    ///
    /// # Errors
    /// As [`Sim::observe`].
    pub fn observe_from(&mut self, cam_from_target: Isometry3<f64>) -> Result<Observation, SimError> {
        self.observe_with(cam_from_target, None)
    }

    /// Observe at `cam_from_target`, the camera moving with `twist` during the exposure when given.
    fn observe_with(&mut self, cam_from_target: Isometry3<f64>, twist: Option<[f64; 6]>) -> Result<Observation, SimError> {
        let truth = self.truth(cam_from_target);
        let mut scene = self.scene_at(cam_from_target);
        if let Some(t) = twist {
            scene.render.effects.motion.twist = t;
        }
        let Capture { image, features, note, render_ms, detect_ms } = self.sensor.capture(&scene)?;
        let features = resolve_ids(&self.scenario.target, features, &truth.projected_px);
        let obs = Observation { frame: self.frame, time_s: self.time_s, q_rad: self.q.clone(), image, features, note, render_ms, detect_ms, truth };
        self.frame += 1;
        Ok(obs)
    }
}

/// The grid's symmetric orderings (rotations and mirrors; the four transposes only for square
/// grids) as id permutations: entry k (row-major) is the index that id k takes under it.
pub(crate) fn grid_orderings(cols: usize, rows: usize) -> Vec<Vec<usize>> {
    let at = |r: usize, c: usize| r * cols + c;
    let mut out: Vec<Vec<usize>> = Vec::new();
    let maps: [&dyn Fn(usize, usize) -> Option<usize>; 8] = [
        &|r, c| Some(at(r, c)),
        &|r, c| Some(at(rows - 1 - r, cols - 1 - c)),
        &|r, c| Some(at(rows - 1 - r, c)),
        &|r, c| Some(at(r, cols - 1 - c)),
        &|r, c| (cols == rows).then(|| at(c, r)),
        &|r, c| (cols == rows).then(|| at(cols - 1 - c, rows - 1 - r)),
        &|r, c| (cols == rows).then(|| at(c, rows - 1 - r)),
        &|r, c| (cols == rows).then(|| at(cols - 1 - c, r)),
    ];
    for m in maps {
        let p: Option<Vec<usize>> = (0..rows).flat_map(|r| (0..cols).map(move |c| (r, c))).map(|(r, c)| m(r, c)).collect();
        if let Some(p) = p {
            out.push(p);
        }
    }
    out
}

/// Map a planar grid's detector order onto the target's ids (module docs).
fn resolve_ids(target: &Target, features: Vec<Feature>, predicted: &[Option<Point2<f64>>]) -> Vec<Feature> {
    let (cols, rows) = match target {
        Target::Chessboard(b) => (b.inner_corner_count()[0] as usize, b.inner_corner_count()[1] as usize),
        Target::DotGrid(g) => (g.n as usize, g.n as usize),
        // The detector gave each point its id (decoded markers, path fit).
        Target::Charuco(_) | Target::AprilGrid(_) | Target::SPath(_) => return features,
    };
    if features.len() != cols * rows || predicted.len() != cols * rows {
        return features;
    }
    let cost = |perm: &[usize]| -> f64 { features.iter().zip(perm).map(|(f, id)| predicted[*id].map_or(1e12, |p| (p - f.pixel_px).norm_squared())).sum() };
    let best = grid_orderings(cols, rows).into_iter().min_by(|a, b| cost(a).total_cmp(&cost(b)));
    match best {
        Some(perm) => features.iter().zip(perm).map(|(f, id)| Feature { id, pixel_px: f.pixel_px }).collect(),
        None => features,
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn ideal_ur5e() -> Sim<'static> {
        let spec = crate::ScenarioSpec::parse(crate::UR5E_CHESSBOARD).expect("built-in scenario");
        let robot = spec.robot.build(&|p| Err(format!("no file {p}"))).expect("built-in robot");
        let sensor = crate::sensor::IdealSensor::new(0.1, 7).expect("sensor");
        Sim::new(spec.to_scenario().expect("valid"), robot, Box::new(sensor)).expect("sim")
    }

    #[test]
    fn restart_with_a_seed_replays_the_episode() {
        let mut sim = ideal_ur5e();
        let q0 = sim.joints().to_vec();
        let episode = |sim: &mut Sim<'_>| -> Vec<Vec<Feature>> {
            (0..3)
                .map(|_| {
                    let o = sim.observe().expect("observe");
                    sim.command_joint_velocities(&[0.01, -0.01, 0.0, 0.02, 0.0, 0.01], 0.1).expect("command");
                    o.features
                })
                .collect()
        };
        sim.restart(&q0, Some(11)).expect("restart");
        let a = episode(&mut sim);
        sim.restart(&q0, Some(11)).expect("restart");
        assert_eq!((sim.time_s(), sim.observe().expect("observe").frame), (0.0, 0));
        sim.restart(&q0, Some(11)).expect("restart");
        assert_eq!(episode(&mut sim), a);
        sim.restart(&q0, Some(12)).expect("restart");
        assert_ne!(episode(&mut sim), a, "another seed draws other noise");
        // a refused restart changes nothing
        let q = sim.joints().to_vec();
        assert!(sim.restart(&[0.0; 2], Some(1)).is_err());
        assert_eq!(sim.joints(), q.as_slice());
    }

    #[test]
    fn grid_orderings_are_permutations() {
        for (c, r, n) in [(8, 6, 4), (5, 5, 8), (2, 3, 4)] {
            let all = grid_orderings(c, r);
            assert_eq!(all.len(), n);
            for p in &all {
                let mut s = p.clone();
                s.sort_unstable();
                assert_eq!(s, (0..c * r).collect::<Vec<_>>());
            }
        }
    }
}
