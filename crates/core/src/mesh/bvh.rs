//! The bounding-volume hierarchy of a mesh, and exact closest-hit ray casts (f64).
//!
//! Built with the `bvh` crate (binned surface-area heuristic, one triangle per leaf), then
//! re-laid as the classic GPU layout: each inner node stores *both* children's boxes, so a
//! traversal tests two boxes per visit, descends into the nearer child and pushes the farther one
//! (Aila and Laine, "Understanding the Efficiency of Ray Traversal on GPUs", HPG 2009). The
//! shader (`shaders/objects.wgsl`, `mesh_hit`) walks the same nodes in f32; [`MeshBvh::cast`]
//! is its f64 twin and [`cast_brute`] the brute-force check of both.
//!
//! Ray-triangle test: Möller and Trumbore, "Fast, minimum storage ray-triangle intersection",
//! JGT 1997, two-sided (meshes may be open).

use bvh::aabb::{Aabb, Bounded};
use bvh::bounding_hierarchy::BHShape;
use nalgebra::{Point3, Vector3};

use super::Mesh;

/// Flag of a child index that names a leaf (a run of triangles) rather than a node.
pub const LEAF: u32 = 1 << 31;
/// Most triangles in one leaf: subtrees of the built hierarchy with this many or fewer become one
/// leaf (fewer, shorter traversals; the triangles are tested in a loop).
pub const LEAF_SIZE: u32 = 1;
/// A leaf child: [`LEAF`] | (count - 1) << 27 | first, a run of [`MeshBvh::order`].
const COUNT_SHIFT: u32 = 27;
const FIRST_MASK: u32 = (1 << COUNT_SHIFT) - 1;

/// The run of [`MeshBvh::order`] a leaf child names: (first, count).
pub fn leaf_run(child: u32) -> (u32, u32) {
    (child & FIRST_MASK, ((child & !LEAF) >> COUNT_SHIFT) + 1)
}

/// One inner node: the boxes of its two children and their indices (a node index, or a leaf:
/// [`leaf_run`]). An empty child has an inverted box (`lo > hi`).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct BvhNode {
    /// Lower corners of the children's boxes.
    pub lo: [Point3<f64>; 2],
    /// Upper corners of the children's boxes.
    pub hi: [Point3<f64>; 2],
    /// The children.
    pub child: [u32; 2],
}

/// A mesh's hierarchy; node 0 is the root.
#[derive(Debug, Clone, PartialEq)]
pub struct MeshBvh {
    /// Inner nodes, root first.
    pub nodes: Vec<BvhNode>,
    /// The mesh's triangle indices in leaf order: leaves name runs of it.
    pub order: Vec<u32>,
}

/// The closest hit of a ray.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct RayHit {
    /// Ray parameter: the hit is `origin + t * dir`.
    pub t: f64,
    /// The triangle's index in the mesh.
    pub triangle: u32,
    /// Barycentric coordinates (u, v) of the hit: `p = (1-u-v) p0 + u p1 + v p2`.
    pub bary: [f64; 2],
}

struct Shape {
    triangle: u32,
    aabb: Aabb<f64, 3>,
    node: usize,
}

impl Bounded<f64, 3> for Shape {
    fn aabb(&self) -> Aabb<f64, 3> {
        self.aabb
    }
}

impl BHShape<f64, 3> for Shape {
    fn set_bh_node_index(&mut self, i: usize) {
        self.node = i;
    }
    fn bh_node_index(&self) -> usize {
        self.node
    }
}

