//! Objects in datasets: meshes fixed in the scene (`[[object]]`, as in scene files, posed in the
//! camera or the target frame) and random occluders (`[[occluder]]`).
//!
//! ```toml
//! [[occluder]]
//! mesh = "assets/meshes/gripper.obj"
//! count = [0, 2]          # occluders of this mesh per image, uniform in [lo, hi]
//! size_m = [0.04, 0.08]   # the mesh scaled so its bounding ball's diameter is this
//! along = [0.3, 0.8]      # its centre this fraction of the way from the camera to a random
//!                         # feature point of the target (so it tends to hide part of it)
//! albedo = [40.0, 200.0]  # grey where the OBJ has no material
//! shading = "unlit"
//! ```
//!
//! Each image's occluders depend only on (seed, k): they are drawn from their own stream, so
//! adding occluders to a spec leaves its poses and noise unchanged.

use std::sync::Arc;

use nalgebra::{Isometry3, Translation3, UnitQuaternion, Vector3};
use rand::Rng;
use serde::Deserialize;

use super::error::SpecError;
use super::meshes::MeshLibrary;
use synthcam_scene::file::{ObjectFrame, ObjectSpec};
use synthcam_scene::objects::{MeshAsset, SceneObject, Shading};
use synthcam_scene::{Scene, SceneError};

/// One `[[occluder]]` table.
#[derive(Debug, Clone, PartialEq, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct OccluderSpec {
    /// The OBJ file.
    pub mesh: String,
    /// How many per image, `[lo, hi]`.
    pub count: [u32; 2],
    /// Diameter of the scaled mesh's bounding ball, metres, `[lo, hi]`.
    pub size_m: [f64; 2],
    /// Where along the ray from the camera to a random feature point, `[lo, hi]` in (0, 1).
    pub along: [f64; 2],
    /// Grey level, `[lo, hi]` (default `[160, 160]`).
    pub albedo: Option<[f64; 2]>,
    /// Lighting (default unlit).
    #[serde(default)]
    pub shading: Shading,
}

/// The dataset's objects, meshes loaded.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct DatasetObjects {
    /// Fixed objects: spec, its pose, its mesh.
    pub fixed: Vec<(ObjectSpec, Isometry3<f64>, Arc<MeshAsset>)>,
    /// Random occluders and their meshes.
    pub occluders: Vec<(OccluderSpec, Arc<MeshAsset>)>,
}

fn invalid(field: String, reason: String) -> SpecError {
    SpecError::InvalidField { field, reason }
}

fn check_pair(field: String, r: [f64; 2], lo: f64, hi: f64) -> Result<(), SpecError> {
    if !(r[0] >= lo && r[0] <= r[1] && r[1] <= hi) {
        return Err(invalid(field, format!("must be [lo, hi] with {lo} <= lo <= hi <= {hi}, got {r:?}")));
    }
    Ok(())
}

impl DatasetObjects {
    /// Check the tables and load their meshes from `meshes`.
    ///
    /// # Errors
    /// An invalid field (named), a `world` or `tool` frame, or a mesh that does not load.
    pub fn load(objects: &[ObjectSpec], occluders: &[OccluderSpec], meshes: &MeshLibrary) -> Result<Self, SpecError> {
        let mut out = Self::default();
        for (i, o) in objects.iter().enumerate() {
            if matches!(o.frame, ObjectFrame::World | ObjectFrame::Tool) {
                return Err(invalid(format!("object[{i}].frame"), "a dataset takes \"camera\" or \"target\"".into()));
            }
            let pose = o.pose(i)?;
            let asset = meshes.load(&o.mesh).map_err(|source| SceneError::Object { index: i, source })?;
            out.fixed.push((o.clone(), pose, asset));
        }
        for (i, o) in occluders.iter().enumerate() {
            let f = |name: &str| format!("occluder[{i}].{name}");
            if o.count[0] > o.count[1] || o.count[1] > 64 {
                return Err(invalid(f("count"), format!("must be [lo, hi] with lo <= hi <= 64, got {:?}", o.count)));
            }
            check_pair(f("size_m"), o.size_m, f64::MIN_POSITIVE, 1e3)?;
            check_pair(f("along"), o.along, 1e-3, 0.999)?;
            check_pair(f("albedo"), o.albedo.unwrap_or([160.0; 2]), 0.0, 255.0)?;
            let asset = meshes.load(&o.mesh).map_err(|source| SceneError::Object { index: objects.len() + i, source })?;
            out.occluders.push((o.clone(), asset));
        }
        Ok(out)
    }

    /// Whether there is any object at all.
    pub fn is_empty(&self) -> bool {
        self.fixed.is_empty() && self.occluders.is_empty()
    }

    /// Put the objects of image `k` into `scene` (its pose already sampled): the fixed ones, then
    /// the occluders drawn from the stream of (`seed`, `k`).
    pub fn place(&self, scene: &mut Scene, seed: u64, k: u64) {
        for (spec, pose, asset) in &self.fixed {
            let frame = if spec.frame == ObjectFrame::Target { scene.cam_from_target } else { Isometry3::identity() };
            scene.objects.push(spec.place(asset.clone(), frame * pose));
        }
        let mut rng = super::rng::image_rng(seed ^ 0x6f63_636c_7564_6572, k);
        let points = scene.target.feature_points_m();
        for (spec, asset) in &self.occluders {
            let n = rng.random_range(spec.count[0]..=spec.count[1]);
            for _ in 0..n {
                scene.objects.push(occluder(&mut rng, spec, asset, scene, &points));
            }
        }
    }
}

fn uniform(rng: &mut impl Rng, r: [f64; 2]) -> f64 {
    if r[1] > r[0] {
        rng.random_range(r[0]..=r[1])
    } else {
        r[0]
    }
}

/// One occluder: random size, orientation (uniform on SO(3)), and place on the line of sight to
/// a random feature point.
fn occluder(rng: &mut impl Rng, spec: &OccluderSpec, asset: &Arc<MeshAsset>, scene: &Scene, points: &[nalgebra::Point3<f64>]) -> SceneObject {
    let (centre, radius) = asset.bounds[0];
    let scale = uniform(rng, spec.size_m) / (2.0 * radius).max(1e-12);
    let feature = points.get(rng.random_range(0..points.len().max(1))).copied().unwrap_or_else(nalgebra::Point3::origin);
    let at = (scene.cam_from_target * feature).coords * uniform(rng, spec.along);
    // Shoemake's uniform random rotation.
    let (u1, u2, u3): (f64, f64, f64) = (rng.random(), rng.random(), rng.random());
    let tau = std::f64::consts::TAU;
    let q = nalgebra::Quaternion::new(
        (u1.sqrt()) * (tau * u3).cos(),
        (1.0 - u1).sqrt() * (tau * u2).sin(),
        (1.0 - u1).sqrt() * (tau * u2).cos(),
        u1.sqrt() * (tau * u3).sin(),
    );
    let rot = UnitQuaternion::from_quaternion(q);
    // The mesh's bounding-ball centre lands on the line of sight.
    let t: Vector3<f64> = at - rot * (centre.coords * scale);
    let mut o = SceneObject::new(asset.clone(), Isometry3::from_parts(Translation3::from(t), rot));
    o.scale = scale;
    o.albedo = uniform(rng, spec.albedo.unwrap_or([160.0; 2]));
    o.shading = spec.shading;
    o
}
