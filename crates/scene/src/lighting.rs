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
//! A point light at `L` with intensity `I` adds `I max(0, -n . u) / r^2` at a surface point `X`,
//! `r = |X - L|`, `u = (X - L) / r` (the inverse-square law: `I` is the irradiance at 1 m on a
//! surface facing the light).
//!
//! A planar target under directional lights has one normal, so its shading is one factor per
//! image and exact: the renderer scales the target's grey levels by it ([`shade`]). A point light
//! varies over the board: the shader evaluates the factor at each pixel's board point (at the
//! pixel centre's ray for closed-form edge coverage, at every sample where it supersamples), so
//! a pixel's value is exact to the factor's variation across one pixel (second order: below
//! 1e-3 grey levels for a lamp 0.1 m or more from the board). Targets whose normal varies (a
//! warped board, the S-path's beads) are refused with lights until the shader shades them; with
//! objects, one directional light, whose shadows they cast on the board ([`crate::shadow`]).
//!
//! Reference: J. Lambert, *Photometria* (1760); any graphics text (e.g. Pharr, Jakob, Humphreys,
//! *Physically Based Rendering*, 4th ed., section 4.3 on irradiance and the cosine law).

use nalgebra::Vector3;

use crate::area_light::AreaLight;
pub use crate::gloss::Gloss;
use crate::{Scene, SceneError};

/// At most this many directional lights per scene (the settings stay `Copy`).
pub const MAX_LIGHTS: usize = 8;

/// At most this many point lights (the shader's uniforms hold one).
pub const MAX_POINT_LIGHTS: usize = 1;

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

/// One point light.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct PointLight {
    /// The frame of `position_m`.
    pub frame: LightFrame,
    /// Its position, metres.
    pub position_m: [f64; 3],
    /// Irradiance at 1 m on a surface facing it, grey levels per unit albedo.
    pub intensity: f64,
}

/// The lights of a scene and its ambient term.
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct Lighting {
    /// The target's glossy coating (`[render] specular`, `roughness`); it reflects point lights.
    pub gloss: Option<Gloss>,
    /// The ambient term `A`; `None`: 1 without lights, 0 with.
    pub ambient: Option<f64>,
    /// Directional lights (`None` entries are unused slots).
    pub lights: [Option<DirectionalLight>; MAX_LIGHTS],
    /// Point lights.
    pub points: [Option<PointLight>; MAX_POINT_LIGHTS],
    /// A rectangular area light (soft light and soft shadows: [`crate::area_light`]); the
    /// shader's lamp uniforms hold it or the point light, not both.
    pub area: Option<AreaLight>,
}

impl Lighting {
    /// Whether this lighting leaves every target as it is (no light, ambient 1 or unset).
    pub fn is_neutral(&self) -> bool {
        !self.any_light() && self.ambient.is_none_or(|a| a == 1.0)
    }

    /// The specular grey level the point lights add at `p_cam` (camera frame; the camera at the
    /// origin), normal `normal_cam`; 0 without gloss.
    pub fn specular_at(&self, p_cam: &Vector3<f64>, normal_cam: &Vector3<f64>, cam_from_target: &nalgebra::Isometry3<f64>) -> f64 {
        let Some(g) = self.gloss else { return 0.0 };
        let v = -p_cam.normalize();
        self.points
            .iter()
            .flatten()
            .map(|lamp| {
                let to_l = Self::point_in_camera(lamp, cam_from_target) - p_cam;
                let r2 = to_l.norm_squared();
                g.grey_per_irradiance(normal_cam, &to_l.normalize(), &v) * lamp.intensity / r2.max(f64::MIN_POSITIVE)
            })
            .sum()
    }

    /// The ambient term `A` in effect: as given, else 1 without lights and 0 with.
    pub fn ambient_term(&self) -> f64 {
        self.ambient.unwrap_or(if self.any_light() { 0.0 } else { 1.0 })
    }

    fn any_light(&self) -> bool {
        self.lights.iter().any(Option::is_some) || self.varies()
    }

    /// Whether the shading varies over a flat board (a point or an area light).
    pub fn varies(&self) -> bool {
        self.points.iter().any(Option::is_some) || self.area.is_some()
    }

    /// Add a point light (at most [`MAX_POINT_LIGHTS`]).
    ///
    /// # Errors
    /// [`SceneError::InvalidField`] for a non-finite position, a negative or non-finite
    /// intensity, or one light too many.
    pub fn add_point(&mut self, frame: LightFrame, position_m: [f64; 3], intensity: f64) -> Result<(), SceneError> {
        check_point(position_m, intensity)?;
        let slot = self.points.iter_mut().find(|l| l.is_none()).ok_or_else(|| invalid("light", format!("at most {MAX_POINT_LIGHTS} point light so far")))?;
        *slot = Some(PointLight { frame, position_m, intensity });
        Ok(())
    }

    /// A point light's position in the camera frame.
    pub fn point_in_camera(l: &PointLight, cam_from_target: &nalgebra::Isometry3<f64>) -> Vector3<f64> {
        match l.frame {
            LightFrame::Camera => Vector3::from(l.position_m),
            LightFrame::Target => (cam_from_target * nalgebra::Point3::from(l.position_m)).coords,
        }
    }

