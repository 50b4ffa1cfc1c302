//! Lights (`[[light]]`) and the ambient term (`[render] ambient`): Lambertian shading of the
//! target. A surface of albedo `a` (the target's grey levels) whose normal `n` (on the side the
//! camera sees) makes `cos_i = max(0, -n . d_i)` with light i's travel direction `d_i` shows
//!
//! `a (A + sum_i E_i cos_i)`
//!
//! before the sensor model, `A` the ambient term (default 1 when no light is given, 0 otherwise)
//! and `E_i` the light's irradiance in the same units (a light along the normal with `E = 1` and
//! no ambient leaves the target as it was). The background (what rays that miss the target see)
//! is not a surface and stays as given.
//!
//! A planar target under directional lights has one normal, so its shading is one factor per
//! image and exact: the renderer scales the target's grey levels by it ([`shade`]). Targets
//! whose normal varies (a warped board, the S-path's beads) and objects are refused with lights
//! until the shader shades per pixel.
//!
//! Reference: J. Lambert, *Photometria* (1760); any graphics text (e.g. Pharr, Jakob, Humphreys,
//! *Physically Based Rendering*, 4th ed., section 4.3 on irradiance and the cosine law).

use nalgebra::Vector3;

use crate::{Scene, SceneError};

/// At most this many lights per scene (the settings stay `Copy`).
pub const MAX_LIGHTS: usize = 8;

/// The frame a light's direction is given in.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, serde::Deserialize, serde::Serialize)]
#[serde(rename_all = "kebab-case")]
pub enum LightFrame {
    /// The camera's (a light on the camera: its direction moves with it).
    #[default]
    Camera,
    /// The target's (a lamp fixed to the board's world).
    Target,
}

/// One directional light.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct DirectionalLight {
    /// The frame of `direction`.
    pub frame: LightFrame,
    /// The direction the light travels, unit length.
    pub direction: [f64; 3],
    /// Irradiance on a surface facing the light, in the targets' grey-level units (per unit
    /// albedo).
    pub irradiance: f64,
}

/// The lights of a scene and its ambient term.
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct Lighting {
    /// The ambient term `A`; `None`: 1 without lights, 0 with.
    pub ambient: Option<f64>,
    /// Directional lights (`None` entries are unused slots).
    pub lights: [Option<DirectionalLight>; MAX_LIGHTS],
}

impl Lighting {
    /// Whether this lighting leaves every target as it is (no light, ambient 1 or unset).
    pub fn is_neutral(&self) -> bool {
        self.lights.iter().all(Option::is_none) && self.ambient.is_none_or(|a| a == 1.0)
    }

    /// Add a light (at most [`MAX_LIGHTS`]).
    ///
    /// # Errors
    /// [`SceneError::InvalidField`] for a zero or non-finite direction, a negative or non-finite
    /// irradiance, or one light too many.
    pub fn add(&mut self, frame: LightFrame, direction: [f64; 3], irradiance: f64) -> Result<(), SceneError> {
        let d = Vector3::from(direction);
        if !(d.norm() > 0.0) || !d.iter().all(|v| v.is_finite()) {
            return Err(invalid("light.direction", format!("must be a finite, non-zero vector, got {direction:?}")));
        }
        if !(irradiance >= 0.0) || !irradiance.is_finite() {
            return Err(invalid("light.irradiance", format!("must be finite and >= 0, got {irradiance}")));
        }
        let slot = self.lights.iter_mut().find(|l| l.is_none()).ok_or_else(|| invalid("light", format!("at most {MAX_LIGHTS} lights")))?;
        *slot = Some(DirectionalLight { frame, direction: d.normalize().into(), irradiance });
        Ok(())
    }

