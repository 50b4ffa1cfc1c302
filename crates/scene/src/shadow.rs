//! Hard shadows: the user's objects (meshes) shadow the target from a directional light.
//!
//! With objects in a scene, one directional light may be given (no point light, no gloss yet):
//! a board point `x` whose ray towards the light (`x + s l`, `s > 0`, `l` against the light's
//! travel) meets an object gets only the ambient term, `a A` instead of `a (A + E cos)`; the
//! objects keep their own shading ([`crate::objects::Shading`]) and do not shadow each other.
//! The renderer draws a shadowed board pixel as the lit one times [`ShadowLight::ratio`] and
//! integrates the pixels a shadow's edge crosses exactly along scan lines (the objects' fine pass,
//! `shaders/objects.wgsl`); a feature's truth says whether it lies in shadow.
//!
//! Reference: hard shadows by shadow rays, T. Whitted, *An improved illumination model for
//! shaded display* (CACM 1980).

use nalgebra::{Point3, Vector3};

use crate::lighting::{camera_side_normal, direction_in_camera};
use crate::Scene;

/// The light that casts the objects' shadows on the target.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct ShadowLight {
    /// Unit direction towards the light, camera frame.
    pub toward_light_cam: Vector3<f64>,
    /// Shadowed over lit shading of the target: `A / (A + E cos)` (0 without ambient light).
    pub ratio: f64,
}

/// The scene's shadow light: its one directional light when it has objects and the light
/// reaches the side of the board the camera sees; `None` otherwise (no shadow to draw).
pub fn shadow_light(scene: &Scene) -> Option<ShadowLight> {
    let lighting = &scene.render.lighting;
    let mut lights = lighting.lights.iter().flatten();
    let (Some(light), None) = (lights.next(), lights.next()) else { return None };
    if scene.objects.is_empty() {
        return None;
    }
    let n = camera_side_normal(scene);
    let d = direction_in_camera(light, &scene.cam_from_target);
    let lit = lighting.factor(&n, &scene.cam_from_target);
    (lit > 0.0 && -n.dot(&d) > 0.0).then(|| ShadowLight { toward_light_cam: -d, ratio: lighting.ambient_term() / lit })
}

/// Whether the point `p_cam` (camera frame) lies in an object's shadow of `light`.
pub fn in_shadow(scene: &Scene, light: &ShadowLight, p_cam: &Point3<f64>) -> bool {
    scene.objects.iter().any(|o| {
        let (origin, dir) = o.ray_in_object_from(p_cam, &light.toward_light_cam);
        o.asset.bvh.cast(&o.asset.mesh, &origin, &dir, 1e-9, f64::INFINITY).is_some()
    })
}
