//! Triangle meshes: the user's own objects in a scene (a workpiece, a gripper, a 3-D calibration
//! object), loaded from Wavefront OBJ with `tobj` ([`obj`]), or made by [`primitives`].
//!
//! A [`Mesh`] lives in its own frame (metres). [`bvh`] builds its bounding-volume hierarchy (the
//! `bvh` crate's binned SAH build, flattened into the two-boxes-per-node layout the shader
//! traverses) and casts exact f64 rays on the CPU (truth, depth, masks, the reference renderer).
//! [`texture`] holds a grey albedo texture with its row prefix sums, so a box of any size is
//! averaged exactly in O(rows).
//!
//! No file I/O here: [`obj::load_obj`] takes a `read` function (the CLI passes `std::fs::read`).
//!
//! ```
//! use synthcam_core::mesh::{primitives::icosphere, MeshBvh};
//! use nalgebra::{Point3, Vector3};
//!
//! let sphere = icosphere(0.05, 8); // 1280 triangles, radius 5 cm
//! let bvh = MeshBvh::build(&sphere);
//! let hit = bvh.cast(&sphere, &Point3::new(0.0, 0.0, -1.0), &Vector3::z(), 0.0, f64::INFINITY).expect("hit");
//! assert!((hit.t - 0.95).abs() < 1e-3); // the facets lie within 0.2 mm of the sphere
//! ```
//!
//! Texture coordinates follow OBJ: `(u, v)` in [0, 1], `v = 0` at the *bottom* row of the image;
//! coordinates outside [0, 1] are clamped (no repeat).

pub mod bvh;
pub mod obj;
pub mod primitives;
pub mod texture;

use std::sync::Arc;

use nalgebra::Point3;

pub use bvh::{MeshBvh, RayHit};
pub use texture::Texture;

/// One triangle of a [`Mesh`].
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Triangle {
    /// Vertex indices into [`Mesh::positions_m`], counter-clockwise seen from outside.
    pub v: [u32; 3],
    /// Texture coordinates of the three vertices, when the triangle is textured.
    pub uv: Option<[[f32; 2]; 3]>,
    /// Grey albedo of its material (MTL `Kd`, BT.601 luma x 255), when it has one.
    pub albedo: Option<f32>,
}

/// A triangle mesh in its own frame.
#[derive(Debug, Clone, PartialEq)]
pub struct Mesh {
    /// Name, for messages (the OBJ path, or the primitive's name).
    pub name: String,
    /// Vertex positions, metres, object frame.
    pub positions_m: Vec<Point3<f64>>,
    /// Triangles (no degenerate ones: loaders skip them).
    pub triangles: Vec<Triangle>,
    /// The albedo texture of the textured triangles (one per mesh).
    pub texture: Option<Arc<Texture>>,
}

/// Errors of mesh loading and building.
#[derive(Debug, thiserror::Error)]
#[non_exhaustive]
pub enum MeshError {
    /// A file could not be read.
    #[error("{path}: cannot read: {source}")]
    Read {
        /// The file.
        path: String,
        /// The I/O error.
        source: std::io::Error,
    },
    /// The OBJ (or its MTL) does not parse.
    #[error("{path}: not a valid OBJ/MTL file: {source}")]
    Obj {
        /// The file.
        path: String,
        /// tobj's error.
        source: tobj::LoadError,
    },
    /// The texture image does not decode.
    #[error("{path}: texture does not load: {source}")]
    Texture {
        /// The image file.
        path: String,
        /// The image crate's error.
        source: image::ImageError,
    },
    /// The mesh is unusable: no triangle left, a non-finite vertex, an index out of range, more
    /// than one texture.
    #[error("{path}: {reason}")]
    Invalid {
        /// The file or primitive.
        path: String,
        /// What is wrong.
        reason: String,
    },
}

impl Mesh {
    /// The axis-aligned bounds of the vertices, `(min, max)`, object frame.
    pub fn bounds_m(&self) -> (Point3<f64>, Point3<f64>) {
        let mut lo = Point3::from([f64::INFINITY; 3]);
        let mut hi = Point3::from([f64::NEG_INFINITY; 3]);
        for p in &self.positions_m {
            lo = lo.inf(p);
            hi = hi.sup(p);
        }
        (lo, hi)
    }

    /// The three corners of triangle `i`, object frame.
    pub fn corners_m(&self, i: usize) -> [Point3<f64>; 3] {
        self.triangles[i].v.map(|k| self.positions_m[k as usize])
    }

    /// Check that the mesh can be rendered: at least one triangle, finite vertices, indices in
    /// range, and texture coordinates finite.
    ///
    /// # Errors
    /// [`MeshError::Invalid`] naming the mesh.
    pub fn validate(&self) -> Result<(), MeshError> {
        let invalid = |reason: String| Err(MeshError::Invalid { path: self.name.clone(), reason });
        if self.triangles.is_empty() {
            return invalid("has no (non-degenerate) triangle".into());
        }
        if let Some(i) = self.positions_m.iter().position(|p| !p.coords.iter().all(|v| v.is_finite())) {
            return invalid(format!("vertex {i} is not finite"));
        }
        let n = self.positions_m.len();
        if let Some(i) = self.triangles.iter().position(|t| t.v.iter().any(|&k| k as usize >= n)) {
            return invalid(format!("triangle {i} indexes a vertex beyond the {n} vertices"));
        }
        if let Some(i) = self.triangles.iter().position(|t| t.uv.is_some_and(|uv| uv.iter().flatten().any(|v| !v.is_finite()))) {
            return invalid(format!("triangle {i} has a non-finite texture coordinate"));
        }
        Ok(())
    }
}

impl Mesh {
    /// Whether the mesh is closed and consistently oriented: every directed edge appears exactly
    /// once and its reverse exactly once (each edge shared by two triangles that wind it in
    /// opposite directions).
    pub fn is_closed(&self) -> bool {
        let mut edges = std::collections::HashMap::new();
        for t in &self.triangles {
            for k in 0..3 {
                *edges.entry((t.v[k], t.v[(k + 1) % 3])).or_insert(0u32) += 1;
            }
        }
        edges.iter().all(|(&(a, b), &n)| n == 1 && edges.get(&(b, a)) == Some(&1))
    }
}

/// Whether the triangle `p` has (numerically) zero area: its doubled area is below `1e-12`
/// of its longest edge squared (a sliver the ray test cannot hit reliably).
pub fn is_degenerate(p: &[Point3<f64>; 3]) -> bool {
    let (e1, e2) = (p[1] - p[0], p[2] - p[0]);
    let longest = e1.norm_squared().max(e2.norm_squared()).max((p[2] - p[1]).norm_squared());
    let area2 = e1.cross(&e2).norm();
    !(area2 > 1e-12 * longest) || !(longest > 0.0)
}
