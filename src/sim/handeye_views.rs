//! Hand-eye calibration from a [`Sim`]: the arm visits random joint configurations around its
//! current ones, each view is observed (rendered and detected, or ideal), PnP gives
//! `cam_from_target`, and Park-Martin refined jointly on the reprojection error
//! ([`crate::handeye`]) estimates `tool_from_cam` and `target_from_base` (the target is the world
//! of the estimate).

use nalgebra::Isometry3;
use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;

use super::controller::EyeInHand;
use super::world::Sim;
use super::SimError;
use crate::handeye::park_martin;
use crate::handeye::refine::{refine_joint, Observations};

/// The views and the estimate.
#[derive(Debug, Clone, PartialEq)]
pub struct HandEyeEstimate {
    /// Refined `tool_from_cam`.
    pub tool_from_cam: Isometry3<f64>,
    /// Refined `target_from_base`.
    pub target_from_base: Isometry3<f64>,
    /// Views used.
    pub views: usize,
    /// Configurations drawn to get them.
    pub drawn: usize,
}

/// Visit `views` configurations within `spread_rad` of the current joints (each showing the whole
/// target, with `margin_px` to the image border, as predicted from the scenario's layout) and
/// estimate the hand-eye transforms. The arm is returned to its joints afterwards.
///
/// # Errors
/// No configuration shows the target within 400 draws per view, a view without enough features,
/// or a degenerate set of motions.
pub fn estimate_hand_eye(sim: &mut Sim<'_>, cell: &EyeInHand, views: usize, spread_rad: f64, margin_px: f64, seed: u64) -> Result<HandEyeEstimate, SimError> {
    let q0 = sim.joints().to_vec();
    let pts = sim.scenario().target.feature_points_m();
    let mut rng = ChaCha8Rng::seed_from_u64(seed);
    let spread = spread_rad.abs().max(1e-9);
    let (mut bt, mut wc, mut obs_all): (Vec<Isometry3<f64>>, Vec<Isometry3<f64>>, Vec<Observations>) = (Vec::new(), Vec::new(), Vec::new());
    let mut drawn = 0;
    while bt.len() < views {
        if drawn >= 400 * views.max(1) {
            sim.set_joints(&q0)?;
            return Err(SimError::Scenario(format!("no configuration within {spread_rad} rad of the start shows the whole target ({drawn} draws)")));
        }
        drawn += 1;
        let q: Vec<f64> = q0.iter().map(|v| v + rng.random_range(-spread..spread)).collect();
        if sim.admits(&q).is_err() || !sim.scenario().camera.sees_all(&sim.cam_from_target_at(&q)?, &pts, margin_px) {
            continue;
        }
        sim.set_joints(&q)?;
        let obs = sim.observe()?;
        if obs.features.len() < pts.len() {
            continue;
        }
        let (pose, pixels) = cell.pose_and_pixels(&obs)?;
        obs_all.push(obs.features.iter().zip(pixels).map(|(f, px)| (pts[f.id], px)).collect());
        bt.push(sim.robot().base_from_tool(&q)?);
        wc.push(pose.cam_from_target.inverse());
    }
    sim.set_joints(&q0)?;
    let pm = park_martin(&bt, &wc).map_err(|e| SimError::Control(format!("hand-eye: {e}")))?;
    let refined = refine_joint(&cell.camera, &bt, &obs_all, &pm);
    Ok(HandEyeEstimate { tool_from_cam: refined.tool_from_cam, target_from_base: refined.world_from_base, views, drawn })
}
