//! The scene conditions of the robustness experiment (issue 41's realistic scenes): a lamp's
//! gradient across the board, a glossy board's highlight over its corners, and a cluttered room
//! behind it. Each level sets one parameter; the strength reported is measured on the scene's
//! truth (module docs of [`super`]).

use std::sync::Arc;

use nalgebra::{UnitQuaternion, Vector3};
use synthcam_scene::background::{clutter, Background};
use synthcam_scene::lighting::{camera_side_normal, Gloss, LightFrame, Lighting};
use synthcam_scene::{Scene, TruthLabels};

use super::centre_cam;

/// [`super::Effect::Gradient`]'s ambient term: the lamp's light is added to it.
pub const GRADIENT_AMBIENT: f64 = 0.25;

/// A desk lamp 0.15 m beside the board's left edge and 0.2 m in front of it (target frame, at
/// the middle of its height), of intensity `level` (irradiance at 1 m), over an ambient of
/// [`GRADIENT_AMBIENT`]: bright near the lamp, dim across the board.
pub fn gradient(base: &Scene, level: f64) -> Scene {
    let mut s = base.clone();
    let mut lighting = Lighting { ambient: Some(GRADIENT_AMBIENT), ..Default::default() };
    let [x0, y0, _, y1] = base.target.extent_m().unwrap_or([0.0; 4]);
    if level > 0.0 {
        // Positions and intensities here are finite and the intensity positive: `add_point` accepts them.
        let _ = lighting.add_point(LightFrame::Target, [x0 - 0.15, 0.5 * (y0 + y1), 0.2 * camera_side_in_target(base)], level);
    }
    s.render.lighting = lighting;
    s
}

/// The side of the target's plane the camera is on, as the sign of target z (+1 or -1).
fn camera_side_in_target(scene: &Scene) -> f64 {
    let n_t = scene.cam_from_target.rotation.inverse() * camera_side_normal(scene);
    n_t.z.signum()
}

/// [`super::Effect::Highlight`]'s lamp distance from the board centre, metres: far enough that its
/// diffuse light is small beside its highlight.
pub const HIGHLIGHT_LAMP_M: f64 = 3.0;

/// A laminated board (GGX, `F0` 0.05, roughness 0.25) under a lamp of intensity `level` placed
/// where the camera's view of the board centre reflects ([`HIGHLIGHT_LAMP_M`] away): the
/// highlight lies on the board's centre; ambient 1 (the board as given plus the lamp).
pub fn highlight(base: &Scene, level: f64) -> Scene {
    let mut s = base.clone();
    let c = centre_cam(base).coords;
    let n = camera_side_normal(base);
    let v = -c.normalize();
    let r = 2.0 * n.dot(&v) * n - v;
    let lamp = c + HIGHLIGHT_LAMP_M * r;
    let mut lighting = Lighting { ambient: Some(1.0), gloss: Some(Gloss { specular: 0.05, roughness: 0.25 }), ..Default::default() };
    if level > 0.0 {
        // A finite position and a positive intensity: `add_point` accepts them.
        let _ = lighting.add_point(LightFrame::Camera, [lamp.x, lamp.y, lamp.z], level);
    }
    s.render.lighting = lighting;
    s
}

/// Texels of [`super::Effect::Clutter`]'s panorama (per axis).
pub const CLUTTER_TEXELS: [u32; 2] = [4096, 2048];

/// A cluttered room behind the board: a procedural clutter panorama (seed `seed`, centred ahead)
/// whose contrast about the target's background grey is `level` (0: a uniform grey, 1: the
/// clutter as drawn).
pub fn cluttered(base: &Scene, level: f64, seed: u64) -> Scene {
    let mut s = base.clone();
    let g = base.target.background() as f32;
    let mut t = clutter(seed, CLUTTER_TEXELS[0], CLUTTER_TEXELS[1]);
    t.texels.iter_mut().for_each(|v| *v = (g + level as f32 * (*v - g)).clamp(0.0, 255.0));
    s.background = Some(Background::panorama(Arc::new(t), UnitQuaternion::identity()));
    s
}

/// [`super::Effect::Shadow`]'s light: the angle at which it grazes the board, degrees.
pub const SHADOW_GRAZING_DEG: f64 = 20.0;

/// A bar (2 x 60 x 2 cm, grey 80) 0.2 m left of the board's sheet and 0.15 m in front of it,
/// along the board's y axis, under a light from the left grazing the board at
/// [`SHADOW_GRAZING_DEG`]: its
/// shadow is a band about a square wide across the board's columns 4 and 5, over their corners.
/// `level` is the shadow's contrast, lit over shadowed shading (1: no shadow), the lit shading
/// kept at 1: ambient `1 / level`, the light the rest.
pub fn shadowed(base: &Scene, level: f64) -> Scene {
    let mut s = base.clone();
    let [x0, y0, _, y1] = base.target.extent_m().unwrap_or([0.0; 4]);
    let camera_side = camera_side_in_target(base);
    let bar =
        synthcam_core::mesh::primitives::textured_box([0.02, 0.6, 0.02], Arc::new(synthcam_core::mesh::Texture { width: 1, height: 1, texels: vec![80.0] }));
    // The bar's mesh is valid by construction (a closed box): `MeshAsset::new` accepts it.
    if let Ok(asset) = synthcam_scene::objects::MeshAsset::new(bar) {
        let target_from_bar = nalgebra::Isometry3::translation(x0 - 0.2, 0.5 * (y0 + y1), 0.15 * camera_side);
        s.objects = vec![synthcam_scene::objects::SceneObject::new(asset, base.cam_from_target * target_from_bar)];
    }
    let contrast = level.max(1.0);
    let (sin, cos) = SHADOW_GRAZING_DEG.to_radians().sin_cos();
    // Along the board's x, into it (away from the camera's side).
    let travel = Vector3::new(cos, 0.0, -camera_side * sin);
    let mut lighting = Lighting { ambient: Some(1.0 / contrast), ..Default::default() };
    // A unit direction and a finite irradiance >= 0: `add` accepts them.
    let _ = lighting.add(LightFrame::Target, travel.into(), (1.0 - 1.0 / contrast) / sin);
    s.render.lighting = lighting;
    s
}

/// The strength of a condition in `scene`: the gradient's ratio of the brightest to the dimmest
/// corner's irradiance, the highlight's largest specular grey level at a corner, or the clutter's
/// or the shadow's contrast (`level`).
pub fn condition_strength(truth: &TruthLabels, kind: Condition, level: f64) -> f64 {
    let values = |f: fn(&synthcam_scene::truth::FeatureLabel) -> Option<f64>| truth.features.iter().filter_map(f).collect::<Vec<f64>>();
    match kind {
        Condition::Gradient => {
            let e = values(|f| f.irradiance);
            let (lo, hi) = e.iter().fold((f64::INFINITY, 0.0f64), |(lo, hi), v| (lo.min(*v), hi.max(*v)));
            if lo > 0.0 && lo.is_finite() {
                hi / lo
            } else {
                1.0
            }
        }
        Condition::Highlight => values(|f| f.specular).into_iter().fold(0.0, f64::max),
        Condition::Clutter | Condition::Shadow => level,
    }
}

/// The three scene conditions.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Condition {
    /// [`gradient`].
    Gradient,
    /// [`highlight`].
    Highlight,
    /// [`cluttered`].
    Clutter,
    /// [`shadowed`].
    Shadow,
}