impl MeshBvh {
    /// Build the hierarchy of `mesh` (in parallel); an empty mesh gets one node with two empty
    /// children.
    pub fn build(mesh: &Mesh) -> Self {
        let mut shapes: Vec<Shape> = (0..mesh.triangles.len())
            .map(|i| {
                let [a, b, c] = mesh.corners_m(i);
                Shape { triangle: i as u32, aabb: Aabb::with_bounds(a.inf(&b).inf(&c), a.sup(&b).sup(&c)), node: 0 }
            })
            .collect();
        let empty = BvhNode { lo: [Point3::from([f64::INFINITY; 3]); 2], hi: [Point3::from([f64::NEG_INFINITY; 3]); 2], child: [LEAF; 2] };
        if shapes.is_empty() {
            return Self { nodes: vec![empty], order: Vec::new() };
        }
        let built = bvh::bvh::Bvh::build_with_executor(&mut shapes, bvh::bvh::rayon_executor);
        let mut relay = Relay { src: &built.nodes, shapes: &shapes, nodes: Vec::with_capacity(shapes.len()), order: Vec::with_capacity(shapes.len()) };
        if relay.count(0) <= LEAF_SIZE as usize {
            let (lo, hi) = shapes.iter().fold((empty.lo[0], empty.hi[0]), |(lo, hi), s| (lo.inf(&s.aabb.min), hi.sup(&s.aabb.max)));
            let leaf = relay.leaf(0);
            relay.nodes.push(BvhNode { lo: [lo, empty.lo[1]], hi: [hi, empty.hi[1]], child: [leaf, leaf] });
        } else {
            relay.node(0);
        }
        Self { nodes: relay.nodes, order: relay.order }
    }

    /// The longest root-to-leaf path, in inner nodes (the stack a traversal needs is at most this).
    pub fn depth(&self) -> usize {
        fn down(nodes: &[BvhNode], i: usize) -> usize {
            1 + nodes[i].child.iter().filter(|c| *c & LEAF == 0).map(|c| down(nodes, *c as usize)).max().unwrap_or(0)
        }
        down(&self.nodes, 0)
    }

    /// The boxes `levels` below the root (fewer where leaves come first), `(lo, hi)`: together
    /// they hold every triangle.
    pub fn boxes_at(&self, levels: u32) -> Vec<(Point3<f64>, Point3<f64>)> {
        let mut out = Vec::new();
        let mut todo = vec![(0u32, 1u32)];
        while let Some((n, level)) = todo.pop() {
            let node = &self.nodes[n as usize];
            for k in 0..2 {
                if node.lo[k].x > node.hi[k].x {
                    continue;
                }
                if node.child[k] & LEAF != 0 || level >= levels {
                    out.push((node.lo[k], node.hi[k]));
                } else {
                    todo.push((node.child[k], level + 1));
                }
            }
        }
        out
    }

    /// The closest hit of the ray `origin + t dir`, `t` in `(t_min, t_max)`, with `mesh`
    /// (the mesh this hierarchy was built from), or `None`.
    pub fn cast(&self, mesh: &Mesh, origin: &Point3<f64>, dir: &Vector3<f64>, t_min: f64, t_max: f64) -> Option<RayHit> {
        let inv = dir.map(|v| 1.0 / v);
        let mut best: Option<RayHit> = None;
        let mut t_far = t_max;
        let mut stack = vec![0u32];
        while let Some(n) = stack.pop() {
            let node = &self.nodes[n as usize];
            let enter = [0, 1].map(|k| slab(&node.lo[k], &node.hi[k], origin, &inv, t_min, t_far));
            let (ks, count) = order(enter);
            for &k in &ks[..count] {
                let c = node.child[k];
                if c & LEAF != 0 {
                    let (first, count) = leaf_run(c);
                    for &tri in &self.order[first as usize..(first + count) as usize] {
                        if let Some(h) = hit_triangle(mesh, tri, origin, dir, t_min, t_far) {
                            t_far = h.t;
                            best = Some(h);
                        }
                    }
                } else {
                    stack.push(c);
                }
            }
        }
        best
    }
}

/// Children with a hit, farther first (so the nearer is popped first); leaves are tested in
/// that order too, which only changes the order of tests.
fn order(enter: [Option<f64>; 2]) -> ([usize; 2], usize) {
    match enter {
        [Some(a), Some(b)] if a < b => ([1, 0], 2),
        [Some(_), Some(_)] => ([0, 1], 2),
        [Some(_), None] => ([0, 0], 1),
        [None, Some(_)] => ([1, 1], 1),
        [None, None] => ([0, 0], 0),
    }
}

