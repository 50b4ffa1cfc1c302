//! The user's objects in a scene: meshes ([`synthcam_core::mesh`]) placed in the camera frame, shaded
//! unlit (their albedo), under a head light, or under the scene's light with the objects' shadows
//! ([`crate::shadow::ObjectLight`]), and the exact f64 ray casts against them that the CPU side
//! needs (the reference renderer, occlusion truth, depth and instance masks).
//!
//! Targets stay analytic; objects and targets occlude each other by ray parameter.

use std::sync::Arc;

use nalgebra::{Isometry3, Point3, Vector3};

use super::SceneError;
use synthcam_core::mesh::{Mesh, MeshBvh, MeshError, RayHit};

/// A mesh and its hierarchy, built once and shared by every scene that shows it.
#[derive(Debug, Clone, PartialEq)]
pub struct MeshAsset {
    /// The mesh, object frame.
    pub mesh: Mesh,
    /// Its bounding-volume hierarchy.
    pub bvh: MeshBvh,
    /// Balls that bound the mesh (object frame, metres): the vertices' ball about the centre of
    /// their box, then the balls of the hierarchy's boxes three levels down (the renderer picks
    /// the tiles an object may cover with them).
    pub bounds: Vec<(Point3<f64>, f64)>,
    /// The mesh is closed, consistently oriented and wound outwards (every edge used once in
    /// each direction, positive signed volume): seen from outside, a ray's first hit is on a
    /// triangle facing it.
    pub closed: bool,
}

impl MeshAsset {
    /// Validate `mesh` and build its hierarchy.
    ///
    /// # Errors
    /// [`MeshError::Invalid`] for an unusable mesh.
    pub fn new(mesh: Mesh) -> Result<Arc<Self>, MeshError> {
        mesh.validate()?;
        let bvh = MeshBvh::build(&mesh);
        let (lo, hi) = mesh.bounds_m();
        let centre = nalgebra::center(&lo, &hi);
        let radius = mesh.positions_m.iter().map(|p| (p - centre).norm()).fold(0.0, f64::max);
        let mut bounds = vec![(centre, radius)];
        bounds.extend(bvh.boxes_at(3).iter().map(|(lo, hi)| (nalgebra::center(lo, hi), 0.5 * (hi - lo).norm())));
        // Closed and wound outwards (positive signed volume): back faces can be culled.
        let volume6: f64 = (0..mesh.triangles.len()).map(|i| mesh.corners_m(i)).map(|[a, b, c]| a.coords.dot(&b.coords.cross(&c.coords))).sum();
        let closed = mesh.is_closed() && volume6 > 0.0;
        Ok(Arc::new(Self { mesh, bvh, bounds, closed }))
    }
}

/// How an object is lit.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, serde::Deserialize, serde::Serialize)]
#[serde(rename_all = "kebab-case")]
pub enum Shading {
    /// Its albedo, whatever the angle (the default: like the targets).
    #[default]
    Unlit,
    /// Lambert under a light at the camera: albedo x |cos| of the angle between the ray and the
    /// face normal.
    HeadLight,
    /// Lambert under the scene's lights, as the targets are: albedo x `(A + E max(0, n . l))`
    /// with `n` the face normal on the side the camera sees and `l` towards the directional
    /// light; `A` alone where an object (this one included) hides the light
    /// ([`crate::shadow::ObjectLight`]).
    Lit,
}

/// One object in a scene.
#[derive(Debug, Clone)]
pub struct SceneObject {
    /// The mesh and its hierarchy.
    pub asset: Arc<MeshAsset>,
    /// Pose: `x_cam = R (scale x_object) + t`.
    pub cam_from_object: Isometry3<f64>,
    /// Uniform scale applied to the mesh (object frame) before the pose.
    pub scale: f64,
    /// Grey level of triangles with no material of their own, 0..255.
    pub albedo: f64,
    /// Lighting.
    pub shading: Shading,
}

impl PartialEq for SceneObject {
    fn eq(&self, o: &Self) -> bool {
        (Arc::ptr_eq(&self.asset, &o.asset) || self.asset == o.asset)
            && self.cam_from_object == o.cam_from_object
            && self.scale == o.scale
            && self.albedo == o.albedo
            && self.shading == o.shading
    }
}

/// The closest object a ray from the camera centre meets.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct ObjectHit {
    /// Index of the object in the scene.
    pub object: usize,
    /// The hit on its mesh (`t` is the camera ray's parameter).
    pub hit: RayHit,
}

impl SceneObject {
    /// An unlit object of albedo 160 at `cam_from_object`, scale 1.
    pub fn new(asset: Arc<MeshAsset>, cam_from_object: Isometry3<f64>) -> Self {
        Self { asset, cam_from_object, scale: 1.0, albedo: 160.0, shading: Shading::Unlit }
    }

    /// The ray `t d_cam` from the camera centre in the object's (unscaled mesh) frame: origin and
    /// direction, with the same parameter `t`.
    pub fn ray_in_object(&self, d_cam: &Vector3<f64>) -> (Point3<f64>, Vector3<f64>) {
        self.ray_in_object_from(&Point3::origin(), d_cam)
    }

    /// The ray `origin_cam + t d_cam` (camera frame) in the object's (unscaled mesh) frame, with
    /// the same parameter `t`.
    pub fn ray_in_object_from(&self, origin_cam: &Point3<f64>, d_cam: &Vector3<f64>) -> (Point3<f64>, Vector3<f64>) {
        let inv = self.cam_from_object.inverse();
        ((inv * origin_cam) / self.scale, (inv.rotation * d_cam) / self.scale)
    }

