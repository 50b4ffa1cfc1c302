//! Servo runs (`synthcam servo`, [`ServoTrace`]) and open-scenario loops (`synthcam sim`,
//! [`LoopTrace`]) as rerun recordings: one `step` a control update, the robot's transforms from
//! its joints (as in the bags, [`super::super::series`]).

use std::path::Path;

use nalgebra::{Isometry3, Point2};

use super::{Rrd, RrdCounts, DESIRED, DETECTED, TRUTH};
use crate::dataset::formats::series::DEFAULT_FRAME_PERIOD_NS;
use crate::dataset::formats::FormatError;
use synthcam_core::robot::Robot;
use synthcam_course::servo_run::ServoTrace;
use synthcam_render::GreyImage;
use synthcam_scene::file::CameraSpec;
use synthcam_sim::controller::{pixel_rms, LoopTrace};
use synthcam_sim::sensor::Feature;
use synthcam_sim::SimScenario;

/// One step of a run, as recorded.
struct StepLog<'a> {
    step: usize,
    q_rad: &'a [f64],
    qdot: &'a [f64],
    detected: Vec<Feature>,
    /// The true camera against the goal: millimetres and degrees.
    pose_error: (f64, f64),
    render_detect_ms: (f64, f64),
    frame: Option<&'a GreyImage>,
}

/// What every step of a run shares: the scenario, its robot and the goal's features (the target
/// and the goal are logged once, static: they do not move).
struct RunLog<'a> {
    rrd: Rrd,
    scenario: &'a SimScenario,
    robot: &'a dyn Robot,
    desired: Vec<Option<Point2<f64>>>,
    period_s: f64,
}

impl RunLog<'_> {
    fn start<'a>(path: &Path, scenario: &'a SimScenario, robot: &'a dyn Robot, desired: Vec<Option<Point2<f64>>>) -> Result<RunLog<'a>, FormatError> {
        let rrd = Rrd::create(path, &format!("synthcam {}", robot.name()))?;
        let cam = CameraSpec::from_model(&scenario.camera);
        rrd.camera("world/camera/image", &cam)?;
        rrd.camera_info(robot.name(), &cam)?;
        let world_from_goal_cam = scenario.world_from_target * scenario.goal_cam_from_target.inverse();
        rrd.pose("world/goal_camera", &world_from_goal_cam, true)?;
        rrd.camera("world/goal_camera/image", &cam)?;
        rrd.pose("world/target", &scenario.world_from_target, true)?;
        rrd.log_static("world/camera/image/desired", &Rrd::points_2d(&seen(&desired), DESIRED))?;
        for (entity, name) in [
            ("error/pixel_rms_px", "detected vs desired RMS (px)"),
            ("error/detection_rms_px", "detected vs truth RMS (px)"),
            ("error/pose_mm", "camera vs goal (mm)"),
            ("error/pose_deg", "camera vs goal (deg)"),
            ("timing/render_ms", "render (ms)"),
            ("timing/detect_ms", "detect (ms)"),
        ] {
            rrd.log_static(entity, &rerun::SeriesLines::new().with_names([name]))?;
        }
        for i in 0..robot.dof() {
            rrd.log_static(&format!("joints/q{i}"), &rerun::SeriesLines::new().with_names([format!("q{i} (rad)")]))?;
        }
        Ok(RunLog { rrd, scenario, robot, desired, period_s: DEFAULT_FRAME_PERIOD_NS as f64 * 1e-9 })
    }

    fn step(&self, s: &StepLog<'_>) -> Result<(), FormatError> {
        let rrd = &self.rrd;
        rrd.at_step(s.step as u64, self.period_s);
        let base_from_tool = self.robot.base_from_tool(s.q_rad).map_err(|e| rrd.err(format!("step {}: forward kinematics: {e}", s.step)))?;
        let world_from_cam: Isometry3<f64> = self.scenario.world_from_base * base_from_tool * self.scenario.tool_from_cam;
        rrd.pose("world/camera", &world_from_cam, false)?;
        if let Some(img) = s.frame {
            rrd.frame("world/camera/image", crate::dataset::encode_png(img)?)?;
        }
        let truth = self.scenario.projected_px(&(world_from_cam.inverse() * self.scenario.world_from_target));
        let detected: Vec<(usize, Point2<f64>)> = s.detected.iter().map(|f| (f.id, f.pixel_px)).collect();
        rrd.points("world/camera/image/detected", &detected, DETECTED)?;
        rrd.points("world/camera/image/truth", &seen(&truth), TRUTH)?;
        for (i, q) in s.q_rad.iter().enumerate() {
            rrd.scalar(&format!("joints/q{i}"), *q)?;
        }
        for (i, v) in s.qdot.iter().enumerate() {
            rrd.scalar(&format!("command/qdot{i}"), *v)?;
        }
        if let Some(rms) = pixel_rms(&s.detected, &self.desired) {
            rrd.scalar("error/pixel_rms_px", rms)?;
        }
        if let Some(rms) = pixel_rms(&s.detected, &truth) {
            rrd.scalar("error/detection_rms_px", rms)?;
        }
        let matched = s.detected.iter().filter(|f| self.desired.get(f.id).is_some_and(Option::is_some)).count();
        rrd.scalar("error/pose_mm", s.pose_error.0)?;
        rrd.scalar("error/pose_deg", s.pose_error.1)?;
        rrd.scalar("features/detected", s.detected.len() as f64)?;
        rrd.scalar("features/matched", matched as f64)?;
        rrd.scalar("timing/render_ms", s.render_detect_ms.0)?;
        rrd.scalar("timing/detect_ms", s.render_detect_ms.1)
    }
}