    /// The irradiance factor at the surface point `p_cam` (camera frame) with camera-side normal
    /// `normal_cam`: [`Lighting::factor`] plus every point light's inverse-square term and the
    /// area light's ([`Lighting::area_term`]).
    pub fn irradiance_at(&self, p_cam: &Vector3<f64>, normal_cam: &Vector3<f64>, cam_from_target: &nalgebra::Isometry3<f64>) -> f64 {
        self.factor(normal_cam, cam_from_target)
            + self.area_term(p_cam, normal_cam, cam_from_target)
            + self
                .points
                .iter()
                .flatten()
                .map(|l| {
                    let d = p_cam - Self::point_in_camera(l, cam_from_target);
                    let r = d.norm();
                    if r > 0.0 {
                        l.intensity * (-normal_cam.dot(&d)).max(0.0) / (r * r * r)
                    } else {
                        0.0
                    }
                })
                .sum::<f64>()
    }

    /// The area light's irradiance at `p_cam` (camera frame), normal `normal_cam` (Lambert's
    /// polygon formula, [`crate::area_light`]); 0 without one.
    pub fn area_term(&self, p_cam: &Vector3<f64>, normal_cam: &Vector3<f64>, cam_from_target: &nalgebra::Isometry3<f64>) -> f64 {
        self.area.map_or(0.0, |a| a.radiance() * a.rectangle_in_camera(cam_from_target).projected_solid_angle(&(*p_cam).into(), normal_cam))
    }

    /// Add a light (at most [`MAX_LIGHTS`]).
    ///
    /// # Errors
    /// [`SceneError::InvalidField`] for a zero or non-finite direction, a negative or non-finite
    /// irradiance, or one light too many.
    pub fn add(&mut self, frame: LightFrame, direction: [f64; 3], irradiance: f64) -> Result<(), SceneError> {
        check_directional(direction, irradiance)?;
        let slot = self.lights.iter_mut().find(|l| l.is_none()).ok_or_else(|| invalid("light", format!("at most {MAX_LIGHTS} lights")))?;
        *slot = Some(DirectionalLight { frame, direction: Vector3::from(direction).normalize().into(), irradiance });
        Ok(())
    }

    /// Check the ambient term and every light.
    ///
    /// # Errors
    /// [`SceneError::InvalidField`] for a negative or non-finite ambient term, a zero or
    /// non-finite direction, or a negative or non-finite irradiance.
    pub fn validate(&self) -> Result<(), SceneError> {
        if let Some(g) = self.gloss {
            if !((0.0..=1.0).contains(&g.specular) && g.roughness > 0.0 && g.roughness <= 1.0) {
                return Err(invalid("render.specular", format!("specular must be in [0, 1] and roughness in (0, 1], got {} and {}", g.specular, g.roughness)));
            }
        }
        if let Some(a) = self.ambient.filter(|a| !(*a >= 0.0) || !a.is_finite()) {
            return Err(invalid("render.ambient", format!("must be finite and >= 0, got {a}")));
        }
        for p in self.points.iter().flatten() {
            check_point(p.position_m, p.intensity)?;
        }
        if let Some(a) = self.area {
            a.validate()?;
            if self.points.iter().any(Option::is_some) || self.gloss.is_some() {
                return Err(invalid(
                    "light",
                    "an area light takes no point light and no gloss beside it (one lamp in the shader; the coating reflects point lights only)".into(),
                ));
            }
        }
        for l in self.lights.iter().flatten() {
            check_directional(l.direction, l.irradiance)?;
        }
        Ok(())
    }

    /// The shading factor `A + sum E_i max(0, -n . d_i)` (directional lights and ambient; point
    /// lights: [`Lighting::irradiance_at`]) of a surface whose camera-side normal
    /// is `normal_cam` (camera frame), `cam_from_target` turning target-frame directions.
    pub fn factor(&self, normal_cam: &Vector3<f64>, cam_from_target: &nalgebra::Isometry3<f64>) -> f64 {
        let lit = self.lights.iter().flatten();
        self.ambient_term()
            + lit
                .map(|l| {
                    let d = direction_in_camera(l, cam_from_target);
                    l.irradiance * (-normal_cam.dot(&d)).max(0.0)
                })
                .sum::<f64>()
    }
}

/// A directional light's values: a finite, non-zero direction and a finite irradiance >= 0.
fn check_directional(direction: [f64; 3], irradiance: f64) -> Result<(), SceneError> {
    let d = Vector3::from(direction);
    if !(d.norm() > 0.0) || !d.iter().all(|v| v.is_finite()) {
        return Err(invalid("light.direction", format!("must be a finite, non-zero vector, got {direction:?}")));
    }
    if !(irradiance >= 0.0) || !irradiance.is_finite() {
        return Err(invalid("light.irradiance", format!("must be finite and >= 0, got {irradiance}")));
    }
    Ok(())
}

