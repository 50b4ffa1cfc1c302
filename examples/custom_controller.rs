//! Your controller in the loop: a hand-written proportional law closes the loop on rendered and
//! detected pixels through the same step API synthcam's PBVS and IBVS use. The law here is the
//! simplest image-based one (Chaumette & Hutchinson 2006, eq. 3): qdot = -gain J^+ (s - s*), with
//! the image Jacobian estimated *numerically* from the arm model and the desired depths, written
//! with nalgebra in the user's own code. Exits non-zero unless it converges to < 0.5 px RMS.
//!
//! `cargo run --release --example custom_controller`

use nalgebra::{DMatrix, DVector, Point2};
use synthcam::render::Renderer;
use synthcam::robot::Robot;
use synthcam::sim::controller::{pixel_rms, Command, Controller};
use synthcam::sim::sensor::RenderedSensor;
use synthcam::sim::{Observation, ScenarioSpec, Sim, SimError};

/// Predicted pixel of every feature at joints q (the user's model of the cell).
type Predictor = Box<dyn Fn(&[f64]) -> Vec<Option<Point2<f64>>>>;

/// A user's law: finite-difference image Jacobian at the desired pose, damped pseudo-inverse.
struct MyIbvs {
    desired: Vec<Option<Point2<f64>>>,
    predict: Predictor,
}

impl Controller for MyIbvs {
    fn command(&mut self, robot: &dyn Robot, obs: &Observation, dt_s: f64) -> Result<Command, SimError> {
        let matched: Vec<_> = obs.features.iter().filter_map(|f| self.desired[f.id].map(|d| (f.id, f.pixel_px - d))).collect();
        if pixel_rms(&obs.features, &self.desired).is_some_and(|r| r < 0.05) {
            return Ok(Command::Stop);
        }
        // d(pixel)/d(q) by central differences of the model's prediction (no analytic Jacobian).
        let n = robot.dof();
        let mut j = DMatrix::zeros(2 * matched.len(), n);
        for k in 0..n {
            let (mut qp, mut qm) = (obs.q_rad.clone(), obs.q_rad.clone());
            qp[k] += 1e-6;
            qm[k] -= 1e-6;
            let (pp, pm) = ((self.predict)(&qp), (self.predict)(&qm));
            for (row, (id, _)) in matched.iter().enumerate() {
                let (Some(a), Some(b)) = (pp[*id], pm[*id]) else { continue };
                let d = (a - b) / 2e-6;
                j[(2 * row, k)] = d.x;
                j[(2 * row + 1, k)] = d.y;
            }
        }
        let e = DVector::from_iterator(2 * matched.len(), matched.iter().flat_map(|(_, e)| [e.x, e.y]));
        let a = j.transpose() * &j + DMatrix::identity(n, n) * 100.0;
        let dq = a.try_inverse().ok_or_else(|| SimError::Control("singular".into()))? * (j.transpose() * e);
        Ok(Command::Velocities(dq.iter().map(|v| -0.3 * v / dt_s).collect()))
    }
}

fn main() -> Result<(), Box<dyn std::error::Error>> {
    let spec = ScenarioSpec::parse(synthcam::sim::UR5E_CHESSBOARD)?;
    let scenario = spec.to_scenario()?;
    let renderer = Renderer::headless()?;
    let mut sim = Sim::new(scenario.clone(), spec.robot.build(&|_| Err("no files".into()))?, Box::new(RenderedSensor::new(&renderer)))?;
    // Teach the desired features by showing the camera the goal view.
    let goal = sim.observe_from(scenario.goal_cam_from_target)?;
    let mut desired = vec![None; scenario.target.feature_points_m().len()];
    for f in &goal.features {
        desired[f.id] = Some(f.pixel_px);
    }
    // The user's model of the cell: here the scenario's nominal layout.
    let (robot, sc, count) = (spec.robot.build(&|_| Err("no files".into()))?, scenario.clone(), desired.len());
    let predict = move |q: &[f64]| -> Vec<Option<Point2<f64>>> {
        let Ok(bt) = robot.base_from_tool(q) else { return vec![None; count] };
        let cam_from_target = (sc.world_from_base * bt * sc.tool_from_cam).inverse() * sc.world_from_target;
        sc.target.feature_points_m().iter().map(|p| sc.camera.project(&(cam_from_target * p))).map(|pr| pr.visible().then_some(pr.pixel_px)).collect()
    };
    let mut law = MyIbvs { desired: desired.clone(), predict: Box::new(predict) };
    // The loop, written out: observe, command, move.
    for step in 0..200 {
        let obs = sim.observe()?;
        let rms = pixel_rms(&obs.features, &desired).unwrap_or(f64::INFINITY);
        match law.command(sim.robot(), &obs, 0.1)? {
            Command::Stop => {
                println!("converged at step {step}: {rms:.4} px RMS");
                return Ok(());
            }
            Command::Velocities(qdot) => sim.command_joint_velocities(&qdot, 0.1)?,
        }
        if step % 20 == 0 {
            println!("step {step}: {rms:.3} px RMS, {} features", obs.features.len());
        }
    }
    let rms = pixel_rms(&sim.observe()?.features, &desired).unwrap_or(f64::INFINITY);
    if rms > 0.5 {
        return Err(format!("did not converge: {rms:.3} px RMS after 200 steps").into());
    }
    println!("after 200 steps: {rms:.4} px RMS");
    Ok(())
}