/// The visible points of a per-id list, with their ids.
fn seen(pts: &[Option<Point2<f64>>]) -> Vec<(usize, Point2<f64>)> {
    pts.iter().enumerate().filter_map(|(i, p)| p.map(|p| (i, p))).collect()
}

/// Log `steps` after [`RunLog::start`], then close the file.
fn record<'a>(
    path: &Path,
    scenario: &SimScenario,
    robot: &dyn Robot,
    desired: Vec<Option<Point2<f64>>>,
    steps: impl Iterator<Item = StepLog<'a>>,
) -> Result<RrdCounts, FormatError> {
    let log = RunLog::start(path, scenario, robot, desired)?;
    let mut counts = RrdCounts::default();
    for s in steps {
        counts.frames += usize::from(s.frame.is_some());
        counts.steps += 1;
        log.step(&s)?;
    }
    counts.bytes = log.rrd.finish()?;
    Ok(counts)
}

/// Write a servo run as a rerun recording at `path`: every step of `trace`, with the frames of
/// `images` ((step, rendered frame); steps without one are logged without an image).
///
/// # Errors
/// [`FormatError::Rerun`] or [`FormatError::Write`] when the file cannot be written (nothing is
/// left at `path`); forward kinematics failing at a step.
pub fn write_servo_rrd(
    path: &Path,
    scenario: &SimScenario,
    robot: &dyn Robot,
    trace: &ServoTrace,
    images: &[(usize, GreyImage)],
) -> Result<RrdCounts, FormatError> {
    let desired = trace.desired_px.iter().map(|d| d.map(|[u, v]| Point2::new(u, v))).collect();
    let steps = trace.steps.iter().map(|s| StepLog {
        step: s.step,
        q_rad: &s.q_rad,
        // The servo trace keeps the joints, not the commands.
        qdot: &[],
        detected: s.features_px.iter().map(|f| Feature { id: f[0] as usize, pixel_px: Point2::new(f[1], f[2]) }).collect(),
        pose_error: (s.pose_error_mm, s.pose_error_deg),
        render_detect_ms: (s.render_ms, s.detect_ms),
        frame: images.iter().find(|(i, _)| *i == s.step).map(|(_, img)| img),
    });
    record(path, scenario, robot, desired, steps)
}

/// Write an open-scenario loop (`synthcam sim`) as a rerun recording at `path`: `images` are
/// (simulator frame, rendered frame) of every observation; the loop's steps are logged, step k
/// at `step` k (the hand-eye views before the loop are left out). The desired features are the
/// goal pose's exact projections.
///
/// # Errors
/// As [`write_servo_rrd`].
pub fn write_loop_rrd(
    path: &Path,
    scenario: &SimScenario,
    robot: &dyn Robot,
    trace: &LoopTrace,
    images: &[(usize, GreyImage)],
) -> Result<RrdCounts, FormatError> {
    let steps = trace.steps.iter().enumerate().map(|(k, s)| StepLog {
        step: k,
        q_rad: &s.q_rad,
        qdot: &s.qdot,
        detected: s.observed.clone(),
        pose_error: s.goal_error_mm_deg,
        render_detect_ms: s.render_detect_ms,
        frame: images.iter().find(|(i, _)| *i as u64 == s.frame).map(|(_, img)| img),
    });
    record(path, scenario, robot, scenario.projected_px(&scenario.goal_cam_from_target), steps)
}
