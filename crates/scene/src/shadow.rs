//! Shadows: the user's objects (meshes) shadow the target from a directional light (hard
//! shadows) or an area light (soft shadows).
//!
//! With objects in a scene, one directional light or one area light may be given (and the
//! ambient term; no point light, no gloss yet). A board point `x` whose ray towards the
//! directional light (`x + s l`, `s > 0`, `l` against the light's travel) meets an object gets
//! only the ambient term, `a A` instead of `a (A + E cos)`. Under an area light `x` gets
//! `a (A + E V)`, `E` the light's closed-form term ([`crate::area_light`]) and `V` the visible
//! share of the emitter, weighted by `cos_x cos_light / r^2` ([`visible_share`]).
//!
//! Objects shaded [`Shading::Lit`] take the same light: `a (A + E max(0, n . l))` at a surface
//! point of normal `n` (the side the camera sees), `a A` where an object, itself included, meets
//! the point's ray towards the directional light ([`ObjectLight`]): objects shadow each other and
//! themselves. Under an area light they are refused so far (unlit and head-lit objects keep
//! their own shading under any light).
//!
//! The renderer draws a shadowed board pixel as the lit one times the ratio of the two shadings
//! and integrates the pixels a hard shadow's edge crosses exactly along scan lines (the objects'
//! fine pass, `shaders/objects.wgsl`); a soft shadow's share is integrated over the emitter row
//! by row, each row's hidden part in closed form (the intervals of the row that the triangles
//! cut by the plane through the point and the row hide from it), on a lattice of image points
//! whose cells the pixels interpolate where the lattice's second differences allow, per pixel
//! elsewhere (the render crate's `soft_lattice`); a point whose shaft to the emitter meets no
//! object's triangle sees all of it. A feature's truth says whether it lies in
//! shadow (for an area light: whether any of the light is hidden from it).
//!
//! Reference: hard shadows by shadow rays, T. Whitted, *An improved illumination model for
//! shaded display* (CACM 1980); soft shadows as the visibility-weighted irradiance integral over
//! the emitter, R. Cook, T. Porter, L. Carpenter, *Distributed ray tracing* (SIGGRAPH 1984).

use nalgebra::{Point3, Vector3};

use crate::area_light::Rectangle;
use crate::lighting::{camera_side_normal, direction_in_camera};
use crate::objects::{ObjectHit, SceneObject, Shading};
use crate::Scene;

/// The light that casts the objects' shadows on the target.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum ShadowLight {
    /// The directional light.
    Sun {
        /// Unit direction towards the light, camera frame.
        toward_light_cam: Vector3<f64>,
        /// Shadowed over lit shading of the target: `A / (A + E cos)` (0 without ambient light).
        ratio: f64,
    },
    /// The area light.
    Area {
        /// Its rectangle, camera frame.
        rect: Rectangle,
        /// Its radiance.
        radiance: f64,
        /// The ambient term `A`.
        ambient: f64,
    },
}

/// The scene's shadow light: with objects, its one directional light when the light reaches the
/// side of the board the camera sees, or its area light; `None` otherwise (no shadow to draw).
pub fn shadow_light(scene: &Scene) -> Option<ShadowLight> {
    let lighting = &scene.render.lighting;
    if scene.objects.is_empty() {
        return None;
    }
    if let Some(area) = lighting.area {
        let rect = area.rectangle_in_camera(&scene.cam_from_target);
        return Some(ShadowLight::Area { rect, radiance: area.radiance(), ambient: lighting.ambient_term() });
    }
    let mut lights = lighting.lights.iter().flatten();
    let (Some(light), None) = (lights.next(), lights.next()) else { return None };
    let n = camera_side_normal(scene);
    let d = direction_in_camera(light, &scene.cam_from_target);
    let lit = lighting.factor(&n, &scene.cam_from_target);
    (lit > 0.0 && -n.dot(&d) > 0.0).then(|| ShadowLight::Sun { toward_light_cam: -d, ratio: lighting.ambient_term() / lit })
}

/// Emitter rows and columns [`ShadowLight::irradiance_at`] samples the area light with (its
/// visible share to about 1 / 64 of the penumbra's depth: truth labels, not pixels).
pub const TRUTH_SAMPLES: usize = 32;

impl ShadowLight {
    /// The target's irradiance factor at `p_cam` (camera frame) with the objects' shadow, given
    /// the unshadowed factor `lit`, and whether the objects shadow the point (any of an area
    /// light hidden).
    pub fn irradiance_at(&self, scene: &Scene, lit: f64, p_cam: &Point3<f64>) -> (f64, bool) {
        match self {
            ShadowLight::Sun { toward_light_cam, ratio } => {
                let dark = blocked(&scene.objects, p_cam, toward_light_cam, f64::INFINITY);
                (if dark { lit * ratio } else { lit }, dark)
            }
            ShadowLight::Area { rect, radiance, .. } => {
                let n = camera_side_normal(scene);
                let v = visible_share(scene, rect, p_cam, &n, TRUTH_SAMPLES);
                let e = radiance * rect.projected_solid_angle(p_cam, &n);
                (lit - e * (1.0 - v), v < 1.0)
            }
        }
    }
}

