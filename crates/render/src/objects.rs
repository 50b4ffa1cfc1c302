//! Objects on the GPU: the rows of the `objs` buffer (`shaders/objects.wgsl` documents the
//! layout), built with glam's f32 types, and the tiles an object may cover.
//!
//! The meshes' rows (hierarchy, triangles, textures) depend only on which meshes a scene shows,
//! so the renderer keeps them, and their upload, between frames; the instances' rows (poses)
//! follow them and are written every frame.

use std::sync::Arc;

use glam::{Mat3, Vec3, Vec4};
use nalgebra::Vector3;
use rayon::prelude::*;

use super::tiles::{TileCornerRays, TILE_PX};
use super::uniforms::Params;
use super::RenderError;
use synthcam_core::mesh::bvh::LEAF;
use synthcam_scene::area_light::Rectangle;
use synthcam_scene::objects::{MeshAsset, Shading};
use synthcam_scene::shadow::{ObjectLight, ShadowLight};
use synthcam_scene::Scene;

/// The shader's traversal stack (`MESH_STACK` in `shaders/objects.wgsl`).
pub const MESH_STACK: usize = 48;
/// Rows per instance.
const INSTANCE_ROWS: usize = 5;
/// Albedo codes of a triangle row: the instance's albedo, or the texture.
const INSTANCE_ALBEDO: f32 = -1.0;
const TEXTURED: f32 = -2.0;

/// Where one mesh's rows start.
#[derive(Debug, Clone, Copy, PartialEq)]
struct MeshOffsets {
    node: u32,
    tri: u32,
    tex: u32,
    tex_size: [u32; 2],
}

/// The rows of the distinct meshes of a scene, in order of first appearance.
#[derive(Debug)]
pub(crate) struct MeshRows {
    /// The meshes (kept alive, so a pointer compare identifies them).
    pub assets: Vec<Arc<MeshAsset>>,
    /// Their rows.
    pub rows: Vec<[f32; 4]>,
    offsets: Vec<MeshOffsets>,
}

impl MeshRows {
    /// Whether these rows are those of `scene`'s meshes.
    pub fn serves(&self, scene: &Scene) -> bool {
        let mine = distinct_assets(scene);
        mine.len() == self.assets.len() && mine.iter().zip(&self.assets).all(|(a, b)| Arc::ptr_eq(a, b))
    }

    /// Lay out the meshes of `scene`.
    ///
    /// # Errors
    /// [`RenderError::Degenerate`] for a hierarchy deeper than the shader's stack.
    pub fn new(scene: &Scene) -> Result<Self, RenderError> {
        let assets = distinct_assets(scene);
        // The fine pass packs (instance, triangle) into one word: 8 and 24 bits.
        if scene.objects.len() > 255 {
            return Err(RenderError::Degenerate(format!("{} objects: the renderer takes up to 255", scene.objects.len())));
        }
        if let Some(a) = assets.iter().find(|a| a.mesh.triangles.len() >= 1 << 24) {
            return Err(RenderError::Degenerate(format!("mesh `{}`: {} triangles, the renderer takes fewer than 2^24", a.mesh.name, a.mesh.triangles.len())));
        }
        let mut rows = Vec::new();
        let mut offsets = Vec::new();
        for a in &assets {
            let depth = a.bvh.depth();
            if depth >= MESH_STACK {
                return Err(RenderError::Degenerate(format!("mesh `{}`: its hierarchy is {depth} levels deep, the shader's stack {MESH_STACK}", a.mesh.name)));
            }
            offsets.push(push_mesh(&mut rows, a));
        }
        Ok(Self { assets, rows, offsets })
    }
}

fn distinct_assets(scene: &Scene) -> Vec<Arc<MeshAsset>> {
    let mut out: Vec<Arc<MeshAsset>> = Vec::new();
    for o in &scene.objects {
        if !out.iter().any(|a| Arc::ptr_eq(a, &o.asset)) {
            out.push(o.asset.clone());
        }
    }
    out
}