/// The crate's hierarchy re-laid: inner nodes with both children's boxes, small subtrees
/// collapsed into leaves.
struct Relay<'a> {
    src: &'a [bvh::bvh::BvhNode<f64, 3>],
    shapes: &'a [Shape],
    nodes: Vec<BvhNode>,
    order: Vec<u32>,
}

impl Relay<'_> {
    /// Triangles under the crate's node `i`.
    fn count(&self, i: usize) -> usize {
        match self.src[i] {
            bvh::bvh::BvhNode::Leaf { .. } => 1,
            bvh::bvh::BvhNode::Node { child_l_index, child_r_index, .. } => self.count(child_l_index) + self.count(child_r_index),
        }
    }

    /// Append the triangles under node `i` to the order; the leaf child naming them.
    fn leaf(&mut self, i: usize) -> u32 {
        let first = self.order.len() as u32;
        let mut todo = vec![i];
        while let Some(n) = todo.pop() {
            match self.src[n] {
                bvh::bvh::BvhNode::Leaf { shape_index, .. } => self.order.push(self.shapes[shape_index].triangle),
                bvh::bvh::BvhNode::Node { child_l_index, child_r_index, .. } => todo.extend([child_r_index, child_l_index]),
            }
        }
        LEAF | ((self.order.len() as u32 - first - 1) << COUNT_SHIFT) | first
    }

    /// Re-lay the crate's inner node `i` and its subtree; returns its index.
    fn node(&mut self, i: usize) -> u32 {
        let bvh::bvh::BvhNode::Node { child_l_index, child_l_aabb, child_r_index, child_r_aabb, .. } = self.src[i] else {
            return LEAF; // Unreachable: callers pass inner nodes.
        };
        let me = self.nodes.len();
        self.nodes.push(BvhNode { lo: [child_l_aabb.min, child_r_aabb.min], hi: [child_l_aabb.max, child_r_aabb.max], child: [0, 0] });
        for (k, c) in [child_l_index, child_r_index].into_iter().enumerate() {
            let idx = if self.count(c) <= LEAF_SIZE as usize { self.leaf(c) } else { self.node(c) };
            self.nodes[me].child[k] = idx;
        }
        me as u32
    }
}

/// Entry parameter of the ray into the box, if it meets it within `(t_min, t_max)`.
fn slab(lo: &Point3<f64>, hi: &Point3<f64>, o: &Point3<f64>, inv: &Vector3<f64>, t_min: f64, t_max: f64) -> Option<f64> {
    let (mut t0, mut t1) = (t_min, t_max);
    for a in 0..3 {
        let (mut ta, mut tb) = ((lo[a] - o[a]) * inv[a], (hi[a] - o[a]) * inv[a]);
        if ta > tb {
            std::mem::swap(&mut ta, &mut tb);
        }
        // NaN (a zero direction component on a box face) keeps the slab open.
        t0 = if ta > t0 { ta } else { t0 };
        t1 = if tb < t1 { tb } else { t1 };
    }
    (t0 <= t1).then_some(t0)
}

fn hit_triangle(mesh: &Mesh, tri: u32, o: &Point3<f64>, d: &Vector3<f64>, t_min: f64, t_max: f64) -> Option<RayHit> {
    let (t, u, v) = intersect_triangle(&mesh.corners_m(tri as usize), o, d)?;
    (t > t_min && t < t_max).then_some(RayHit { t, triangle: tri, bary: [u, v] })
}