/// Whether the segment `p_cam + s d_cam`, `0 < s < s_max`, meets an object.
fn blocked(objects: &[SceneObject], p_cam: &Point3<f64>, d_cam: &Vector3<f64>, s_max: f64) -> bool {
    objects.iter().any(|o| {
        let (origin, dir) = o.ray_in_object_from(p_cam, d_cam);
        o.asset.bvh.cast(&o.asset.mesh, &origin, &dir, 1e-9, s_max).is_some()
    })
}

/// The share of the area light `rect` that the objects leave visible from `x` (normal `n`),
/// weighted by `cos_x cos_light / r^2`: the midpoint rule on `samples^2` cells of the emitter,
/// each visible or not by a shadow ray to its centre; 1 where no part of it shines on `x`.
pub fn visible_share(scene: &Scene, rect: &Rectangle, x: &Point3<f64>, n: &Vector3<f64>, samples: usize) -> f64 {
    let (mut seen, mut all) = (0.0, 0.0);
    for i in 0..samples {
        for j in 0..samples {
            let p = rect.at((i as f64 + 0.5) / samples as f64, (j as f64 + 0.5) / samples as f64);
            let w = rect.weight(x, n, &p);
            if w > 0.0 {
                all += w;
                if !blocked(&scene.objects, x, &(p - x), 1.0) {
                    seen += w;
                }
            }
        }
    }
    if all > 0.0 {
        seen / all
    } else {
        1.0
    }
}

/// Whether the point `p_cam` (camera frame) lies in an object's shadow of `light` (for an area
/// light: whether any of it is hidden).
pub fn in_shadow(scene: &Scene, light: &ShadowLight, p_cam: &Point3<f64>) -> bool {
    light.irradiance_at(scene, 1.0, p_cam).1
}

/// Where a lit object's shadow ray starts: its surface point `t d_cam` moved back along the camera
/// ray to `SHADOW_RAY_START t d_cam`, off the surface on the side the camera sees (the side the
/// light reaches when `n . l > 0`), so that the ray does not meet its own face; the shader's rays
/// start there too (`shaders/objects.wgsl` `sun_on`).
pub const SHADOW_RAY_START: f64 = 1.0 - 1e-4;

/// The light on [`Shading::Lit`] objects: the ambient term and the directional light, from the
/// scene as given (before [`crate::lighting::shade`] folds the target's light into its greys).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct ObjectLight {
    /// The ambient term `A`.
    pub ambient: f64,
    /// The directional light: the unit direction towards it (camera frame) and its irradiance `E`.
    pub sun: Option<(Vector3<f64>, f64)>,
}

impl ObjectLight {
    /// The light `scene` sheds on its lit objects (with objects a scene has one directional light
    /// at most: [`crate::lighting::check_with_objects`]).
    pub fn of(scene: &Scene) -> Self {
        let lighting = &scene.render.lighting;
        let sun = lighting.lights.iter().flatten().next().map(|l| (-direction_in_camera(l, &scene.cam_from_target), l.irradiance));
        Self { ambient: lighting.ambient_term(), sun }
    }

    /// The factor `A + E max(0, n . l)` at the surface point `p_cam` of normal `n_seen` (unit,
    /// the side seen), `A` where one of `objects` meets the shadow ray ([`SHADOW_RAY_START`]).
    pub fn factor(&self, objects: &[SceneObject], p_cam: &Point3<f64>, n_seen: &Vector3<f64>) -> f64 {
        let Some((toward, e)) = self.sun else { return self.ambient };
        let cos = n_seen.dot(&toward);
        if cos <= 0.0 || blocked(objects, &(p_cam * SHADOW_RAY_START), &toward, f64::INFINITY) {
            self.ambient
        } else {
            self.ambient + e * cos
        }
    }

    /// The grey level the object hit `h` shows along `d_cam` (camera frame), among `objects`.
    pub fn object_value(&self, objects: &[SceneObject], h: &ObjectHit, d_cam: &Vector3<f64>) -> f64 {
        let o = &objects[h.object];
        let lit = if o.shading == Shading::Lit { self.factor(objects, &Point3::from(d_cam * h.hit.t), &o.seen_normal(&h.hit, d_cam)) } else { 1.0 };
        o.shade(&h.hit, d_cam, lit)
    }
}
