//! Hand-eye calibration from a [`Sim`]: the arm visits random joint configurations around its
//! current ones, each view is observed (rendered and detected, or ideal), PnP gives
//! `cam_from_target`, and Park-Martin refined jointly on the reprojection error
//! ([`synthcam_geometry::handeye`]) estimates `tool_from_cam` and `target_from_base` (the target is the world
//! of the estimate).

use nalgebra::Isometry3;
use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;

use super::controller::EyeInHand;
use super::world::Sim;
use super::SimError;
use synthcam_geometry::handeye::park_martin;
use synthcam_geometry::handeye::refine::{refine_joint, Observations};

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

/// How hand-eye views are drawn.
#[derive(Debug, Clone, Copy)]
pub struct Draw {
    /// Views wanted.
    pub views: usize,
    /// Joints drawn uniformly within this of the current ones, radians.
    pub spread_rad: f64,
    /// The whole target must be predicted this far inside the image, pixels.
    pub margin_px: f64,
    /// A view with fewer detected features is drawn again.
    pub min_features: usize,
    /// Seed of the draws.
    pub seed: u64,
}

/// The drawn views.
pub struct Views {
    /// `base_from_tool` per view.
    pub base_from_tool: Vec<Isometry3<f64>>,
    /// `target_from_cam` per view, from PnP.
    pub target_from_cam: Vec<Isometry3<f64>>,
    /// The true `target_from_cam` per view.
    pub truth_target_from_cam: Vec<Isometry3<f64>>,
    /// Target points and the pixels PnP used, per view.
    pub observations: Vec<Observations>,
    /// Configurations drawn.
    pub drawn: usize,
}

/// Why drawing views failed.
#[derive(Debug)]
pub enum DrawFailure {
    /// Fewer than the views wanted in 400 draws per view (the draws made).
    Unreachable(usize),
    /// PnP failed on a view.
    View {
        /// View index.
        view: usize,
        /// The failure.
        error: SimError,
    },
    /// The simulator failed.
    Sim(SimError),
}

impl From<SimError> for DrawFailure {
    fn from(e: SimError) -> Self {
        DrawFailure::Sim(e)
    }
}

/// Visit configurations around the current joints until `draw.views` of them show the whole
/// target (predicted from the scenario's layout) and have it detected; observe and solve PnP at
/// each. The arm is returned to its joints when the draws run out and after the last view.
pub fn draw_views(sim: &mut Sim<'_>, cell: &EyeInHand, draw: &Draw) -> Result<Views, DrawFailure> {
    let q0 = sim.joints().to_vec();
    let pts = sim.scenario().target.feature_points_m();
    let mut rng = ChaCha8Rng::seed_from_u64(draw.seed);
    let spread = draw.spread_rad.abs().max(1e-9);
    let mut v = Views { base_from_tool: Vec::new(), target_from_cam: Vec::new(), truth_target_from_cam: Vec::new(), observations: Vec::new(), drawn: 0 };
    while v.base_from_tool.len() < draw.views {
        if v.drawn >= 400 * draw.views.max(1) {
            sim.set_joints(&q0)?;
            return Err(DrawFailure::Unreachable(v.drawn));
        }
        v.drawn += 1;
        let q: Vec<f64> = q0.iter().map(|x| x + rng.random_range(-spread..spread)).collect();
        if sim.admits(&q).is_err() || !sim.scenario().camera.sees_all(&sim.cam_from_target_at(&q)?, &pts, draw.margin_px) {
            continue;
        }
        sim.set_joints(&q)?;
        let obs = sim.observe()?;
        if obs.features.len() < draw.min_features {
            continue;
        }
        let view = v.base_from_tool.len();
        let (pose, pixels) = cell.pose_and_pixels(&obs).map_err(|error| DrawFailure::View { view, error })?;
        v.observations.push(obs.features.iter().zip(pixels).map(|(f, px)| (pts[f.id], px)).collect());
        v.base_from_tool.push(sim.robot().base_from_tool(&q).map_err(SimError::from)?);
        v.target_from_cam.push(pose.cam_from_target.inverse());
        v.truth_target_from_cam.push(obs.truth.cam_from_target.inverse());
    }
    sim.set_joints(&q0)?;
    Ok(v)
}

/// Visit `views` configurations within `spread_rad` of the current joints (each showing the whole
/// target, with `margin_px` to the image border, as predicted from the scenario's layout, and
/// detected whole) and estimate the hand-eye transforms. The arm is returned to its joints
/// afterwards.
///
/// # Errors
/// No configuration shows the target within 400 draws per view, a view without enough features,
/// or a degenerate set of motions.
pub fn estimate_hand_eye(sim: &mut Sim<'_>, cell: &EyeInHand, views: usize, spread_rad: f64, margin_px: f64, seed: u64) -> Result<HandEyeEstimate, SimError> {
    let min_features = sim.scenario().target.feature_points_m().len();
    let v = draw_views(sim, cell, &Draw { views, spread_rad, margin_px, min_features, seed }).map_err(|f| match f {
        DrawFailure::Unreachable(drawn) => {
            SimError::Scenario(format!("no configuration within {spread_rad} rad of the start shows the whole target ({drawn} draws)"))
        }
        DrawFailure::View { error, .. } | DrawFailure::Sim(error) => error,
    })?;
    let pm = park_martin(&v.base_from_tool, &v.target_from_cam).map_err(|e| SimError::Control(format!("hand-eye: {e}")))?;
    let refined = refine_joint(&cell.camera, &v.base_from_tool, &v.observations, &pm);
    Ok(HandEyeEstimate { tool_from_cam: refined.tool_from_cam, target_from_base: refined.world_from_base, views, drawn: v.drawn })
}