/// Möller-Trumbore, two-sided: `(t, u, v)` of the ray's hit with the triangle's plane inside the
/// triangle (edges included), or `None` (parallel, or outside).
pub fn intersect_triangle(p: &[Point3<f64>; 3], o: &Point3<f64>, d: &Vector3<f64>) -> Option<(f64, f64, f64)> {
    let (e1, e2) = (p[1] - p[0], p[2] - p[0]);
    let pv = d.cross(&e2);
    let det = e1.dot(&pv);
    if det == 0.0 || !det.is_finite() {
        return None;
    }
    let inv = 1.0 / det;
    let s = o - p[0];
    let u = s.dot(&pv) * inv;
    if !(0.0..=1.0).contains(&u) {
        return None;
    }
    let q = s.cross(&e1);
    let v = d.dot(&q) * inv;
    if v < 0.0 || u + v > 1.0 {
        return None;
    }
    Some((e2.dot(&q) * inv, u, v))
}

/// The closest hit by testing every triangle: the check of [`MeshBvh::cast`] and of the shader.
pub fn cast_brute(mesh: &Mesh, origin: &Point3<f64>, dir: &Vector3<f64>, t_min: f64, t_max: f64) -> Option<RayHit> {
    let mut best: Option<RayHit> = None;
    for i in 0..mesh.triangles.len() as u32 {
        if let Some(h) = hit_triangle(mesh, i, origin, dir, t_min, best.map_or(t_max, |b| b.t)) {
            best = Some(h);
        }
    }
    best
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::mesh::Triangle;
    use rand::{Rng, SeedableRng};

    /// A random triangle soup in the unit cube.
    fn soup(n: usize, seed: u64) -> Mesh {
        let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(seed);
        let mut positions_m = Vec::new();
        let mut triangles = Vec::new();
        for i in 0..n as u32 {
            let c = Point3::new(rng.random::<f64>(), rng.random::<f64>(), rng.random::<f64>());
            for _ in 0..3 {
                positions_m.push(c + Vector3::new(rng.random::<f64>(), rng.random::<f64>(), rng.random::<f64>()).map(|v| (v - 0.5) * 0.2));
            }
            triangles.push(Triangle { v: [3 * i, 3 * i + 1, 3 * i + 2], uv: None, albedo: None });
        }
        Mesh { name: "soup".into(), positions_m, triangles, texture: None }
    }

    #[test]
    fn bvh_cast_equals_brute_force_on_random_rays() {
        let mesh = soup(2000, 7);
        let bvh = MeshBvh::build(&mesh);
        assert!(bvh.depth() < 64, "depth {}", bvh.depth());
        let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(9);
        let mut hits = 0;
        for _ in 0..3000 {
            let o = Point3::new(rng.random::<f64>() * 3.0 - 1.0, rng.random::<f64>() * 3.0 - 1.0, -1.0);
            let target = Point3::new(rng.random::<f64>(), rng.random::<f64>(), rng.random::<f64>());
            let d = target - o;
            let a = bvh.cast(&mesh, &o, &d, 0.0, f64::INFINITY);
            let b = cast_brute(&mesh, &o, &d, 0.0, f64::INFINITY);
            assert_eq!(a.map(|h| h.triangle), b.map(|h| h.triangle));
            hits += usize::from(a.is_some());
        }
        assert!(hits > 1000, "{hits} hits");
    }

    #[test]
    fn one_triangle_and_axis_parallel_rays() {
        let mut mesh = soup(1, 1);
        mesh.positions_m = vec![Point3::new(0.0, 0.0, 1.0), Point3::new(1.0, 0.0, 1.0), Point3::new(0.0, 1.0, 1.0)];
        let bvh = MeshBvh::build(&mesh);
        let h = bvh.cast(&mesh, &Point3::new(0.25, 0.25, 0.0), &Vector3::z(), 0.0, 10.0).expect("hit");
        assert!((h.t - 1.0).abs() < 1e-15 && (h.bary[0] - 0.25).abs() < 1e-15 && (h.bary[1] - 0.25).abs() < 1e-15);
        assert!(bvh.cast(&mesh, &Point3::new(0.75, 0.75, 0.0), &Vector3::z(), 0.0, 10.0).is_none());
        assert!(bvh.cast(&mesh, &Point3::new(0.25, 0.25, 0.0), &Vector3::z(), 0.0, 0.5).is_none(), "t_max bounds the ray");
    }
}
