//! Time series as ROS 2 bags ([`super::mcap`]): robot-mode datasets (image k at k x the frame
//! period) and servo runs (step s at s x the frame period, one control update per frame).
//!
//! Frames (ids as tf): `world` -> `base` (the robot's base) -> `tool0` -> `cam0` (the camera's
//! optical frame, OpenCV's axes) and, for datasets, `cam0` -> `target` from the truth's
//! `cam_from_target`; for servo runs `world` -> `target` from the scenario (the target does not
//! move). Each transform is `parent_from_child`.

use nalgebra::{Isometry3, Matrix3, Rotation3, Translation3, UnitQuaternion, Vector3};

use super::bag::{write_bag, BagOutput};
use super::folder::DatasetFolder;
use super::mcap::{decode_raw_image, raw_image, McapCounts, SeriesFrame};
use super::ros2_msgs::FrameTransform;
use super::FormatError;
use crate::dataset::spec::PoseMode;
use synthcam_core::robot::{base_from_tool, Joints, Robot};
use synthcam_course::servo_run::ServoTrace;
use synthcam_render::GreyImage;
use synthcam_scene::file::CameraSpec;
use synthcam_scene::truth::PoseLabel;
use synthcam_sim::controller::LoopTrace;
use synthcam_sim::SimScenario;

/// Default time between frames: 100 ms (10 Hz).
pub const DEFAULT_FRAME_PERIOD_NS: u64 = 100_000_000;

fn tf(parent: &str, child: &str, parent_from_child: Isometry3<f64>) -> FrameTransform {
    FrameTransform { parent: parent.into(), child: child.into(), parent_from_child }
}

/// The isometry of a truth pose label (rotation rows re-orthonormalised by the quaternion).
pub fn pose_of_label(p: &PoseLabel) -> Isometry3<f64> {
    let r = Matrix3::from_fn(|i, j| p.r[i][j]);
    let q = UnitQuaternion::from_rotation_matrix(&Rotation3::from_matrix_unchecked(r));
    Isometry3::from_parts(Translation3::from(Vector3::from(p.t_m)), q)
}

/// Write a robot-mode dataset as a bag at `out`; returns the bytes written.
///
/// # Errors
/// [`FormatError::Unsupported`] for a dataset whose poses are not a robot's, a read, decode or
/// write error.
pub fn write_dataset_bag(folder: &DatasetFolder, out: &BagOutput, frame_period_ns: u64, tick: super::Tick<'_>) -> Result<u64, FormatError> {
    let plan = folder.plan()?;
    let PoseMode::Robot(cell) = &plan.mode else {
        return Err(FormatError::Unsupported {
            format: "mcap",
            reason: "its images are independent views, not a time series: only `[poses] mode = \"robot\"` datasets (or `synthcam servo --mcap`) make bags"
                .into(),
        });
    };
    let (tool_from_cam, world_from_base) = cell.truth();
    if folder.entries.is_empty() {
        return Err(FormatError::Unsupported { format: "mcap", reason: "the dataset has no images".into() });
    }
    let frames = folder.entries.iter().map(|e| {
        tick();
        let truth = folder.read_truth(e)?;
        let q = e.joints_rad.ok_or_else(|| FormatError::Corrupt {
            path: folder.dir.join("manifest.jsonl").display().to_string(),
            reason: format!("k = {}: no joints_rad", e.k),
        })?;
        let transforms = vec![
            tf("world", "base", world_from_base),
            tf("base", "tool0", base_from_tool(&Joints::from(q))),
            tf("tool0", "cam0", tool_from_cam),
            tf("cam0", "target", pose_of_label(&truth.cam_from_target)),
        ];
        let image = decode_raw_image(&folder.read_image(e)?, &e.file)?;
        Ok(SeriesFrame { stamp_ns: e.k.saturating_mul(frame_period_ns), image, transforms })
    });
    Ok(write_bag(out, &CameraSpec::from_model(&plan.camera), frames)?.1)
}

/// The frames of a run on a robot: `images` are (index, rendered frame), each stamped at index x
/// `frame_period_ns` with the robot's transforms at `q_at(index)` (images without joints are
/// skipped).
///
/// # Errors
/// [`FormatError::Unsupported`] when the robot's forward kinematics fails.
fn robot_frames<'t>(
    scenario: &SimScenario,
    robot: &dyn Robot,
    images: &[(usize, GreyImage)],
    q_at: impl Fn(usize) -> Option<&'t [f64]>,
    frame_period_ns: u64,
) -> Result<Vec<SeriesFrame>, FormatError> {
    let mut frames = Vec::with_capacity(images.len());
    for (index, img) in images {
        let Some(q) = q_at(*index) else { continue };
        let base_from_tool =
            robot.base_from_tool(q).map_err(|e| FormatError::Unsupported { format: "mcap", reason: format!("frame {index}: forward kinematics: {e}") })?;
        let transforms = vec![
            tf("world", "base", scenario.world_from_base),
            tf("base", "tool0", base_from_tool),
            tf("tool0", "cam0", scenario.tool_from_cam),
            tf("world", "target", scenario.world_from_target),
        ];
        frames.push(SeriesFrame { stamp_ns: (*index as u64).saturating_mul(frame_period_ns), image: raw_image(img), transforms });
    }
    Ok(frames)
}

/// The frames of a servo run: `images` are (step, rendered frame); each is stamped at step x
/// `frame_period_ns` with the robot's transforms at that step's joints (frames of steps the
/// trace does not hold are skipped).
///
/// # Errors
/// [`FormatError::Unsupported`] when the robot's forward kinematics fails at a step.
pub fn servo_frames(
    scenario: &SimScenario,
    robot: &dyn Robot,
    trace: &ServoTrace,
    images: &[(usize, GreyImage)],
    frame_period_ns: u64,
) -> Result<Vec<SeriesFrame>, FormatError> {
    robot_frames(scenario, robot, images, |step| trace.steps.iter().find(|r| r.step == step).map(|r| r.q_rad.as_slice()), frame_period_ns)
}

/// Write an open-scenario run (`synthcam sim`) as a bag at `out`: `images` are (simulator frame,
/// rendered frame) of every observation; those of the loop's steps are written, stamped at frame x
/// 100 ms (the hand-eye views before the loop leave a gap). Returns the counts and bytes.
///
/// # Errors
/// As [`write_servo_bag`].
pub fn write_loop_bag(
    out: &BagOutput,
    scenario: &SimScenario,
    robot: &dyn Robot,
    trace: &LoopTrace,
    images: &[(usize, GreyImage)],
) -> Result<(McapCounts, u64), FormatError> {
    let q_at = |frame: usize| trace.steps.iter().find(|s| s.frame == frame as u64).map(|s| s.q_rad.as_slice());
    let frames = robot_frames(scenario, robot, images, q_at, DEFAULT_FRAME_PERIOD_NS)?;
    write_bag(out, &CameraSpec::from_model(&scenario.camera), frames.into_iter().map(Ok))
}

/// Write a servo run as a bag at `out` ([`servo_frames`]). Returns the counts and bytes.
///
/// # Errors
/// As [`servo_frames`] and [`write_bag`].
pub fn write_servo_bag(
    out: &BagOutput,
    scenario: &SimScenario,
    robot: &dyn Robot,
    trace: &ServoTrace,
    images: &[(usize, GreyImage)],
) -> Result<(McapCounts, u64), FormatError> {
    let frames = servo_frames(scenario, robot, trace, images, DEFAULT_FRAME_PERIOD_NS)?;
    write_bag(out, &CameraSpec::from_model(&scenario.camera), frames.into_iter().map(Ok))
}