/// A point light's values: a finite position and a finite intensity >= 0.
fn check_point(position_m: [f64; 3], intensity: f64) -> Result<(), SceneError> {
    if !position_m.iter().all(|v| v.is_finite()) {
        return Err(invalid("light.position_m", format!("must be finite, got {position_m:?}")));
    }
    if !(intensity >= 0.0) || !intensity.is_finite() {
        return Err(invalid("light.intensity", format!("must be finite and >= 0, got {intensity}")));
    }
    Ok(())
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

/// Check a scene's lighting: its values ([`Lighting::validate`]), and lights only on what the
/// shading covers (module documentation). Part of [`Scene::validate`].
///
/// # Errors
/// [`SceneError::InvalidField`] naming the light or value.
pub fn check(scene: &Scene) -> Result<(), SceneError> {
    let lighting = scene.render.lighting;
    if lighting.is_neutral() {
        return Ok(());
    }
    lighting.validate()?;
    if !scene.target.is_planar() || scene.target.warp().is_some() {
        return Err(invalid("light", "lights shade flat boards only so far (not the S-path or a warped board)".into()));
    }
    if scene.objects.is_empty() {
        return Ok(());
    }
    check_with_objects(&lighting)?;
    if lighting.area.is_some() && scene.objects.iter().any(|o| o.shading == crate::objects::Shading::Lit) {
        return Err(invalid(
            "light",
            "lit objects (shading = \"lit\") take a directional light so far; under an area light give them \"unlit\" or \"head-light\"".into(),
        ));
    }
    Ok(())
}

/// The lighting a scene with objects takes so far: one directional light or one area light
/// (whose shadows the objects cast: [`crate::shadow`]) and the ambient term.
///
/// # Errors
/// [`SceneError::InvalidField`] (`light`) for a point light, gloss or more lights.
pub fn check_with_objects(lighting: &Lighting) -> Result<(), SceneError> {
    let lamps = lighting.lights.iter().flatten().count() + usize::from(lighting.area.is_some());
    if lighting.points.iter().any(Option::is_some) || lighting.gloss.is_some() || lamps > 1 {
        return Err(invalid(
            "light",
            "with objects, one directional or area light (its shadows: scene::shadow) and the ambient term so far; point lights, gloss and more lights take scenes without objects".into(),
        ));
    }
    Ok(())
}

/// The direction light `l` travels, unit, in the camera frame.
pub fn direction_in_camera(l: &DirectionalLight, cam_from_target: &nalgebra::Isometry3<f64>) -> Vector3<f64> {
    // Directions are unit when added; a `[ranges]` draw may change one component.
    let d = Vector3::from(l.direction).try_normalize(0.0).unwrap_or_default();
    match l.frame {
        LightFrame::Camera => d,
        LightFrame::Target => cam_from_target.rotation * d,
    }
}

/// The scene as the renderer draws it: the target's surface grey levels (not its background)
/// scaled by the lighting's factor and the lighting made neutral; the scene itself when its
/// lighting is neutral already, or varies over the board (a point light: the shader shades).
///
/// # Errors
/// [`SceneError::InvalidField`] for lights on a target or with objects the shading does not
/// cover yet (module documentation).
pub fn shade(scene: &Scene) -> Result<std::borrow::Cow<'_, Scene>, SceneError> {
    check(scene)?;
    let lighting = scene.render.lighting;
    if lighting.is_neutral() || lighting.varies() {
        return Ok(std::borrow::Cow::Borrowed(scene));
    }
    let f = lighting.factor(&camera_side_normal(scene), &scene.cam_from_target);
    let [dark, light, margin, background] = scene.target.greys();
    let target = scene.target.with_greys([dark * f, light * f, margin * f, background]);
    let render = crate::RenderSettings { lighting: Lighting::default(), ..scene.render };
    Ok(std::borrow::Cow::Owned(Scene { target, render, ..scene.clone() }))
}

#[cfg(test)]
mod tests {
    use super::*;

    /// No light and no ambient given leaves every surface as it is; a point light behind the
    /// board adds nothing; the highlight of a coating is zero where the camera or the light is
    /// behind the surface.
    #[test]
    fn neutral_and_hidden_lights_add_nothing() {
        let id = nalgebra::Isometry3::identity();
        let n = Vector3::new(0.0, 0.0, -1.0);
        assert_eq!(Lighting::default().factor(&n, &id), 1.0);
        let mut l = Lighting { ambient: Some(0.25), ..Default::default() };
        l.add_point(LightFrame::Camera, [0.0, 0.0, 2.0], 1.0).expect("lamp");
        assert_eq!(l.irradiance_at(&Vector3::new(0.0, 0.0, 1.0), &n, &id), 0.25);
        let g = Gloss { specular: 0.04, roughness: 0.3 };
        let v = Vector3::new(0.0, 0.0, -1.0);
        assert_eq!(g.grey_per_irradiance(&n, &Vector3::new(0.0, 0.0, 1.0), &v), 0.0);
        assert!(g.grey_per_irradiance(&n, &v, &v) > 0.0);
    }
}