/// f32 bounds that contain the f64 box, grown by `pad`.
fn outward(lo: &nalgebra::Point3<f64>, hi: &nalgebra::Point3<f64>, pad: f64) -> (Vec3, Vec3) {
    let down = |v: f64| {
        let f = (v - pad) as f32;
        if f64::from(f) > v - pad {
            f.next_down()
        } else {
            f
        }
    };
    let up = |v: f64| {
        let f = (v + pad) as f32;
        if f64::from(f) < v + pad {
            f.next_up()
        } else {
            f
        }
    };
    (Vec3::new(down(lo.x), down(lo.y), down(lo.z)), Vec3::new(up(hi.x), up(hi.y), up(hi.z)))
}

fn push_mesh(rows: &mut Vec<[f32; 4]>, a: &MeshAsset) -> MeshOffsets {
    let (lo, hi) = a.mesh.bounds_m();
    // Flat boxes (axis-aligned triangles) and f32 rounding of the slab test: a margin of 1e-6 of
    // the mesh's size keeps every box conservative.
    let pad = 1e-6 * (hi - lo).norm().max(lo.coords.amax()).max(hi.coords.amax());
    let node = rows.len() as u32;
    for n in &a.bvh.nodes {
        let (lo0, hi0) = outward(&n.lo[0], &n.hi[0], pad);
        let (lo1, hi1) = outward(&n.lo[1], &n.hi[1], pad);
        rows.push(lo0.extend(f32::from_bits(n.child[0])).to_array());
        rows.push(hi0.extend(f32::from_bits(n.child[1])).to_array());
        rows.push(lo1.extend(0.0).to_array());
        rows.push(hi1.extend(0.0).to_array());
    }
    let tri = rows.len() as u32;
    let textured = a.mesh.texture.is_some();
    // In leaf order: a leaf names a run of rows.
    for &i in &a.bvh.order {
        let (i, t) = (i as usize, &a.mesh.triangles[i as usize]);
        let [p0, p1, p2] = a.mesh.corners_m(i);
        let v = |p: Vector3<f64>| Vec3::new(p.x as f32, p.y as f32, p.z as f32);
        let uv = t.uv.unwrap_or([[0.0; 2]; 3]);
        let albedo = match (t.uv, textured) {
            (Some(_), true) => TEXTURED,
            _ => t.albedo.unwrap_or(INSTANCE_ALBEDO),
        };
        rows.push(v(p0.coords).extend(albedo).to_array());
        rows.push(v(p1 - p0).extend(uv[0][0]).to_array());
        rows.push(v(p2 - p0).extend(uv[0][1]).to_array());
        rows.push([uv[1][0], uv[1][1], uv[2][0], uv[2][1]]);
    }
    let tex = rows.len() as u32;
    let tex_size = a.mesh.texture.as_ref().map_or([0, 0], |t| {
        let sums = t.row_prefix_sums();
        rows.extend(sums.chunks(4).map(|c| std::array::from_fn(|k| c.get(k).copied().unwrap_or(0.0))));
        [t.width, t.height]
    });
    // A mesh's rows bound mis-indexed reads by the next mesh's, never by a missing row.
    if a.bvh.nodes.is_empty() {
        rows.push([0.0; 4]);
    }
    debug_assert!(a.bvh.nodes.iter().all(|n| n.child.iter().all(|c| c & LEAF != 0 || (*c as usize) < a.bvh.nodes.len())));
    MeshOffsets { node, tri, tex, tex_size }
}

