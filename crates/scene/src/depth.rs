//! Per-pixel depth and instance masks: exact f64 ray casts through each pixel centre (the
//! camera model's exact inverse, [`synthcam_core::camera::CameraModel::unproject_ray`]).
//!
//! Depth is the camera-frame z of the first surface the centre ray meets (the target's sheet or
//! an object), metres, as OpenCV, ROS and BlenderProc write depth images; `NaN` where the ray
//! meets nothing (or cannot be unprojected). The instance id is 0 for nothing, 1 for the target
//! and `2 + i` for object `i` of [`super::Scene::objects`]; a background ([`crate::background`])
//! is [`BACKGROUND_ID`] where its image is seen, at the plane's depth or, for a panorama, at
//! infinity.

use nalgebra::{Point2, Vector3};
use rayon::prelude::*;

use super::objects::cast_objects;
use super::Scene;
use synthcam_core::target::Target;

/// Instance id of the target in masks.
pub const TARGET_ID: u16 = 1;
/// Instance id of object 0 (object `i` is `FIRST_OBJECT_ID + i`).
pub const FIRST_OBJECT_ID: u16 = 2;
/// Instance id of the background's image (the last id, so objects keep theirs).
pub const BACKGROUND_ID: u16 = u16::MAX;

/// Depth and instance id of every pixel, row-major.
#[derive(Debug, Clone, PartialEq)]
pub struct DepthMask {
    /// Width, pixels.
    pub width: u32,
    /// Height, pixels.
    pub height: u32,
    /// Camera-frame z of the first surface, metres (`NaN`: none).
    pub depth_m: Vec<f32>,
    /// 0 nothing, [`TARGET_ID`], or [`FIRST_OBJECT_ID`] + object index.
    pub instance: Vec<u16>,
}

/// The ray parameter at which `t d_cam` meets the target's sheet (planar targets) or the
/// S-path's sphere (its beads are not included), if it does.
fn target_t(scene: &Scene, d_cam: &Vector3<f64>) -> Option<f64> {
    match &scene.target {
        Target::SPath(s) => {
            let sphere = super::trace::SphereCam { centre: scene.cam_from_target * s.path.sphere_center_m, radius: s.path.sphere_radius_m };
            let n = d_cam.norm();
            sphere.intersect(&(d_cam / n)).map(|t| t / n)
        }
        target => {
            let inv = scene.cam_from_target.inverse();
            let (o, d) = (inv.translation.vector, inv.rotation * d_cam);
            let t = -o.z / d.z;
            (t > 0.0 && t.is_finite() && target.on_sheet(o.x + t * d.x, o.y + t * d.y)).then_some(t)
        }
    }
}

/// The depth (camera z, metres) and instance id seen along the ray `d_cam`.
pub fn depth_along(scene: &Scene, d_cam: &Vector3<f64>) -> (f64, u16) {
    let t_target = target_t(scene, d_cam);
    match cast_objects(&scene.objects, d_cam, t_target.unwrap_or(f64::INFINITY)) {
        Some(h) => (h.hit.t * d_cam.z, FIRST_OBJECT_ID + h.object as u16),
        None => match t_target {
            Some(t) => (t * d_cam.z, TARGET_ID),
            None => scene.background.as_ref().and_then(|b| b.depth_along(d_cam)).map_or((f64::NAN, 0), |z| (z, BACKGROUND_ID)),
        },
    }
}

/// Depth and instance id at every pixel centre of `scene` (in parallel over rows).
pub fn depth_mask(scene: &Scene) -> DepthMask {
    let (w, h) = (scene.camera.size.width, scene.camera.size.height);
    let rows: Vec<(Vec<f32>, Vec<u16>)> = (0..h)
        .into_par_iter()
        .map(|y| {
            (0..w)
                .map(|x| match scene.camera.unproject_ray(&Point2::new(f64::from(x), f64::from(y))) {
                    Ok(d) => {
                        let (z, id) = depth_along(scene, &d);
                        (z as f32, id)
                    }
                    Err(_) => (f32::NAN, 0),
                })
                .unzip()
        })
        .collect();
    let (mut depth_m, mut instance) = (Vec::with_capacity((w * h) as usize), Vec::with_capacity((w * h) as usize));
    for (d, i) in rows {
        depth_m.extend(d);
        instance.extend(i);
    }
    DepthMask { width: w, height: h, depth_m, instance }
}