    /// Check the ambient term and every light.
    ///
    /// # Errors
    /// [`SceneError::InvalidField`] for a negative or non-finite ambient term, a zero or
    /// non-finite direction, or a negative or non-finite irradiance.
    pub fn validate(&self) -> Result<(), SceneError> {
        if let Some(a) = self.ambient.filter(|a| !(*a >= 0.0) || !a.is_finite()) {
            return Err(invalid("render.ambient", format!("must be finite and >= 0, got {a}")));
        }
        for l in self.lights.iter().flatten() {
            let d = Vector3::from(l.direction);
            if !(d.norm() > 0.0) || !d.iter().all(|v| v.is_finite()) || !(l.irradiance >= 0.0) || !l.irradiance.is_finite() {
                return Err(invalid("light", format!("direction {:?} must be finite and non-zero, irradiance {} finite and >= 0", l.direction, l.irradiance)));
            }
        }
        Ok(())
    }

    /// The shading factor `A + sum E_i max(0, -n . d_i)` of a surface whose camera-side normal
    /// is `normal_cam` (camera frame), `cam_from_target` turning target-frame directions.
    pub fn factor(&self, normal_cam: &Vector3<f64>, cam_from_target: &nalgebra::Isometry3<f64>) -> f64 {
        let lit = self.lights.iter().flatten();
        let ambient = self.ambient.unwrap_or(if lit.clone().next().is_some() { 0.0 } else { 1.0 });
        ambient
            + lit
                .map(|l| {
                    // Directions are unit when added; a `[ranges]` draw may change one component.
                    let d = Vector3::from(l.direction).try_normalize(0.0).unwrap_or_default();
                    let d = match l.frame {
                        LightFrame::Camera => d,
                        LightFrame::Target => cam_from_target.rotation * d,
                    };
                    l.irradiance * (-normal_cam.dot(&d)).max(0.0)
                })
                .sum::<f64>()
    }
}

fn invalid(field: &str, reason: String) -> SceneError {
    SceneError::InvalidField { field: field.into(), reason }
}

/// The normal of a planar target's plane on the side the camera sees (camera frame): the
/// target's z axis, turned towards the camera.
pub fn camera_side_normal(scene: &Scene) -> Vector3<f64> {
    let n = scene.cam_from_target.rotation * Vector3::z();
    // The target's origin as seen from the camera: the side the camera looks at faces -origin.
    if n.dot(&scene.cam_from_target.translation.vector) > 0.0 {
        -n
    } else {
        n
    }
}

/// The scene as the renderer draws it: the target's surface grey levels (not its background)
/// scaled by the lighting's factor and the lighting made neutral; the scene itself when its
/// lighting is neutral already.
///
/// # Errors
/// [`SceneError::InvalidField`] for lights on a target or with objects the shading does not
/// cover yet (module documentation).
pub fn shade(scene: &Scene) -> Result<std::borrow::Cow<'_, Scene>, SceneError> {
    let lighting = scene.render.lighting;
    if lighting.is_neutral() {
        return Ok(std::borrow::Cow::Borrowed(scene));
    }
    lighting.validate()?;
    if !scene.target.is_planar() || scene.target.warp().is_some() {
        return Err(invalid("light", "lights shade flat boards only so far (not the S-path or a warped board)".into()));
    }
    if !scene.objects.is_empty() {
        return Err(invalid("light", "objects are not shaded yet: lights take scenes without objects".into()));
    }
    let f = lighting.factor(&camera_side_normal(scene), &scene.cam_from_target);
    let t = &scene.target;
    let [dark, light, margin] = surface_greys(t);
    let target = t.with_greys([dark * f, light * f, margin * f, t.background()]);
    let render = crate::RenderSettings { lighting: Lighting::default(), ..scene.render };
    Ok(std::borrow::Cow::Owned(Scene { target, render, ..scene.clone() }))
}

/// A target's surface grey levels `[dark, light, margin]` (as [`synthcam_core::target::Target::with_greys`] takes them).
fn surface_greys(t: &synthcam_core::target::Target) -> [f64; 3] {
    use synthcam_core::target::Target;
    match t {
        Target::Chessboard(b) => [b.dark, b.light, b.margin],
        Target::DotGrid(g) => [g.dark, g.light, g.light],
        Target::SPath(s) => [s.dark, s.light, s.light],
        Target::Charuco(c) => [c.look.dark, c.look.light, c.look.margin],
        Target::AprilGrid(g) => [g.look.dark, g.look.light, g.look.margin],
    }
}