/// The instances' rows (appended after `meshes.rows`, at row `meshes.rows.len()`).
pub(crate) fn instance_rows(scene: &Scene, meshes: &MeshRows) -> Vec<[f32; 4]> {
    let mut rows = Vec::with_capacity(scene.objects.len() * INSTANCE_ROWS);
    for o in &scene.objects {
        let k = meshes.assets.iter().position(|a| Arc::ptr_eq(a, &o.asset)).unwrap_or(0);
        let off = meshes.offsets[k];
        let inv = o.cam_from_object.inverse();
        let r = inv.rotation.to_rotation_matrix().into_inner() / o.scale;
        let b = inv.translation.vector / o.scale;
        let m = Mat3::from_cols_array(&[r[(0, 0)], r[(1, 0)], r[(2, 0)], r[(0, 1)], r[(1, 1)], r[(2, 1)], r[(0, 2)], r[(1, 2)], r[(2, 2)]].map(|v| v as f32));
        for row in 0..3 {
            rows.push(m.row(row).extend(b[row] as f32).to_array());
        }
        rows.push([off.node, off.tri, off.tex, off.tex_size[0]].map(f32::from_bits));
        // Back faces may be skipped when the mesh is closed and the camera outside its ball.
        let (c, r) = o.asset.bounds[0];
        let outside = (o.cam_from_object * (c * o.scale)).coords.norm() > r * o.scale * (1.0 + 1e-6);
        let flags = u32::from(o.shading == Shading::HeadLight) | (u32::from(o.asset.closed && outside) << 1) | (u32::from(o.shading == Shading::Lit) << 2);
        rows.push(Vec4::new(o.albedo as f32, f32::from_bits(off.tex_size[1]), f32::from_bits(flags), 0.0).to_array());
    }
    rows
}

/// The object uniforms: instance count and first row, fine samples, and the target's plane and
/// sheet (where objects and the target meet).
pub(crate) fn object_params(p: &mut Params, scene: &Scene, instance_row: usize) {
    // Edge pixels: scan lines, an eighth of `samples` (2 to 8; crossings are bisected, and the
    // lines' mean is exact for a straight edge), or a grid of half `samples` (2 to 16) squared.
    p.obj = [scene.objects.len() as u32, instance_row as u32, (scene.render.samples / 8).clamp(2, 8), (scene.render.samples / 2).clamp(2, 16)];
    let (n, c) = target_plane(scene);
    p.plane = [n.x as f32, n.y as f32, n.z as f32, c as f32];
    // No sheet (the S-path): an empty one, so objects are always in front.
    let s = scene.target.extent_m().unwrap_or([0.0, 0.0, -1.0, -1.0]);
    p.sheet = s.map(|v| v as f32);
}

/// The target's plane `n . x = c` in the camera frame: `(n, c)`.
fn target_plane(scene: &Scene) -> (Vector3<f64>, f64) {
    let n = scene.cam_from_target.rotation * Vector3::z();
    (n, n.dot(&scene.cam_from_target.translation.vector))
}

/// The objects' shadow uniforms (`Params::sun` for a directional light, `soft_c`, `soft_u`,
/// `soft_v` for an area light; zero without a shadow light) and their own light (`obj_sun`).
pub(crate) fn shadow_params(p: &mut Params, sun: Option<&ShadowLight>, on_objects: &ObjectLight) {
    let f32s = |v: &Vector3<f64>, w: f64| [v.x as f32, v.y as f32, v.z as f32, w as f32];
    let (toward, e) = on_objects.sun.unwrap_or_default();
    p.obj_sun = f32s(&(toward * e), on_objects.ambient);
    match sun {
        Some(ShadowLight::Sun { toward_light_cam, ratio }) => p.sun = f32s(toward_light_cam, *ratio),
        Some(ShadowLight::Area { rect, ambient, .. }) => {
            p.soft_c = f32s(&rect.corner.coords, *ambient);
            p.soft_u = f32s(&rect.u, 1.0);
            p.soft_v = f32s(&rect.v, 0.0);
        }
        None => {}
    }
}

/// A ball's shadow on the target plane `n . x = c` along `toward` (towards the light): a ball
/// around the shadow's ellipse (semi-axes `r` and `r / |cos|`), or `None` when the plane is not
/// beyond the ball seen from the light.
fn shadow_ball((centre, r): (Vector3<f64>, f64), (n, c): (Vector3<f64>, f64), toward: &Vector3<f64>) -> Option<(Vector3<f64>, f64)> {
    let cos = n.dot(toward).abs();
    let s = (n.dot(&centre) - c) / n.dot(toward);
    (cos > 1e-9 && s > -r / cos).then(|| (centre - s * toward, r / cos))
}

