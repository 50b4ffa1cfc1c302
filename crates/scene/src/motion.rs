//! Motion during the exposure: a camera and/or target moving with constant body twists, the
//! exposure (motion blur) and a rolling shutter.
//!
//! **Time.** `t = 0` is the middle of the exposure of the first row read out: the scene's pose
//! (`cam_from_target`) holds then. Row `r` is read `k(r)` lines later, `k(r) = r` top-down and
//! `H - 1 - r` bottom-up, so its exposure is centred at `t(r) = k(r) line_delay_s` and spans
//! `[t(r) - exposure_s / 2, t(r) + exposure_s / 2]`. Rows are continuous: a feature imaged at
//! sub-pixel row `v` is exposed at `t(v)` (the row-time fixed point of [`super::truth`]). A global
//! shutter is `line_delay_s = 0`.
//!
//! **Poses.** The camera moves with the body twist `twist` (its own frame) and the target with
//! `target_twist` (its own frame), both constant: `cam0_from_cam(t) = exp(t twist)`,
//! `target0_from_target(t) = exp(t target_twist)` ([`synthcam_core::math::se3::exp_twist`]), so
//! `cam(t)_from_target(t) = exp(t twist)^-1 cam0_from_target0 exp(t target_twist)`.
//!
//! Reference: Meingast, Geyer & Sastry, "Geometric models of rolling-shutter cameras" (2005) for
//! the row-time model; Cook, Porter & Carpenter, "Distributed ray tracing" (1984) for sampling the
//! exposure time.

use nalgebra::Isometry3;

use super::SceneError;
use synthcam_core::math::se3::exp_twist;

/// The order in which rows are read out.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, serde::Serialize, serde::Deserialize)]
#[serde(rename_all = "kebab-case")]
pub enum Readout {
    /// Row 0 first.
    #[default]
    TopDown,
    /// The last row first.
    BottomUp,
}

/// Most exposure-time samples per pixel.
pub const MAX_TIME_SAMPLES: u32 = 64;

/// Motion during the exposure (`[motion]` in scene files). The default is a still scene.
#[derive(Debug, Clone, Copy, PartialEq, serde::Serialize, serde::Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct Motion {
    /// The camera's body twist `[wx, wy, wz, vx, vy, vz]`, rad/s and m/s, in its own frame.
    pub twist: [f64; 6],
    /// The target's body twist in its own frame, same units.
    pub target_twist: [f64; 6],
    /// Exposure time integrated for motion blur, seconds (0: none). `[sensor] exposure_s` when
    /// this is not given and a sensor is.
    pub exposure_s: f64,
    /// Time between the exposures of consecutive rows (0: global shutter), seconds.
    pub line_delay_s: f64,
    /// Row readout order.
    pub readout: Readout,
    /// Exposure-time samples per pixel (0: automatic, four per pixel the image moves, at most
    /// [`MAX_TIME_SAMPLES`]).
    pub time_samples: u32,
    /// Robot scenarios only: the camera's twist is the arm's, from its last applied joint
    /// velocities at each frame (`synthcam_sim::Sim::camera_twist`); `twist` is then ignored.
    pub follow_robot: bool,
}

impl Default for Motion {
    fn default() -> Self {
        Self { twist: [0.0; 6], target_twist: [0.0; 6], exposure_s: 0.0, line_delay_s: 0.0, readout: Readout::TopDown, time_samples: 0, follow_robot: false }
    }
}

fn invalid(field: &str, reason: String) -> SceneError {
    SceneError::InvalidField { field: format!("motion.{field}"), reason }
}

impl Motion {
    /// Check every field.
    ///
    /// # Errors
    /// [`SceneError::InvalidField`] naming the field.
    pub fn validate(&self) -> Result<(), SceneError> {
        for (name, v) in [("twist", &self.twist), ("target_twist", &self.target_twist)] {
            if v.iter().any(|x| !x.is_finite()) {
                return Err(invalid(name, format!("must be finite, got {v:?}")));
            }
        }
        for (name, v) in [("exposure_s", self.exposure_s), ("line_delay_s", self.line_delay_s)] {
            if !v.is_finite() || !(0.0..=10.0).contains(&v) {
                return Err(invalid(name, format!("must be in [0, 10] s, got {v}")));
            }
        }
        if self.time_samples > MAX_TIME_SAMPLES {
            return Err(invalid("time_samples", format!("must be in 0..={MAX_TIME_SAMPLES}, got {}", self.time_samples)));
        }
        Ok(())
    }

    /// Whether nothing moves (a camera following a robot moves when the simulator has set its
    /// twist).
    pub fn is_still(&self) -> bool {
        self.twist.iter().chain(&self.target_twist).all(|v| *v == 0.0)
    }

    /// Whether the image changes with time in a way the renderer must sample: something moves
    /// and either the exposure or the line delay is positive.
    pub fn is_active(&self) -> bool {
        !self.is_still() && (self.exposure_s > 0.0 || self.line_delay_s > 0.0)
    }

    /// Whether rows are exposed at different times while something moves.
    pub fn rolling(&self) -> bool {
        !self.is_still() && self.line_delay_s > 0.0
    }

    /// `cam(t)_from_target(t)` given the pose at `t = 0`.
    pub fn cam_from_target_at(&self, cam_from_target: &Isometry3<f64>, t: f64) -> Isometry3<f64> {
        exp_twist(&self.twist, t).inverse() * cam_from_target * exp_twist(&self.target_twist, t)
    }

    /// The centre of the exposure of (continuous) row `row` of an image `height` rows tall.
    pub fn row_time_s(&self, row: f64, height: u32) -> f64 {
        let k = match self.readout {
            Readout::TopDown => row,
            Readout::BottomUp => f64::from(height) - 1.0 - row,
        };
        k * self.line_delay_s
    }

    /// Offsets from a row's exposure centre of `n` stratified time samples (midpoints of `n`
    /// equal parts of the exposure).
    pub fn time_offsets_s(&self, n: u32) -> Vec<f64> {
        let n = n.max(1);
        (0..n).map(|k| ((f64::from(k) + 0.5) / f64::from(n) - 0.5) * self.exposure_s).collect()
    }
}
