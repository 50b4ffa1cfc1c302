//! Truth under the camera effects, per feature ([`super::truth::FeatureLabel::effects`]).
//!
//! - **Rolling shutter**: the pixel where the feature is imaged while its own row is exposed:
//!   the fixed point `v = pi_v(cam(t(v))_from_target(t(v)) X)` of the row time `t(v)`
//!   ([`super::motion`]), solved by Newton's method on `g(v) = pi_v(.) - v` (derivative by central
//!   differences), and that row's time.
//! - **Motion blur**: the feature's image trajectory over its row's exposure at five times
//!   (start, quarter, middle, three quarters, end); the middle is the mid-exposure projection.
//! - **Defocus**: the circle of confusion's radius at the feature's depth
//!   ([`synthcam_core::camera::optics::ThinLens::coc_radius_px`]).
//!
//! The ideal projection (`pixel_px`, the pose at `t = 0`) stays in every label.

use nalgebra::{Point2, Point3};
use serde::Serialize;

use super::Scene;

/// Effect truth of one feature; fields absent when their effect is off.
#[derive(Debug, Clone, PartialEq, Default, Serialize, serde::Deserialize)]
pub struct EffectLabel {
    /// Rolling shutter: the pixel at the time its own row is exposed.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub rolling_shutter_px: Option<[f64; 2]>,
    /// Rolling shutter: that row's exposure centre, seconds after the first row's.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub row_time_s: Option<f64>,
    /// Motion during the exposure: the image trajectory at 0, 1/4, 1/2, 3/4 and 1 of its row's
    /// exposure (the middle is the mid-exposure projection).
    #[serde(default, skip_serializing_if = "Vec::is_empty")]
    pub trajectory_px: Vec<[f64; 2]>,
    /// Defocus: the circle of confusion's radius, pixels (fx).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub coc_radius_px: Option<f64>,
}

impl EffectLabel {
    /// Whether no effect applies.
    pub fn is_empty(&self) -> bool {
        *self == Self::default()
    }
}

/// The image of target point `p` at time `t` ([`super::motion`]), or `None` behind the camera.
pub(crate) fn pixel_at(scene: &Scene, p: &Point3<f64>, t: f64) -> Option<Point2<f64>> {
    let pose = scene.render.effects.motion.cam_from_target_at(&scene.cam_from_target, t);
    let q = scene.camera.project(&(pose * p));
    (q.in_front && q.pixel_px.x.is_finite() && q.pixel_px.y.is_finite()).then_some(q.pixel_px)
}

/// The rolling-shutter pixel of target point `p` and its row time, or `None` when Newton's method
/// does not converge (the image moves faster than the readout, or the point leaves the lens).
pub fn rolling_shutter_pixel(scene: &Scene, p: &Point3<f64>) -> Option<(Point2<f64>, f64)> {
    let m = &scene.render.effects.motion;
    let h = scene.camera.size.height;
    let g = |v: f64| pixel_at(scene, p, m.row_time_s(v, h)).map(|q| q.y - v);
    let mut v = pixel_at(scene, p, 0.0)?.y;
    for _ in 0..50 {
        let step = 1e-3;
        let (g0, gp, gm) = (g(v)?, g(v + step)?, g(v - step)?);
        let dg = (gp - gm) / (2.0 * step);
        if !(dg.abs() > 1e-9) {
            return None;
        }
        let dv = g0 / dg;
        v -= dv;
        if dv.abs() < 1e-11 {
            let t = m.row_time_s(v, h);
            return pixel_at(scene, p, t).map(|q| (q, t));
        }
    }
    None
}

/// The effect truth of target point `p` (target frame).
pub fn effect_label(scene: &Scene, p: &Point3<f64>) -> EffectLabel {
    let fx = &scene.render.effects;
    let mut label = EffectLabel::default();
    let mut t_row = 0.0;
    if fx.motion.rolling() {
        if let Some((q, t)) = rolling_shutter_pixel(scene, p) {
            label.rolling_shutter_px = Some([q.x, q.y]);
            label.row_time_s = Some(t);
            t_row = t;
        }
    }
    if !fx.motion.is_still() && fx.motion.exposure_s > 0.0 {
        label.trajectory_px =
            [-0.5, -0.25, 0.0, 0.25, 0.5].iter().filter_map(|f| pixel_at(scene, p, t_row + f * fx.motion.exposure_s).map(|q| [q.x, q.y])).collect();
    }
    if let Some(lens) = fx.optics.thin_lens {
        let z = (fx.motion.cam_from_target_at(&scene.cam_from_target, t_row) * p).z;
        label.coc_radius_px = (z > 0.0).then(|| lens.coc_radius_px(scene.camera.intrinsics.fx, z));
    }
    label
}
