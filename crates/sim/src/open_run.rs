//! A whole open-scenario run: hand-eye from views around the start, then PBVS or IBVS with the
//! estimate, on a [`Sim`] (what `synthcam sim` does).

use super::controller::{pixel_rms, run_loop, Controller, EyeInHand, Ibvs, LoopTrace, Pbvs};
use super::controller::{Law, PoseError};
use super::handeye_views::{estimate_hand_eye, HandEyeEstimate};
use super::world::Sim;
use super::SimError;
use synthcam_geometry::servo::{IbvsParams, PbvsParams};

/// Options of [`run_open`].
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct OpenRunOptions {
    /// The law.
    pub law: Law,
    /// Hand-eye views (0: use the true `tool_from_cam`).
    pub handeye_views: usize,
    /// Joint spread of the hand-eye views, radians.
    pub spread_rad: f64,
    /// Control steps at most.
    pub max_steps: usize,
    /// Control period, seconds.
    pub dt_s: f64,
    /// Seed of the hand-eye views.
    pub seed: u64,
    /// IBVS stops below this RMS pixel error (on ideal projections keep it above the noise floor,
    /// sigma sqrt(2)).
    pub stop_px: f64,
}

impl Default for OpenRunOptions {
    fn default() -> Self {
        Self { law: Law::Pbvs, handeye_views: 10, spread_rad: 0.25, max_steps: 300, dt_s: 1.0, seed: 1, stop_px: 0.05 }
    }
}

/// What [`run_open`] measured.
#[derive(Debug, Clone, PartialEq, serde::Serialize)]
pub struct OpenRun {
    /// Hand-eye `tool_from_cam` error vs the truth: millimetres, degrees (0 when the truth was used).
    pub handeye_error_mm_deg: (f64, f64),
    /// The loop.
    pub trace: LoopTrace,
    /// IBVS: RMS pixel error at the end vs the desired features.
    pub final_pixel_rms_px: Option<f64>,
}

/// Hand-eye, then the law, from the scenario's start.
///
/// # Errors
/// Bad options, a failed hand-eye estimate, a sensor or controller failure.
pub fn run_open(sim: &mut Sim<'_>, options: &OpenRunOptions) -> Result<OpenRun, SimError> {
    if options.max_steps == 0 || !(options.dt_s > 0.0) || !options.spread_rad.is_finite() {
        return Err(SimError::Scenario(format!("need max_steps > 0, dt_s > 0 and a finite spread, got {options:?}")));
    }
    let sc = sim.scenario().clone();
    let truth_cell = EyeInHand { camera: sc.camera, target: sc.target.clone(), tool_from_cam: sc.tool_from_cam };
    let (tool_from_cam, handeye_error_mm_deg) = if options.handeye_views == 0 {
        (sc.tool_from_cam, (0.0, 0.0))
    } else {
        let HandEyeEstimate { tool_from_cam: x, .. } = estimate_hand_eye(sim, &truth_cell, options.handeye_views, options.spread_rad, 20.0, options.seed)?;
        let e = PoseError::between(&x, &sc.tool_from_cam);
        (x, (e.mm, e.deg))
    };
    let cell = EyeInHand { tool_from_cam, ..truth_cell };
    let goal = sc.goal_cam_from_target;
    let (mut controller, desired): (Box<dyn Controller>, _) = match options.law {
        Law::Pbvs => (
            Box::new(Pbvs {
                cell,
                goal_cam_from_target: goal,
                params: PbvsParams::default(),
                stop_mm_deg: (0.05, 0.005),
                base_from_target: None,
                bias: Default::default(),
            }),
            None,
        ),
        Law::Ibvs => {
            let desired = Ibvs::desired_from(&sim.observe_from(goal)?, sc.target.feature_points_m().len());
            (
                Box::new(Ibvs {
                    cell,
                    desired_px: desired.clone(),
                    goal_cam_from_target: goal,
                    params: IbvsParams::default(),
                    stop_px: options.stop_px,
                    bias: Default::default(),
                }),
                Some(desired),
            )
        }
    };
    let trace = run_loop(sim, controller.as_mut(), &goal, options.dt_s, options.max_steps)?;
    let final_pixel_rms_px = match desired {
        Some(d) => pixel_rms(&sim.observe()?.features, &d),
        None => None,
    };
    Ok(OpenRun { handeye_error_mm_deg, trace, final_pixel_rms_px })
}