/// A ball around every shadow a ball casts on the target plane `n . x = c` from an area light
/// `rect`: a board point `x` in it sees the ball on its segment to a light point `p` at a point
/// `q` of height `h_q` (over the plane, on the light's side), so `x - q = (q - p) h_q / (h_p - h_q)`;
/// bounding `h_q <= h_c + r`, `h_p >= h_L - rho` and `|q - p| <= |c - L| + r + rho` (`L`, `rho`
/// the light's centre and half diagonal) bounds `|x - c|`. The whole plane when the ball reaches
/// the light's lowest height.
fn soft_shadow_ball((centre, r): (Vector3<f64>, f64), (n, c): (Vector3<f64>, f64), rect: &Rectangle) -> (Vector3<f64>, f64) {
    let light = (rect.corner + 0.5 * (rect.u + rect.v)).coords;
    let rho = 0.5 * (rect.u + rect.v).norm();
    let side = (n.dot(&light) - c).signum();
    let (h_l, h_c) = (side * (n.dot(&light) - c), side * (n.dot(&centre) - c));
    let gap = h_l - rho - (h_c + r);
    if gap <= 0.0 {
        return (centre, f64::INFINITY);
    }
    (centre, r + (h_c + r).max(0.0) / gap * ((centre - light).norm() + r + rho))
}

/// The tiles (packed `tx | ty << 16`) an object or its shadow on the target may cover: the cone
/// around each tile's corner rays, widened by a pixel, meets the object's bounding sphere or the
/// ball around that sphere's shadow.
pub(crate) fn object_tiles(scene: &Scene, grid: &TileCornerRays, sun: Option<&ShadowLight>) -> Vec<u32> {
    // Per object its balls in the camera frame: the whole mesh's, then its parts'.
    let mut balls: Vec<Vec<(Vector3<f64>, f64)>> =
        scene.objects.iter().map(|o| o.asset.bounds.iter().map(|(c, r)| ((o.cam_from_object * (c * o.scale)).coords, r * o.scale)).collect()).collect();
    let plane = target_plane(scene);
    let shadows: Vec<Vec<(Vector3<f64>, f64)>> = match sun {
        Some(ShadowLight::Sun { toward_light_cam, .. }) => {
            balls.iter().filter_map(|b| b.iter().map(|ball| shadow_ball(*ball, plane, toward_light_cam)).collect::<Option<Vec<_>>>()).collect()
        }
        Some(ShadowLight::Area { rect, .. }) => balls.iter().map(|b| b.iter().map(|ball| soft_shadow_ball(*ball, plane, rect)).collect()).collect(),
        None => Vec::new(),
    };
    balls.extend(shadows);
    let meets = |rays: &[Vector3<f64>; 4], b: &[(Vector3<f64>, f64)]| cone_meets(rays, &b[0].0, b[0].1) && b[1..].iter().any(|(c, r)| cone_meets(rays, c, *r));
    let (w, h) = (scene.camera.size.width, scene.camera.size.height);
    let (tiles_x, tiles_y) = (w.div_ceil(TILE_PX), h.div_ceil(TILE_PX));
    let covers = |tx: u32, ty: u32| !grid.beyond_lens(tx, ty) && grid.tile(tx, ty).is_none_or(|rays| balls.iter().any(|b| meets(&rays, b)));
    (0..tiles_y).into_par_iter().flat_map_iter(|ty| (0..tiles_x).filter(move |&tx| covers(tx, ty)).map(move |tx| tx | (ty << 16))).collect()
}

/// Whether the cone around the four corner rays of a tile (widened by an eighth of the tile's
/// angular size, a pixel) meets the ball (`c`, `r`).
fn cone_meets(rays: &[Vector3<f64>; 4], c: &Vector3<f64>, r: f64) -> bool {
    let dist = c.norm();
    if dist <= r {
        return true;
    }
    let units = rays.map(|d| d.normalize());
    let axis = (units[0] + units[1] + units[2] + units[3]).normalize();
    let half = units.iter().map(|u| u.angle(&axis)).fold(0.0, f64::max);
    let across = units[0].angle(&units[2]).max(units[1].angle(&units[3]));
    let widened = half + 0.25 * across;
    axis.angle(c) - (r / dist).asin() <= widened
}
