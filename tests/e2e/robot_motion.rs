//! A camera on a moving arm (issue 18, "in robot scenarios joint velocities"): with `[motion]
//! follow_robot = true` each frame is exposed while the arm keeps its last joint velocities.

use synthcam::math::se3::exp_twist;
use synthcam::sim::sensor::RenderedSensor;
use synthcam::sim::{ScenarioSpec, Sim};

use crate::common::renderer;

fn moving_sim(extra: &str) -> Sim<'static> {
    let text = format!("{}\n{extra}", synthcam::sim::UR5E_CHESSBOARD);
    let spec = ScenarioSpec::parse(&text).expect("scenario parses");
    let robot = spec.robot.build(&|_| Err("no files".into())).expect("robot");
    Sim::new(spec.to_scenario().expect("valid"), robot, Box::new(RenderedSensor::new(renderer()))).expect("sim")
}

#[test]
fn the_camera_moves_with_the_arm_during_the_exposure() {
    let mut sim = moving_sim("[motion]\nfollow_robot = true\nexposure_s = 0.02\nline_delay_s = 2e-5\n");
    let still = sim.observe().expect("observe");
    let qdot = [0.3, -0.2, 0.25, 0.4, -0.3, 0.5];
    sim.command_joint_velocities(&qdot, 0.01).expect("command");
    let twist = sim.camera_twist().expect("twist");
    // Independent: the camera's pose after dt of joint motion against the twist's exponential.
    let dt = 1e-3;
    let q = sim.joints().to_vec();
    let ahead: Vec<f64> = q.iter().zip(&qdot).map(|(q, v)| q + v * dt).collect();
    let moved = sim.world_from_cam_at(&q).expect("pose").inverse() * sim.world_from_cam_at(&ahead).expect("pose");
    let predicted = exp_twist(&twist, dt);
    let (dt_err, dr_err) = ((moved.translation.vector - predicted.translation.vector).norm(), moved.rotation.angle_to(&predicted.rotation));
    let speed = (twist[3].powi(2) + twist[4].powi(2) + twist[5].powi(2)).sqrt();
    eprintln!("arm twist {twist:.4?}: after 1 ms, exp(twist dt) vs forward kinematics {dt_err:.2e} m, {dr_err:.2e} rad (camera speed {speed:.3} m/s)");
    assert!(dt_err < 2e-7 && dr_err < 2e-6, "{dt_err} {dr_err}");
    let blurred = sim.observe().expect("observe");
    let (Some(a), Some(b)) = (still.image.as_ref(), blurred.image.as_ref()) else { panic!("images") };
    assert_ne!(a, b);
    assert!(!blurred.features.is_empty(), "{:?}", blurred.note);
    // Placed at joints (not driven there): the arm stands still.
    sim.set_joints(&q).expect("joints");
    assert!(sim.camera_twist().expect("twist").iter().all(|v| v.abs() < 1e-6));
}

#[test]
fn scenes_and_s_path_scenarios_refuse_follow_robot() {
    let scene = format!("{}\n[motion]\nfollow_robot = true\n", include_str!("../../assets/scenes/chessboard_k1.toml"));
    let err = synthcam::scene::file::parse_scene(&scene).expect_err("scene").to_string();
    assert!(err.contains("motion.follow_robot"), "{err}");
    let course = format!("{}\n[motion]\nfollow_robot = true\nexposure_s = 0.01\n", synthcam::course::SCENARIO);
    let err = ScenarioSpec::parse(&course).expect("parses").to_scenario().expect_err("S-path").to_string();
    assert!(err.contains("S-path"), "{err}");
}