    /// The albedo at `hit`: the texture (nearest texel), the triangle's material or the object's
    /// albedo.
    pub fn albedo_at(&self, hit: &RayHit) -> f64 {
        let mesh = &self.asset.mesh;
        let tri = &mesh.triangles[hit.triangle as usize];
        let [u, v] = hit.bary;
        match (tri.uv, &mesh.texture) {
            (Some(uv), Some(tex)) => {
                let at = |k: usize| f64::from(uv[0][k]) * (1.0 - u - v) + f64::from(uv[1][k]) * u + f64::from(uv[2][k]) * v;
                tex.at(tex.texel_of([at(0), at(1)]))
            }
            _ => tri.albedo.map_or(self.albedo, f64::from),
        }
    }

    /// The unit normal of the face `hit` lies on, camera frame, on the side the ray `d_cam` sees.
    pub fn seen_normal(&self, hit: &RayHit, d_cam: &Vector3<f64>) -> Vector3<f64> {
        let [a, b, c] = self.asset.mesh.corners_m(hit.triangle as usize);
        let n = (self.cam_from_object.rotation * (b - a).cross(&(c - a))).normalize();
        if n.dot(d_cam) > 0.0 {
            -n
        } else {
            n
        }
    }

    /// The grey level seen where ray `d_cam` hits this object at `hit` unlit or under the head
    /// light ([`Self::albedo_at`] times the head light's cosine); a [`Shading::Lit`] object's
    /// light comes from the scene ([`crate::shadow::ObjectLight`]): `lit` is its factor.
    pub fn shade(&self, hit: &RayHit, d_cam: &Vector3<f64>, lit: f64) -> f64 {
        let albedo = self.albedo_at(hit);
        match self.shading {
            Shading::Unlit => albedo,
            Shading::HeadLight => albedo * -self.seen_normal(hit, d_cam).dot(&d_cam.normalize()),
            Shading::Lit => albedo * lit,
        }
    }

    /// Check the pose, scale and albedo (`i`: the object's index, for messages); `max_angle_rad`
    /// is the lens's reach ([`synthcam_core::camera::Lens::max_angle_rad`]).
    ///
    /// # Errors
    /// [`SceneError::InvalidField`] naming `object[i]` and the field.
    pub fn validate(&self, i: usize, max_angle_rad: f64) -> Result<(), SceneError> {
        let invalid = |f: &str, reason: String| Err(SceneError::InvalidField { field: format!("object[{i}].{f}"), reason });
        let r = self.cam_from_object.rotation.to_rotation_matrix();
        if r.matrix().iter().chain(self.cam_from_object.translation.vector.iter()).any(|v| !v.is_finite()) {
            return invalid("pose", "contains a non-finite number".into());
        }
        if !(self.scale > 0.0) || !self.scale.is_finite() {
            return invalid("scale", format!("must be finite and > 0, got {}", self.scale));
        }
        if !(0.0..=255.0).contains(&self.albedo) {
            return invalid("albedo", format!("must be in [0, 255], got {}", self.albedo));
        }
        let (lo, hi) = self.asset.mesh.bounds_m();
        let corners = (0..8).map(|k| Point3::new([lo.x, hi.x][k & 1], [lo.y, hi.y][(k >> 1) & 1], [lo.z, hi.z][k >> 2]));
        let seen = corners.map(|p| self.cam_from_object * (p * self.scale)).any(|p| p.z > 0.0 || p.coords.xy().norm().atan2(p.z) < max_angle_rad);
        if !seen {
            return invalid("pose", format!("puts `{}` behind the camera (outside the lens's reach)", self.asset.mesh.name));
        }
        Ok(())
    }
}

/// The closest hit of the camera ray `t d_cam`, `t` in `(0, t_max)`, among `objects`.
pub fn cast_objects(objects: &[SceneObject], d_cam: &Vector3<f64>, t_max: f64) -> Option<ObjectHit> {
    let mut best: Option<ObjectHit> = None;
    for (i, o) in objects.iter().enumerate() {
        let (origin, dir) = o.ray_in_object(d_cam);
        let limit = best.map_or(t_max, |b| b.hit.t);
        if let Some(hit) = o.asset.bvh.cast(&o.asset.mesh, &origin, &dir, 0.0, limit) {
            best = Some(ObjectHit { object: i, hit });
        }
    }
    best
}

/// Whether an object lies between the camera centre and the point `p_cam` (camera frame): the
/// exact segment test a feature's `visible` uses. A hit within `1e-9` of the point (the point on
/// an object's surface) does not hide it.
pub fn occluded(objects: &[SceneObject], p_cam: &Point3<f64>) -> bool {
    cast_objects(objects, &p_cam.coords, 1.0 - 1e-9).is_some()
}

/// The scene of the objects' speed benchmark (issue 19): `scene` (the embedded 1280 x 1024
/// chessboard under k1 = -0.25) with a 100 820-triangle icosphere of radius 6 cm (geodesic
/// frequency 71), 0.5 m in front of the camera and a little off its axis, unlit (albedo 200; a
/// head light on facets about a pixel wide puts a shading step in nearly every pixel, and each
/// such pixel is supersampled).
///
/// # Errors
/// As `scene` (passed through), or the mesh.
pub fn with_benchmark_mesh(scene: Result<super::Scene, SceneError>) -> Result<super::Scene, SceneError> {
    let mut scene = scene?;
    let asset = MeshAsset::new(synthcam_core::mesh::primitives::icosphere(0.06, 71)).map_err(|source| SceneError::Object { index: 0, source })?;
    let mut o = SceneObject::new(asset, Isometry3::translation(0.03, 0.02, 0.5));
    o.albedo = 200.0;
    scene.objects.push(o);
    scene.validate()?;
    Ok(scene)
}
