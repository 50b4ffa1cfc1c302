//! The course this project grew from (RPI Robotics I, MP4 / MP5; `shared/spec/course-scenario.md`),
//! as one scenario among others: its camera ([`camera`]), its IRB 1200 cell in the open scenario
//! format ([`SCENARIO`], [`world`]), its servo loop ([`servo_run`]: PBVS and IBVS on the S-path of
//! beads, from the course's start to its goal), its hand-eye experiment ([`handeye_run`]) and its
//! calibration study ([`sweep`]), and the course's own solvers and gains ([`handeye_linear`],
//! [`ibvs_params`], [`calibration_pose`]). Everything below this crate is course-free: a lens, a
//! target, a robot and a controller of the user's run the same way.
//!
//! Users reach it through the `synthcam` facade (`synthcam::course`).
//!
//! ```
//! // The course's cell in the open scenario format, readable by any user of the step API.
//! let spec = synthcam_sim::ScenarioSpec::parse(synthcam_course::SCENARIO)?;
//! let scenario = spec.to_scenario()?;
//! assert_eq!(scenario.q_start_rad.len(), 6); // the IRB 1200's joints
//! # Ok::<(), Box<dyn std::error::Error>>(())
//! ```

#![deny(missing_docs)]

use nalgebra::Isometry3;
use synthcam_core::target::Target;
use synthcam_scene::RenderSettings;
// The step API's modules, named as this crate's own so that the experiments read `crate::sensor`.
use synthcam_sim::{controller, handeye_views, observe, scenario, sensor, Sim, SimError};
use synthcam_sim::{JointLimits, SimScenario};

pub mod handeye_run;
mod presets;
pub mod servo_run;
pub mod sweep;

pub use presets::{calibration_pose, camera, handeye_linear, ibvs_params};

/// The course's servoing cell in the open format: IRB 1200, hand-eye variant A, the S-path of
/// beads, the course camera, the course's start and goal (`assets/scenarios/course_sim.toml`).
pub const SCENARIO: &str = include_str!("../assets/scenarios/course_sim.toml");

/// The course's world as a [`SimScenario`]: the course camera ([`camera`]), the S-path of beads (defined in
/// the world frame, so `world_from_target` is the identity), render noise 1 grey level with
/// 8 x 8 samples (render seeds from `seed`), the hand-eye truth of `cell`, and the course's
/// convention of unchecked joint limits.
pub fn world(cell: &synthcam_core::robot::Cell, q_start_rad: &[f64], goal_cam_from_target: Isometry3<f64>, seed: u64) -> SimScenario {
    let (tool_from_cam, world_from_base) = cell.truth();
    SimScenario {
        camera: camera(),
        target: Target::SPath(synthcam_core::target::SPathDots::default()),
        render: RenderSettings { noise_sigma: 1.0, samples: 8, seed, ..Default::default() },
        world_from_base,
        tool_from_cam,
        world_from_target: Isometry3::identity(),
        goal_cam_from_target,
        q_start_rad: q_start_rad.to_vec(),
        joint_limits: JointLimits::Ignore,
        objects: Vec::new(),
    }
}
