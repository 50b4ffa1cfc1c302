// ---------------------------------------------------------------- objects (meshes)
// The last of the shader files (crates/render/src/shader.rs `SHADER` concatenates them). The user's meshes, each
// an instance of a mesh whose BVH and triangles live in `objs` (crates/render/src/objects.rs lays it out):
//   instance i (at P.obj.y + 5 i): rows 0..2 the affine map from the camera frame to the mesh
//     frame (object_from_cam / scale: xyz = matrix row, w = offset); row 3 = (node offset,
//     triangle offset, texture offset, texture width) as u32 bits; row 4 = (albedo, texture
//     height as u32 bits, flags: bit 0 head light, 0).
//   node (4 rows): (lo0, child0), (hi0, child1), (lo1, 0), (hi1, 0); a child with bit 31 set is
//     a leaf, a run of up to 4 triangle rows (crates/core/src/mesh/bvh.rs).
//   triangle (4 rows): (v0, albedo: >= 0 its material, -1 the instance's, -2 textured),
//     (e1, uv0.x), (e2, uv0.y), (uv1, uv2).
//   texture: per row, the prefix sums of its texels (width + 1 each), four per row of objs.
// Every ray is the camera ray of the existing per-pixel lens inversion (pixel_ray), so objects
// are exact under every lens model. Targets and objects occlude each other by ray parameter:
// the target sheet (P.sheet, in its plane P.plane) is at t = c / (n . d).
// Mirrors: crates/scene/src/objects.rs (CPU, f64).

@group(0) @binding(8) var<storage, read> objs: array<vec4<f32>>;

const LEAF_BIT: u32 = 0x80000000u;
// Traversal stack; the CPU refuses meshes whose hierarchy is deeper (crates/render/src/objects.rs).
const MESH_STACK: u32 = 48u;
const NO_OBJECT: u32 = 0xffffffffu;

struct MeshHit { t: f32, inst: u32, tri: u32, bary: vec2<f32>, };

fn no_hit(t_max: f32) -> MeshHit { return MeshHit(t_max, NO_OBJECT, 0u, vec2<f32>(0.0, 0.0)); }

// Entry parameter of the ray into the box, or -1 when it misses within (0, t_max).
fn box_entry(lo: vec3<f32>, hi: vec3<f32>, o: vec3<f32>, inv: vec3<f32>, t_max: f32) -> f32 {
    let a = (lo - o) * inv;
    let b = (hi - o) * inv;
    let tn = max(max(min(a.x, b.x), min(a.y, b.y)), max(min(a.z, b.z), 0.0));
    let tf = min(min(max(a.x, b.x), max(a.y, b.y)), min(max(a.z, b.z), t_max));
    return select(-1.0, tn, tn <= tf);
}

// Moller-Trumbore (two-sided) against triangle k of the instance's mesh.
fn hit_triangle(tri_base: u32, k: u32, o: vec3<f32>, d: vec3<f32>, best: MeshHit, inst: u32) -> MeshHit {
    let b = tri_base + 4u * k;
    let v0 = objs[b].xyz;
    let e1 = objs[b + 1u].xyz;
    let e2 = objs[b + 2u].xyz;
    let pv = cross3(d, e2);
    let det = dot3(e1, pv);
    let inv = 1.0 / det;
    let s = o - v0;
    let u = dot3(s, pv) * inv;
    let q = cross3(s, e1);
    let v = dot3(d, q) * inv;
    let t = dot3(e2, q) * inv;
    if (det != 0.0 && u >= 0.0 && v >= 0.0 && u + v <= 1.0 && t > 0.0 && t < best.t) {
        return MeshHit(t, inst, k, vec2<f32>(u, v));
    }
    return best;
}

// A leaf child: LEAF_BIT | (count - 1) << 27 | first triangle row (crates/core/src/mesh/bvh.rs leaf_run).
fn leaf_first(c: u32) -> u32 { return c & 0x7ffffffu; }
fn leaf_end(c: u32) -> u32 { return (c & 0x7ffffffu) + ((c >> 27u) & 0xfu) + 1u; }

// The closest hit among the leaf's triangles.
fn hit_leaf(tri_base: u32, c: u32, o: vec3<f32>, d: vec3<f32>, best_in: MeshHit, inst: u32) -> MeshHit {
    var best = best_in;
    for (var k = leaf_first(c); k < leaf_end(c); k = k + 1u) {
        best = hit_triangle(tri_base, k, o, d, best, inst);
    }
    return best;
}

// The ray t d_cam (camera centre origin) in instance `inst`'s mesh frame: origin, direction.
fn instance_ray(inst: u32, d_cam: vec3<f32>) -> array<vec3<f32>, 2> {
    let base = P.obj.y + 5u * inst;
    let r0 = objs[base];
    let r1 = objs[base + 1u];
    let r2 = objs[base + 2u];
    return array<vec3<f32>, 2>(vec3<f32>(r0.w, r1.w, r2.w), vec3<f32>(dot3(r0.xyz, d_cam), dot3(r1.xyz, d_cam), dot3(r2.xyz, d_cam)));
}

// The four rows of node `node` of a mesh whose nodes start at row `base`.
fn node_rows(base: u32, node: u32) -> array<vec4<f32>, 4> {
    let nb = base + 4u * node;
    return array<vec4<f32>, 4>(objs[nb], objs[nb + 1u], objs[nb + 2u], objs[nb + 3u]);
}

// The next node of a traversal: the near child when both are entered (the far one pushed), the
// one entered, else the top of the stack; NO_OBJECT when the stack is empty.
fn next_node(stack: ptr<function, array<u32, MESH_STACK>>, sp: ptr<function, u32>, go_near: bool, go_far: bool, near: u32, far: u32) -> u32 {
    if (go_near && go_far) {
        (*stack)[*sp] = far;
        *sp = min(*sp + 1u, MESH_STACK - 1u);
        return near;
    }
    if (go_near) { return near; }
    if (go_far) { return far; }
    if (*sp == 0u) { return NO_OBJECT; }
    *sp = *sp - 1u;
    return (*stack)[*sp];
}

// The closest hit of instance `inst` nearer than best.t: nearer child first, the other pushed
// (Aila and Laine 2009), leaves tested as they are met.
fn cast_instance(inst: u32, d_cam: vec3<f32>, best_in: MeshHit) -> MeshHit {
    let od = instance_ray(inst, d_cam);
    return cast_instance_ray(inst, od[0], od[1], best_in);
}

// cast_instance for the ray o + t d of the instance's mesh frame.
fn cast_instance_ray(inst: u32, o: vec3<f32>, d: vec3<f32>, best_in: MeshHit) -> MeshHit {
    let info = bitcast<vec4<u32>>(objs[P.obj.y + 5u * inst + 3u]);
    let inv = 1.0 / select(d, vec3<f32>(1e-30, 1e-30, 1e-30), abs(d) < vec3<f32>(1e-30, 1e-30, 1e-30));
    var best = best_in;
    var stack: array<u32, MESH_STACK>;
    var sp = 0u;
    var node = 0u;
    loop {
        // The hot loop of the coarse pass keeps its loads and stack step inline (through
        // node_rows / next_node, as in gather_instance, the frame took 10 % longer on llvmpipe).
        let nb = info.x + 4u * node;
        let a = objs[nb];
        let b = objs[nb + 1u];
        let t0 = box_entry(a.xyz, b.xyz, o, inv, best.t);
        let t1 = box_entry(objs[nb + 2u].xyz, objs[nb + 3u].xyz, o, inv, best.t);
        let c0 = bitcast<u32>(a.w);
        let c1 = bitcast<u32>(b.w);
        var go0 = t0 >= 0.0;
        var go1 = t1 >= 0.0;
        if (go0 && (c0 & LEAF_BIT) != 0u) { best = hit_leaf(info.y, c0, o, d, best, inst); go0 = false; }
        if (go1 && (c1 & LEAF_BIT) != 0u) { best = hit_leaf(info.y, c1, o, d, best, inst); go1 = false; }
        if (go0 && go1) {
            let first = t1 < t0;
            stack[sp] = select(c1, c0, first);
            sp = min(sp + 1u, MESH_STACK - 1u);
            node = select(c0, c1, first);
        } else if (go0) {
            node = c0;
        } else if (go1) {
            node = c1;
        } else {
            if (sp == 0u) { break; }
            sp = sp - 1u;
            node = stack[sp];
        }
    }
    return best;
}

// The closest object along t d_cam nearer than t_max (inst = NO_OBJECT: none).
fn cast_objects(d_cam: vec3<f32>, t_max: f32) -> MeshHit {
    var best = no_hit(t_max);
    for (var i = 0u; i < P.obj.x; i = i + 1u) {
        best = cast_instance(i, d_cam, best);
    }
    return best;
}

// Whether the target point t d_cam lies in an object's shadow: its ray towards the light (P.sun)
// meets an instance (crates/scene/src/shadow.rs).
fn shadowed(d_cam: vec3<f32>, t: f32) -> bool {
    if (P.sun.x == 0.0 && P.sun.y == 0.0 && P.sun.z == 0.0) { return false; }
    return blocked(d_cam, t, P.sun.xyz, 3e38);
}

// Whether an instance meets the ray from the target point t d_cam along `dir` (camera frame)
// before parameter s_max.
fn blocked(d_cam: vec3<f32>, t: f32, dir: vec3<f32>, s_max: f32) -> bool {
    for (var i = 0u; i < P.obj.x; i = i + 1u) {
        // The camera ray in the mesh frame (as the camera's own casts take it: no arithmetic on
        // the ray's literal z, which Mesa's SPIR-V and GLSL paths fold differently), to t.
        let od = instance_ray(i, d_cam);
        let o = od[0] + t * od[1];
        if (cast_instance_ray(i, o, mesh_dir(i, dir), no_hit(s_max)).inst != NO_OBJECT) { return true; }
    }
    return false;
}

// Direction d (camera frame) in instance inst's mesh frame.
fn mesh_dir(inst: u32, d: vec3<f32>) -> vec3<f32> {
    let base = P.obj.y + 5u * inst;
    return vec3<f32>(dot3(objs[base].xyz, d), dot3(objs[base + 1u].xyz, d), dot3(objs[base + 2u].xyz, d));
}

// The target point t d_cam's shading in an object's shadow over its lit shading, and whether it
// is shadowed (x: 1) at all: the directional light's constant ratio (P.sun.w); under the area
// light the pixel's (soft_pixel, computed once per pixel: soft shadows vary smoothly).
fn shadow_ratio(d_cam: vec3<f32>, t: f32) -> vec2<f32> {
    if (P.soft_u.w == 1.0) { return soft; }
    return vec2<f32>(select(0.0, 1.0, shadowed(d_cam, t)), P.sun.w);
}

// The pixel's soft-shadow ratio (soft_pixel) where an area light casts the objects' shadows.
var<private> soft: vec2<f32>;

// Under the area light, the mean over the pixel of the target's shading in the objects' shadow
// over its mean lit shading, (A + E V) / (A + E) with the light's closed-form term E
// (planar.wgsl area_irradiance) and its visible share V (light_share, each point its own rows;
// or bilinear from the soft-shadow lattice where the pixel's quad takes it: lattice_mode), at
// 2 x 2 sub-pixel points; x: 1 when some of the light is hidden from one of them. (0, 1)
// without an area light.
fn soft_pixel(centre: Ray, px: vec2<u32>) -> vec2<f32> {
    if (P.soft_u.w != 1.0 || !centre.ok) { return vec2<f32>(0.0, 1.0); }
    let quad = px / QUAD;
    let mode = lattice_mode(quad);
    var shaded = 0.0;
    var lit = 0.0;
    var hidden = 0.0;
    for (var k = 0u; k < 4u; k = k + 1u) {
        let o = vec2<f32>(f32(k % 2u), f32(k / 2u)) * 0.5 - 0.25;
        let d = ray_at(centre, o);
        let t = target_t(d);
        if (t < 3e38) {
            var v = 1.0;
            if (mode != 0u) {
                v = lattice_lerp(quad, mode, vec2<f32>(px) + o);
            } else if (light_may_be_hidden(d, t)) {
                v = light_share(d, t, (f32(k) + 0.5) * 0.25);
            }
            let e = area_irradiance(plane_point(d).xy);
            shaded = shaded + P.soft_c.w + e * v;
            lit = lit + P.soft_c.w + e;
            hidden = select(hidden, 1.0, v < 1.0);
        }
    }
    return vec2<f32>(hidden, select(1.0, shaded / lit, lit > 0.0));
}

// The soft-shadow lattice (crates/render/src/soft_lattice.rs), where P.soft_v.w > 0 gives its
// first row in objs: the visible share V at the points (QUAD a - 0.5, QUAD b - 0.5) of the image
// (2 tiles_x + 1 per row, 2 tiles_y + 1 rows; -1 where not computed or the ray misses the
// target's plane: V is computed on the plane past the sheet's edge too), then per
// 4 x 4 quad of pixels how it takes V: 2 bilinearly from its tile's corners, 1 from its own, 0
// each pixel integrating its own (the CPU's checks of the lattice's second differences and of
// the cells' centres against the tolerance). Soft shadows vary smoothly: interpolated pixels
// cost no shadow ray.
const QUAD: u32 = 4u;
// Phases of light_share at a lattice point: LIGHT_ROWS times as many rows of the emitter.
const LATTICE_PHASES: u32 = 4u;

fn lattice_at(k: u32) -> f32 {
    let r = objs[u32(P.soft_v.w) + k / 4u];
    return r[k % 4u];
}

// How the pixels of quad `quad` take V (2, 1 or 0, above); 0 without a lattice.
fn lattice_mode(quad: vec2<u32>) -> u32 {
    if (P.soft_v.w <= 0.0) { return 0u; }
    let points = (2u * P.tiles.x + 1u) * (2u * P.tiles.y + 1u);
    return u32(lattice_at(points + quad.y * 2u * P.tiles.x + quad.x));
}

// V at the image point q (pixels) of quad `quad`, bilinear over its cell: the tile's (mode 2)
// or the quad's own (mode 1).
fn lattice_lerp(quad: vec2<u32>, mode: u32, q: vec2<f32>) -> f32 {
    let step = select(1u, 2u, mode == 2u);
    let cell = quad / step * step;
    let uv = (q + 0.5 - vec2<f32>(cell * QUAD)) / f32(step * QUAD);
    let n = 2u * P.tiles.x + 1u;
    let k = cell.y * n + cell.x;
    let top = mix(lattice_at(k), lattice_at(k + step), uv.x);
    let bottom = mix(lattice_at(k + step * n), lattice_at(k + step * n + step), uv.x);
    return mix(top, bottom, uv.y);
}

// The lattice's own values (P.soft_v.w == -1: the fine entry evaluates work items as lattice
// points): V at the point q of the image, the mean over LATTICE_PHASES phases of light_share;
// -1 where q's ray misses the target's plane (beyond the sheet, the plane: V is smooth across
// the sheet's edge).
fn lattice_share(q: vec2<f32>) -> f32 {
    let ray = pixel_ray(q);
    let d = ray_d(ray);
    let t = plane_t(d);
    var v = -1.0;
    if (ray.ok && t < 3e38) {
        v = 1.0;
        if (light_may_be_hidden(d, t)) {
            v = 0.0;
            for (var k = 0u; k < LATTICE_PHASES; k = k + 1u) { v = v + light_share(d, t, (f32(k) + 0.5) / f32(LATTICE_PHASES)) / f32(LATTICE_PHASES); }
        }
    }
    return v;
}

// Whether an instance may hide the light points at `to` (four, relative to the target point
// t d_cam) from that point: the bounding box of the point and them (mesh frame) meets one of the
// boxes of the instance's hierarchy's root's two children. Pixels far from every shadow
// (light_may_be_hidden) cast no shadow ray.
fn hull_meets_objects(d_cam: vec3<f32>, t: f32, to: array<vec3<f32>, 4>) -> bool {
    for (var i = 0u; i < P.obj.x; i = i + 1u) {
        let od = instance_ray(i, d_cam);
        let o = od[0] + t * od[1];
        var lo = o;
        var hi = o;
        for (var k = 0u; k < 4u; k = k + 1u) {
            let c = o + mesh_dir(i, to[k]);
            lo = min(lo, c);
            hi = max(hi, c);
        }
        let nb = bitcast<vec4<u32>>(objs[P.obj.y + 5u * i + 3u]).x;
        let meets0 = all(lo <= objs[nb + 1u].xyz) && all(objs[nb].xyz <= hi);
        let meets1 = all(lo <= objs[nb + 3u].xyz) && all(objs[nb + 2u].xyz <= hi);
        if (meets0 || meets1) { return true; }
    }
    return false;
}

// Whether an object may hide some of the light from the target point t d_cam: hull_meets_objects
// for the whole light's rectangle, then shaft_meets_objects. `false` proves the light wholly visible.
fn light_may_be_hidden(d_cam: vec3<f32>, t: f32) -> bool {
    let x = t * d_cam;
    let c = P.soft_c.xyz - x;
    let to = array<vec3<f32>, 4>(c, c + P.soft_u.xyz, c + P.soft_u.xyz + P.soft_v.xyz, c + P.soft_v.xyz);
    return hull_meets_objects(d_cam, t, to) && shaft_meets_objects(d_cam, t, to);
}

// A shaft (mesh frame): the pyramid from a point through the light's corners, cut by the light's
// plane; five planes n . p >= w (n unit) bound it.
struct Shaft { n: array<vec3<f32>, 5>, w: array<f32, 5>, corners: array<vec3<f32>, 5>, };

// How far beyond a plane a box or triangle must lie to be outside the shaft (mesh units): f32
// rounding must not prove a light visible that a triangle grazes.
const SHAFT_SLACK: f32 = 1e-5;

// The shaft of instance `inst` from its mesh-frame point o to the light corners `to` (camera
// frame, relative to the point, in order around the rectangle).
fn light_shaft(inst: u32, o: vec3<f32>, to: array<vec3<f32>, 4>) -> Shaft {
    var s: Shaft;
    let mc = mesh_dir(inst, 0.25 * (to[0] + to[1] + to[2] + to[3]));
    for (var k = 0u; k < 4u; k = k + 1u) {
        let p = cross3(mesh_dir(inst, to[k]), mesh_dir(inst, to[(k + 1u) % 4u]));
        let n = normalize(select(-p, p, dot3(p, mc) >= 0.0));
        s.n[k] = n;
        s.w[k] = dot3(n, o);
    }
    s.corners[4] = o;
    for (var k = 0u; k < 4u; k = k + 1u) { s.corners[k] = o + mesh_dir(inst, to[k]); }
    let e = normalize(mesh_dir(inst, cross(P.soft_u.xyz, P.soft_v.xyz)));
    let l0 = o + mesh_dir(inst, to[0]);
    let n = select(-e, e, dot3(e, o - l0) >= 0.0);
    s.n[4] = n;
    s.w[4] = dot3(n, l0);
    return s;
}

// Whether the box lo..hi may meet the shaft: not behind any of its planes.
fn box_in_shaft(lo: vec3<f32>, hi: vec3<f32>, s: Shaft) -> bool {
    var inside = lo.x <= hi.x;
    for (var k = 0u; k < 5u; k = k + 1u) {
        let far = select(lo, hi, s.n[k] > vec3<f32>(0.0, 0.0, 0.0));
        inside = inside && dot3(s.n[k], far) >= s.w[k] - SHAFT_SLACK;
    }
    return inside;
}

// Whether a triangle of leaf c may meet the shaft: no plane of the shaft has all three corners
// behind it, and the triangle's own plane does not have all five corners of the shaft on one
// side (separating planes: a large face beside the shaft's edge passes the first test alone).
fn leaf_in_shaft(tri_base: u32, c: u32, s: Shaft) -> bool {
    for (var k = leaf_first(c); k < leaf_end(c); k = k + 1u) {
        let b = tri_base + 4u * k;
        let v0 = objs[b].xyz;
        let e1 = objs[b + 1u].xyz;
        let e2 = objs[b + 2u].xyz;
        let v1 = v0 + e1;
        let v2 = v0 + e2;
        var inside = true;
        for (var j = 0u; j < 5u; j = j + 1u) {
            let lim = s.w[j] - SHAFT_SLACK;
            inside = inside && !(dot3(s.n[j], v0) < lim && dot3(s.n[j], v1) < lim && dot3(s.n[j], v2) < lim);
        }
        let n = cross3(e1, e2);
        let slack = SHAFT_SLACK * length(n);
        var above = 0u;
        var below = 0u;
        for (var j = 0u; j < 5u; j = j + 1u) {
            let side = dot3(n, s.corners[j] - v0);
            above = above + select(0u, 1u, side > slack);
            below = below + select(0u, 1u, side < -slack);
        }
        if (inside && above < 5u && below < 5u) { return true; }
    }
    return false;
}

// Whether a triangle of an object may lie in the shaft from the target point t d_cam to the
// area light's corners `to`: a traversal of each instance's hierarchy entering the boxes the
// shaft may meet, its leaves' triangles tested against the shaft's planes. Conservative (boxes
// and triangles are outside only when wholly behind one plane, or a triangle's plane has the
// whole shaft on one side): `false` proves every light
// point visible from the target point, so light_share (LIGHT_ROWS rows, each a traversal) is not
// needed.
fn shaft_meets_objects(d_cam: vec3<f32>, t: f32, to: array<vec3<f32>, 4>) -> bool {
    for (var i = 0u; i < P.obj.x; i = i + 1u) {
        let od = instance_ray(i, d_cam);
        let s = light_shaft(i, od[0] + t * od[1], to);
        let info = bitcast<vec4<u32>>(objs[P.obj.y + 5u * i + 3u]);
        var stack: array<u32, MESH_STACK>;
        var sp = 0u;
        var node = 0u;
        loop {
            let r = node_rows(info.x, node);
            var go0 = box_in_shaft(r[0].xyz, r[1].xyz, s);
            var go1 = box_in_shaft(r[2].xyz, r[3].xyz, s);
            let c0 = bitcast<u32>(r[0].w);
            let c1 = bitcast<u32>(r[1].w);
            if (go0 && (c0 & LEAF_BIT) != 0u) {
                if (leaf_in_shaft(info.y, c0, s)) { return true; }
                go0 = false;
            }
            if (go1 && (c1 & LEAF_BIT) != 0u) {
                if (leaf_in_shaft(info.y, c1, s)) { return true; }
                go1 = false;
            }
            node = next_node(&stack, &sp, go0, go1, c0, c1);
            if (node == NO_OBJECT) { break; }
        }
    }
    return false;
}

// Rows of the area light the visible share integrates over; segments per row (the trapezoid
// rule of light_weight; where a row is sampled, sampled_row, each segment's crossing bisected
// LIGHT_BISECTIONS times: there an occluder whose shadow leaves a gap narrower than a segment
// between two samples can be missed).
const LIGHT_ROWS: u32 = 16u;
const LIGHT_SEGMENTS: u32 = 8u;
const LIGHT_BISECTIONS: u32 = 7u;

// Whether the segment from the target point t d_cam to the light point at `to` (camera frame,
// relative to that point) is free of objects.
fn light_visible(d_cam: vec3<f32>, t: f32, to: vec3<f32>) -> bool {
    return !blocked(d_cam, t, to, 1.0);
}

// The weight cos_x cos_light / r^2 of the light point at `to` (relative to the target point; the
// board's camera-side normal -sign(c) n of the plane n . x = c, the emitter's u x v), up to a
// constant factor.
fn light_weight(to: vec3<f32>) -> f32 {
    let n = -sign(P.plane.w) * P.plane.xyz;
    let r2 = dot3(to, to);
    return max(dot3(n, to), 0.0) * max(-dot3(cross(P.soft_u.xyz, P.soft_v.xyz), to), 0.0) / max(r2 * r2, 1e-30);
}

// The share of the area light the objects leave visible from the target point t d_cam, weighted
// by light_weight (crates/scene/src/shadow.rs visible_share): per row of the emitter (rows at
// (r + phase) / LIGHT_ROWS: soft_pixel's four sub-pixel points take the four phases, 64 rows
// for the pixel's mean, as many as a lattice point's; the rule across rows is exact where the
// visible length is linear in the row, as behind a straight occluder edge, and errs by up to half
// a row's share where an occluder's edge runs along the rows: 8 rows a point (32 a pixel or
// lattice point) left 0.65 grey levels on a random gripper view, 16 leave 0.29) the row's
// hidden intervals in closed form (row_share), or where they are too many the row sampled
// (sampled_row).
fn light_share(d_cam: vec3<f32>, t: f32, phase: f32) -> f32 {
    let x = t * d_cam;
    var seen = 0.0;
    var all = 0.0;
    for (var r = 0u; r < LIGHT_ROWS; r = r + 1u) {
        let row = P.soft_c.xyz + P.soft_v.xyz * ((f32(r) + phase) / f32(LIGHT_ROWS)) - x;
        var share = row_share(d_cam, t, row);
        if (share.y < 0.0) { share = sampled_row(d_cam, t, row); }
        seen = seen + share.x;
        all = all + share.y;
    }
    return select(1.0, seen / all, all > 0.0);
}

// One row of the emitter (`row`: its start relative to the target point t d_cam, running along
// P.soft_u), sampled: the trapezoid rule over LIGHT_SEGMENTS segments of light_weight where
// visible, each segment whose ends differ split at its bisected crossing. (seen, all).
fn sampled_row(d_cam: vec3<f32>, t: f32, row: vec3<f32>) -> vec2<f32> {
    var seen = 0.0;
    var all = 0.0;
    var sa = 0.0;
    var va = light_visible(d_cam, t, row);
    var wa = light_weight(row);
    for (var k = 1u; k <= LIGHT_SEGMENTS; k = k + 1u) {
        let sb = f32(k) / f32(LIGHT_SEGMENTS);
        let to_b = row + P.soft_u.xyz * sb;
        let vb = light_visible(d_cam, t, to_b);
        let wb = light_weight(to_b);
        all = all + 0.5 * (wa + wb) * (sb - sa);
        if (va == vb) {
            seen = seen + select(0.0, 0.5 * (wa + wb) * (sb - sa), va);
        } else {
            var lo = sa;
            var hi = sb;
            for (var j = 0u; j < LIGHT_BISECTIONS; j = j + 1u) {
                let mid = 0.5 * (lo + hi);
                if (light_visible(d_cam, t, row + P.soft_u.xyz * mid) == va) { lo = mid; } else { hi = mid; }
            }
            let c = 0.5 * (lo + hi);
            let wc = light_weight(row + P.soft_u.xyz * c);
            seen = seen + select(0.5 * (wc + wb) * (sb - c), 0.5 * (wa + wc) * (c - sa), va);
        }
        sa = sb;
        va = vb;
        wa = wb;
    }
    return vec2<f32>(seen, all);
}

// ---- one emitter row in closed form: the row's points a + s u (s in [0, 1], relative to the
// target point o) and o span a plane; a triangle the plane cuts hides from o the central
// projection onto the row of the part of its cut between o and the light, an interval of s.
// The union of the triangles' intervals is the row's hidden part, exact; light_weight is
// integrated over the rest with the trapezoid rule on the LIGHT_SEGMENTS segments.

// Disjoint hidden intervals of the current row; `hid_full` when more would be needed.
const MAX_HIDDEN: u32 = 8u;
var<private> hid_lo: array<f32, MAX_HIDDEN>;
var<private> hid_hi: array<f32, MAX_HIDDEN>;
var<private> hid_n: u32;
var<private> hid_full: bool;

// Add [l, h] to the hidden intervals, merging those it meets (their union with it is one
// interval, which meets no other: one pass suffices).
fn hide(l_in: f32, h_in: f32) {
    var l = l_in;
    var h = h_in;
    var k = 0u;
    loop {
        if (k >= hid_n) { break; }
        if (l <= hid_hi[k] && h >= hid_lo[k]) {
            l = min(l, hid_lo[k]);
            h = max(h, hid_hi[k]);
            hid_n = hid_n - 1u;
            hid_lo[k] = hid_lo[hid_n];
            hid_hi[k] = hid_hi[hid_n];
        } else {
            k = k + 1u;
        }
    }
    if (hid_n == MAX_HIDDEN) {
        hid_full = true;
    } else {
        hid_lo[hid_n] = l;
        hid_hi[hid_n] = h;
        hid_n = hid_n + 1u;
    }
}

// A row in one instance's mesh frame: the point o, the row's start a and direction u (relative
// to o), the plane's unit normal n, the Gram matrix of (a, u) and its determinant, the box of the
// triangle o, o + a, o + a + u.
struct RowFrame { o: vec3<f32>, a: vec3<f32>, u: vec3<f32>, n: vec3<f32>, gram: vec4<f32>, lo: vec3<f32>, hi: vec3<f32>, };

fn row_frame(inst: u32, d_cam: vec3<f32>, t: f32, row: vec3<f32>) -> RowFrame {
    let od = instance_ray(inst, d_cam);
    let o = od[0] + t * od[1];
    let a = mesh_dir(inst, row);
    let u = mesh_dir(inst, P.soft_u.xyz);
    let aa = dot3(a, a);
    let au = dot3(a, u);
    let uu = dot3(u, u);
    let lo = min(o, min(o + a, o + a + u));
    let hi = max(o, max(o + a, o + a + u));
    return RowFrame(o, a, u, normalize(cross3(a, u)), vec4<f32>(aa, au, uu, aa * uu - au * au), lo, hi);
}

// The coordinates (alpha, beta) of p - o = alpha a + beta u, p in the row's plane.
fn row_coords(f: RowFrame, p: vec3<f32>) -> vec2<f32> {
    let q = p - f.o;
    let ap = dot3(f.a, q);
    let up = dot3(f.u, q);
    return vec2<f32>(f.gram.z * ap - f.gram.y * up, f.gram.x * up - f.gram.y * ap) / f.gram.w;
}

// Whether the box lo..hi may meet the triangle o, o + a, o + a + u: the boxes overlap and the
// box reaches the plane (SHAFT_SLACK each).
fn box_meets_row(lo: vec3<f32>, hi: vec3<f32>, f: RowFrame) -> bool {
    let apart = any(hi < f.lo - vec3<f32>(SHAFT_SLACK)) || any(lo > f.hi + vec3<f32>(SHAFT_SLACK));
    let c = 0.5 * (lo + hi);
    let reach = dot3(abs(f.n), 0.5 * (hi - lo));
    return !apart && lo.x <= hi.x && abs(dot3(f.n, c - f.o)) <= reach + SHAFT_SLACK;
}

// The interval of the row the triangle v0 v1 v2 hides from o: where the plane cuts it (the
// crossings of the two edges whose ends lie on opposite sides), the cut clipped to 0 < alpha <= 1
// (between o and the light), its ends projected from o onto the row (s = beta / alpha: a
// segment with alpha > 0 projects onto the interval between its ends' projections).
fn hide_triangle(f: RowFrame, v0: vec3<f32>, v1: vec3<f32>, v2: vec3<f32>) {
    let v = array<vec3<f32>, 3>(v0, v1, v2);
    let d = array<f32, 3>(dot3(f.n, v0 - f.o), dot3(f.n, v1 - f.o), dot3(f.n, v2 - f.o));
    var ends: array<vec2<f32>, 2>;
    var m = 0u;
    for (var e = 0u; e < 3u; e = e + 1u) {
        let j = (e + 1u) % 3u;
        if ((d[e] >= 0.0) != (d[j] >= 0.0)) {
            ends[min(m, 1u)] = row_coords(f, v[e] + (v[j] - v[e]) * (d[e] / (d[e] - d[j])));
            m = m + 1u;
        }
    }
    if (m < 2u) { return; }
    var p1 = ends[0];
    var p2 = ends[1];
    if (p1.x > p2.x) {
        p1 = ends[1];
        p2 = ends[0];
    }
    if (p2.x <= ALPHA_MIN || p1.x >= 1.0) { return; }
    if (p1.x < ALPHA_MIN) { p1 = mix(p1, p2, (ALPHA_MIN - p1.x) / (p2.x - p1.x)); }
    if (p2.x > 1.0) { p2 = mix(p1, p2, (1.0 - p1.x) / (p2.x - p1.x)); }
    let s1 = p1.y / p1.x;
    let s2 = p2.y / p2.x;
    let l = max(min(s1, s2), 0.0);
    let h = min(max(s1, s2), 1.0);
    if (l < h) { hide(l, h); }
}

// A cut this near o (in units of the way to the light) is o's own surface, not an occluder.
const ALPHA_MIN: f32 = 1e-5;

// hide_triangle for every triangle of instance `inst` the row's plane may cut: a traversal of
// its hierarchy entering the boxes box_meets_row keeps. (The traversal's loop is the one of
// shaft_meets_objects and gather_instance with another box test and leaf action: WGSL passes no
// functions, so each keeps its own.)
fn hide_instance(inst: u32, f: RowFrame) {
    let info = bitcast<vec4<u32>>(objs[P.obj.y + 5u * inst + 3u]);
    var stack: array<u32, MESH_STACK>;
    var sp = 0u;
    var node = 0u;
    loop {
        let r = node_rows(info.x, node);
        var go0 = box_meets_row(r[0].xyz, r[1].xyz, f);
        var go1 = box_meets_row(r[2].xyz, r[3].xyz, f);
        let c0 = bitcast<u32>(r[0].w);
        let c1 = bitcast<u32>(r[1].w);
        if (go0 && (c0 & LEAF_BIT) != 0u) {
            hide_leaf(info.y, c0, f);
            go0 = false;
        }
        if (go1 && (c1 & LEAF_BIT) != 0u && c1 != c0) { hide_leaf(info.y, c1, f); }
        if ((c1 & LEAF_BIT) != 0u) { go1 = false; }
        node = next_node(&stack, &sp, go0, go1, c0, c1);
        if (node == NO_OBJECT) { break; }
    }
}

fn hide_leaf(tri_base: u32, c: u32, f: RowFrame) {
    for (var k = leaf_first(c); k < leaf_end(c); k = k + 1u) {
        let b = tri_base + 4u * k;
        let v0 = objs[b].xyz;
        hide_triangle(f, v0, v0 + objs[b + 1u].xyz, v0 + objs[b + 2u].xyz);
    }
}

// One row of the emitter (as sampled_row) in closed form: (seen, all), all = -1 where the hidden
// intervals overflow MAX_HIDDEN.
fn row_share(d_cam: vec3<f32>, t: f32, row: vec3<f32>) -> vec2<f32> {
    hid_n = 0u;
    hid_full = false;
    for (var i = 0u; i < P.obj.x; i = i + 1u) { hide_instance(i, row_frame(i, d_cam, t, row)); }
    if (hid_full) { return vec2<f32>(0.0, -1.0); }
    var all = 0.0;
    var hidden = 0.0;
    var sa = 0.0;
    var wa = light_weight(row);
    for (var k = 1u; k <= LIGHT_SEGMENTS; k = k + 1u) {
        let sb = f32(k) / f32(LIGHT_SEGMENTS);
        let wb = light_weight(row + P.soft_u.xyz * sb);
        all = all + 0.5 * (wa + wb) * (sb - sa);
        for (var j = 0u; j < hid_n; j = j + 1u) {
            let l = max(hid_lo[j], sa);
            let h = min(hid_hi[j], sb);
            if (l < h) {
                let wl = mix(wa, wb, (l - sa) / (sb - sa));
                let wh = mix(wa, wb, (h - sa) / (sb - sa));
                hidden = hidden + 0.5 * (wl + wh) * (h - l);
            }
        }
        sa = sb;
        wa = wb;
    }
    return vec2<f32>(all - hidden, all);
}

// The class of target pixels in an object's shadow (crates/render/src/object_pass.rs).
const SHADOW_CLASS: u32 = 0x80000000u;

// The target sheet's ray parameter along d (the shader's ray d: (xu, yu, 1) or a unit vector),
// or 3e38 where the ray misses the sheet (its margin included) or meets its plane behind.
fn target_t(d: vec3<f32>) -> f32 {
    let pp = plane_point(d);
    let s = P.sheet;
    let on = pp.z > 0.0 && pp.x >= s.x && pp.x < s.z && pp.y >= s.y && pp.y < s.w;
    let nd = P.plane.x * d.x + P.plane.y * d.y + P.plane.z * d.z;
    return select(3e38, P.plane.w / nd, on && nd != 0.0);
}

// The target's plane's ray parameter along d, the sheet's bounds left out (the soft-shadow
// lattice: V is smooth across the sheet's edge), or 3e38 where the ray meets the plane behind.
fn plane_t(d: vec3<f32>) -> f32 {
    let nd = P.plane.x * d.x + P.plane.y * d.y + P.plane.z * d.z;
    return select(3e38, P.plane.w / nd, plane_point(d).z > 0.0 && nd != 0.0);
}

// Texture coordinates (texels: s right, t down) of hit h.
fn hit_texel(h: MeshHit) -> vec2<f32> {
    let info = bitcast<vec4<u32>>(objs[P.obj.y + 5u * h.inst + 3u]);
    let b = info.y + 4u * h.tri;
    let uv0 = vec2<f32>(objs[b + 1u].w, objs[b + 2u].w);
    let r3 = objs[b + 3u];
    let uv = uv0 * (1.0 - h.bary.x - h.bary.y) + r3.xy * h.bary.x + r3.zw * h.bary.y;
    let w = f32(info.w);
    let hh = f32(bitcast<u32>(objs[P.obj.y + 5u * h.inst + 4u].y));
    return vec2<f32>(clamp(uv.x, 0.0, 1.0) * w, (1.0 - clamp(uv.y, 0.0, 1.0)) * hh);
}

// Row j's prefix sum at fractional texel x (the texture is piecewise constant).
fn row_sum(off: u32, w: u32, j: u32, x: f32) -> f32 {
    let i = min(u32(max(x, 0.0)), w - 1u);
    let k0 = j * (w + 1u) + i;
    let s0 = objs[off + k0 / 4u][k0 % 4u];
    let k1 = k0 + 1u;
    let s1 = objs[off + k1 / 4u][k1 % 4u];
    return s0 + (x - f32(i)) * (s1 - s0);
}

// The mean of the instance's texture over the texel box lo..hi (exact for up to 64 rows; a taller
// box takes 64 evenly spaced rows).
fn texture_box(inst: u32, lo_in: vec2<f32>, hi_in: vec2<f32>) -> f32 {
    let info = bitcast<vec4<u32>>(objs[P.obj.y + 5u * inst + 3u]);
    let w = info.w;
    let h = bitcast<u32>(objs[P.obj.y + 5u * inst + 4u].y);
    let lo = clamp(lo_in, vec2<f32>(0.0, 0.0), vec2<f32>(f32(w), f32(h)));
    let hi = clamp(max(hi_in, lo + vec2<f32>(1e-4, 1e-4)), vec2<f32>(0.0, 0.0), vec2<f32>(f32(w), f32(h)));
    let span = max(hi.x - lo.x, 1e-4);
    let j0 = min(u32(lo.y), h - 1u);
    let j1 = max(min(u32(ceil(hi.y)), h), j0 + 1u);
    let step = max((j1 - j0 + 63u) / 64u, 1u);
    var acc = 0.0;
    var wsum = 0.0;
    for (var j = j0; j < j1; j = j + step) {
        let cover = max(min(hi.y, f32(j + 1u)) - max(lo.y, f32(j)), 1e-6);
        acc = acc + cover * (row_sum(info.z, w, j, hi.x) - row_sum(info.z, w, j, lo.x)) / span;
        wsum = wsum + cover;
    }
    return acc / wsum;
}

// Lambert factor of hit h under the head light (flag 1) or the scene's light (flag 4, sun_on);
// 1 unlit. From the triangle's normal and the ray in the mesh frame (a similarity of the camera
// frame: angles are kept).
fn hit_light(h: MeshHit, d_cam: vec3<f32>) -> f32 {
    let flags = bitcast<u32>(objs[P.obj.y + 5u * h.inst + 4u].z);
    if ((flags & 5u) == 0u) { return 1.0; }
    let info = bitcast<vec4<u32>>(objs[P.obj.y + 5u * h.inst + 3u]);
    let b = info.y + 4u * h.tri;
    let n = cross3(objs[b + 1u].xyz, objs[b + 2u].xyz);
    let d = instance_ray(h.inst, d_cam)[1];
    if ((flags & 1u) != 0u) { return abs(dot3(n, d)) / (len3(n) * len3(d)); }
    return sun_on(h, d_cam, select(n, -n, dot3(n, d) > 0.0));
}

// A lit object's factor A + E max(0, n . l) at hit h (n_seen: its face normal in the mesh frame on
// the side seen), A alone where an object, itself included, meets the ray towards the light from
// the hit moved back along the camera ray to SHADOW_RAY_START t (crates/scene/src/shadow.rs
// ObjectLight::factor).
const SHADOW_RAY_START: f32 = 0.9999;
fn sun_on(h: MeshHit, d_cam: vec3<f32>, n_seen: vec3<f32>) -> f32 {
    if (dot3(P.obj_sun.xyz, P.obj_sun.xyz) == 0.0) { return P.obj_sun.w; }
    let l = mesh_dir(h.inst, P.obj_sun.xyz);
    let lit = dot3(n_seen, l) / len3(n_seen) * (len3(P.obj_sun.xyz) / len3(l));
    if (lit <= 0.0 || blocked(d_cam, h.t * SHADOW_RAY_START, P.obj_sun.xyz, 3e38)) { return P.obj_sun.w; }
    return P.obj_sun.w + lit;
}

// The albedo of hit h without its texture: the triangle's material or the instance's albedo
// (-2: textured).
fn hit_albedo(h: MeshHit) -> f32 {
    let info = bitcast<vec4<u32>>(objs[P.obj.y + 5u * h.inst + 3u]);
    let a = objs[info.y + 4u * h.tri].w;
    return select(a, objs[P.obj.y + 5u * h.inst + 4u].x, a == -1.0);
}

// The grey level of hit h sampled at one point (nearest texel).
fn hit_point_value(h: MeshHit, d_cam: vec3<f32>) -> f32 {
    var a = hit_albedo(h);
    if (a == -2.0) {
        let st = hit_texel(h);
        a = texture_box(h.inst, floor(st), floor(st) + vec2<f32>(1.0, 1.0));
    }
    return a * hit_light(h, d_cam);
}

// ---- coarse pass: one ray per pixel centre. The value (the object's shade, its texture
// box-filtered over the pixel's footprint) and a class (0 no object in front, else instance + 1,
// and for textured triangles bit 30 and the triangle in bits 8..29) go back; the CPU compares each pixel's class and value with its neighbours'
// (crates/render/src/object_pass.rs) and sends the pixels on an edge to the fine pass.
const TEXTURED_CLASS: u32 = 0x40000000u;

// The mean texture over the footprint whose corners (top-left, top-right, bottom-left,
// bottom-right) map to texels s00, s10, s01, s11: 4 x 4 sub-pixels, each box-filtered over the
// bounding box of its (bilinearly interpolated) footprint, which bounds it closely.
fn texture_subpixels(inst: u32, s00: vec2<f32>, s10: vec2<f32>, s01: vec2<f32>, s11: vec2<f32>) -> f32 {
    let s = array<vec2<f32>, 4>(s00, s10, s01, s11);
    var acc = 0.0;
    for (var k = 0u; k < 16u; k = k + 1u) {
        let lo = vec2<f32>(f32(k % 4u), f32(k / 4u)) * 0.25;
        let p00 = bilerp(s, lo);
        let p10 = bilerp(s, lo + vec2<f32>(0.25, 0.0));
        let p01 = bilerp(s, lo + vec2<f32>(0.0, 0.25));
        let p11 = bilerp(s, lo + vec2<f32>(0.25, 0.25));
        acc = acc + texture_box(inst, min(min(p00, p10), min(p01, p11)), max(max(p00, p10), max(p01, p11)));
    }
    return acc * 0.0625;
}

// The bilinear map of the unit square onto the corners s (top-left, top-right, bottom-left,
// bottom-right) at uv.
fn bilerp(s: array<vec2<f32>, 4>, uv: vec2<f32>) -> vec2<f32> {
    return mix(mix(s[0], s[1], uv.x), mix(s[2], s[3], uv.x), uv.y);
}

// The texture over the footprint of the pixel whose centre ray `ray` hit h: the texel
// coordinates' Jacobian from the ray's (ray differentials on the triangle's plane:
// dp/dq = t (D - d (n . D) / (n . d)), D = dd/dq in the mesh frame).
fn texture_footprint(h: MeshHit, ray: Ray) -> f32 {
    let base = P.obj.y + 5u * h.inst;
    let info = bitcast<vec4<u32>>(objs[base + 3u]);
    let b = info.y + 4u * h.tri;
    let e1 = objs[b + 1u].xyz;
    let e2 = objs[b + 2u].xyz;
    let uv0 = vec2<f32>(objs[b + 1u].w, objs[b + 2u].w);
    let r3 = objs[b + 3u];
    let n = cross3(e1, e2);
    let nn = dot3(n, n);
    let da = cross3(e2, n) / nn;
    let db = cross3(n, e1) / nn;
    let d = instance_ray(h.inst, ray_d(ray))[1];
    let size = vec2<f32>(f32(info.w), f32(bitcast<u32>(objs[base + 4u].y)));
    var jac: array<vec2<f32>, 2>;
    for (var k = 0u; k < 2u; k = k + 1u) {
        let c = ray_col(ray, k);
        let dk = vec3<f32>(dot3(objs[base].xyz, c), dot3(objs[base + 1u].xyz, c), dot3(objs[base + 2u].xyz, c));
        let dp = h.t * (dk - d * (dot3(n, dk) / dot3(n, d)));
        let duv = (r3.xy - uv0) * dot3(da, dp) + (r3.zw - uv0) * dot3(db, dp);
        jac[k] = vec2<f32>(duv.x * size.x, -duv.y * size.y);
    }
    let st = hit_texel(h);
    let hx = 0.5 * jac[0];
    let hy = 0.5 * jac[1];
    return texture_subpixels(h.inst, st - hx - hy, st + hx - hy, st - hx + hy, st + hx + hy);
}

@compute @workgroup_size(8, 8, 1)
fn cs_coarse_objects(@builtin(workgroup_id) wg: vec3<u32>, @builtin(local_invocation_id) lid: vec3<u32>) {
    let px = coarse_pixel(wg, lid);
    uniform_view();
    let ray = pixel_ray(vec2<f32>(f32(px.x), f32(px.y)));
    let d = ray_d(ray);
    var h = no_hit(0.0);
    let tt = target_t(d);
    if (ray.ok) { h = cast_objects(d, tt); }
    var cls = 0u;
    // Beside the sheet and on it: the shadowed-over-lit ratio (1 where nothing shadows).
    var val = 1.0;
    if (ray.ok && h.inst == NO_OBJECT && tt < 3e38) {
        // A target pixel in an object's shadow: its value is the ratio to the lit one.
        soft = soft_pixel(ray, px.xy);
        let shade = shadow_ratio(d, tt);
        cls = select(0u, SHADOW_CLASS, shade.x == 1.0);
        val = shade.y;
    }
    if (h.inst != NO_OBJECT) {
        let a = hit_albedo(h);
        let light = hit_light(h, d);
        val = a * light;
        cls = h.inst + 1u;
        if (a == -2.0) {
            // The triangle too: one uv map is continuous only within a triangle.
            val = light * texture_footprint(h, ray);
            cls = cls | TEXTURED_CLASS | ((h.tri & 0x3fffffu) << 8u);
        }
    }
    let slot = (wg.y * 65535u + wg.x) * 64u + lid.y * 8u + lid.x;
    out_vals[slot] = val;
    out_hard[slot] = cls;
}

// ---- fine pass (below): the triangles a sub-sample can hit lie in the pixel's
// frustum: one traversal gathers them (up to MAX_CANDIDATES), then each sub-sample tests only
// those; more, and each sub-sample walks the hierarchy itself.
const MAX_CANDIDATES: u32 = 128u;
var<private> cand: array<u32, MAX_CANDIDATES>;
var<private> cand_count: u32;

// Whether the box lo..hi meets the pyramid from o bounded by the planes n[i] . (x - o) >= 0:
// outside when its corner farthest along some n[i] is behind that plane.
fn box_in_frustum(lo: vec3<f32>, hi: vec3<f32>, o: vec3<f32>, n: array<vec3<f32>, 4>) -> bool {
    var inside = lo.x <= hi.x;
    for (var i = 0u; i < 4u; i = i + 1u) {
        let far = select(lo, hi, n[i] > vec3<f32>(0.0, 0.0, 0.0));
        inside = inside && dot3(n[i], far - o) >= 0.0;
    }
    return inside;
}

// Whether triangle k (rows from tri_base) may be a first hit from o: always, unless `cull` and
// o is behind its plane (outward normals: counter-clockwise seen from outside).
fn faces(tri_base: u32, k: u32, o: vec3<f32>, cull: bool) -> bool {
    let b = tri_base + 4u * k;
    let n = cross3(objs[b + 1u].xyz, objs[b + 2u].xyz);
    return !cull || dot3(n, o - objs[b].xyz) >= 0.0;
}

// Add the leaf's triangles that may be a first hit to the candidates; false on overflow.
fn gather_leaf(tri_base: u32, c: u32, o: vec3<f32>, cull: bool, inst: u32) -> bool {
    for (var k = leaf_first(c); k < leaf_end(c); k = k + 1u) {
        if (faces(tri_base, k, o, cull)) {
            if (cand_count == MAX_CANDIDATES) { return false; }
            cand[cand_count] = (inst << 24u) | k;
            cand_count = cand_count + 1u;
        }
    }
    return true;
}

// Gather the triangles of instance `inst` in the frustum of the camera rays c (corners, in
// order around the pixel) and centre d; false when they overflow the list.
fn gather_instance(inst: u32, c: array<vec3<f32>, 4>, d: vec3<f32>) -> bool {
    let info = bitcast<vec4<u32>>(objs[P.obj.y + 5u * inst + 3u]);
    let o = instance_ray(inst, d)[0];
    let dc = instance_ray(inst, d)[1];
    var m: array<vec3<f32>, 4>;
    for (var i = 0u; i < 4u; i = i + 1u) { m[i] = instance_ray(inst, c[i])[1]; }
    var n: array<vec3<f32>, 4>;
    for (var i = 0u; i < 4u; i = i + 1u) {
        let p = cross3(m[i], m[(i + 1u) % 4u]);
        n[i] = select(-p, p, dot3(p, dc) >= 0.0);
    }
    // A closed mesh seen from outside: its back faces are never a first hit.
    let cull = (bitcast<u32>(objs[P.obj.y + 5u * inst + 4u].z) & 2u) != 0u;
    var stack: array<u32, MESH_STACK>;
    var sp = 0u;
    var node = 0u;
    loop {
        let r = node_rows(info.x, node);
        var go0 = box_in_frustum(r[0].xyz, r[1].xyz, o, n);
        var go1 = box_in_frustum(r[2].xyz, r[3].xyz, o, n);
        let c0 = bitcast<u32>(r[0].w);
        let c1 = bitcast<u32>(r[1].w);
        if (go0 && (c0 & LEAF_BIT) != 0u && !gather_leaf(info.y, c0, o, cull, inst)) { return false; }
        if ((c0 & LEAF_BIT) != 0u) { go0 = false; }
        if (go1 && (c1 & LEAF_BIT) != 0u && c1 != c0 && !gather_leaf(info.y, c1, o, cull, inst)) { return false; }
        if (go1 && (c1 & LEAF_BIT) != 0u) { go1 = false; }
        node = next_node(&stack, &sp, go0, go1, c0, c1);
        if (node == NO_OBJECT) { break; }
    }
    return true;
}

// The closest candidate along t d_cam nearer than t_max.
fn cast_candidates(d_cam: vec3<f32>, t_max: f32) -> MeshHit {
    var best = no_hit(t_max);
    for (var k = 0u; k < cand_count; k = k + 1u) {
        let inst = cand[k] >> 24u;
        let od = instance_ray(inst, d_cam);
        let info = bitcast<vec4<u32>>(objs[P.obj.y + 5u * inst + 3u]);
        best = hit_triangle(info.y, cand[k] & 0xffffffu, od[0], od[1], best, inst);
    }
    return best;
}

// What one sub-sample of the pixel at q (centre ray `centre`) sees at offset o: the grey level,
// a class (0: the target or the background; else the object's instance + 1) and whether it is the
// target's sheet (1: its value is what a soft shadow scales).
struct Seen1 { v: f32, cls: u32, sheet: f32, };

fn see(q: vec2<f32>, centre: Ray, o: vec2<f32>, gathered: bool) -> Seen1 {
    // A fisheye's rays bend across the pixel: each its own inversion; the other models' pixels
    // are linear to 1e-4 px (the target passes' assumption too).
    var ray = centre;
    var d = ray_at(centre, o);
    if (wide()) {
        ray = pixel_ray(q + o);
        d = ray_d(ray);
    }
    if (!ray.ok) { return Seen1(P.grey.w, 0u, 0.0); }
    let pp = plane_point(d);
    let tt = target_t(d);
    var h: MeshHit;
    if (gathered) { h = cast_candidates(d, tt); } else { h = cast_objects(d, tt); }
    if (h.inst != NO_OBJECT) { return Seen1(hit_point_value(h, d), h.inst + 1u, 0.0); }
    // Beside the sheet: the background (its image where there is one); on it, the board, darker
    // in an object's shadow.
    if (tt < 3e38) {
        let shade = shadow_ratio(d, tt);
        if (shade.x == 1.0) { return Seen1(plane_value(pp.xy) * shade.y, SHADOW_CLASS, 1.0); }
    }
    return Seen1(select(bg_point(d), plane_value(pp.xy), tt < 3e38), 0u, select(0.0, 1.0, tt < 3e38));
}

fn same_side(a: Seen1, b: Seen1) -> bool { return a.cls == b.cls && abs(a.v - b.v) <= 1.0; }

// Bisections of a crossing along a scan line: its place to 1/128 px.
const CROSSING_BISECTIONS: u32 = 6u;

// The share of a fine pixel's value that comes from the target's sheet (summed as `acc` is):
// under an area light the CPU scales it by the pixel's soft-shadow ratio from the coarse pass
// (crates/render/src/object_pass.rs), so the fine pass casts no shadow ray.
var<private> acc_sheet: f32;

// The mean along the scan line through the pixel at `pos` across `axis` (0: a row, 1: a
// column): samples at its ends and middle; between two that differ (another object, the
// target, or a step of more than a grey level) the crossing is bisected and each side is
// integrated by the trapezoid rule up to it; elsewhere the trapezoid rule.
fn scan_line(q: vec2<f32>, centre: Ray, gathered: bool, axis: u32, pos: f32) -> f32 {
    var acc = 0.0;
    var sa = -0.5;
    var a = see(q, centre, select(vec2<f32>(sa, pos), vec2<f32>(pos, sa), axis == 1u), gathered);
    for (var seg = 0u; seg < 2u; seg = seg + 1u) {
        let sb = sa + 0.5;
        let b = see(q, centre, select(vec2<f32>(sb, pos), vec2<f32>(pos, sb), axis == 1u), gathered);
        if (same_side(a, b)) {
            acc = acc + 0.25 * (a.v + b.v);
            acc_sheet = acc_sheet + 0.25 * (a.v * a.sheet + b.v * b.sheet);
        } else {
            var lo = sa;
            var hi = sb;
            var v_lo = a.v;
            var v_hi = b.v;
            var s_lo = a.sheet;
            var s_hi = b.sheet;
            for (var k = 0u; k < CROSSING_BISECTIONS; k = k + 1u) {
                let mid = 0.5 * (lo + hi);
                let m = see(q, centre, select(vec2<f32>(mid, pos), vec2<f32>(pos, mid), axis == 1u), gathered);
                if (same_side(m, a)) {
                    lo = mid;
                    v_lo = m.v;
                    s_lo = m.sheet;
                } else {
                    hi = mid;
                    v_hi = m.v;
                    s_hi = m.sheet;
                }
            }
            // Each side by the trapezoid rule between its end and its sample nearest the crossing
            // (a lit object's shade changes fastest near its outline).
            let c = 0.5 * (lo + hi);
            acc = acc + 0.5 * (a.v + v_lo) * (c - sa) + 0.5 * (v_hi + b.v) * (sb - c);
            acc_sheet = acc_sheet + 0.5 * (a.v * a.sheet + v_lo * s_lo) * (c - sa) + 0.5 * (v_hi * s_hi + b.v * b.sheet) * (sb - c);
        }
        a = b;
        sa = sb;
    }
    return acc;
}

// Fine pass: pixels on an edge. Between two untextured regions, P.obj.z scan lines across the
// edge (the CPU sets bit 15 of the work item's x for columns: a more horizontal edge), each
// integrated exactly up to its crossings' bisection: a straight edge's coverage is linear along
// the other axis, so the lines' mean (midpoint rule) is exact for it. Elsewhere (bit 31:
// textures, steps inside an object, three regions) a grid of P.obj.w^2 sub-samples.
@compute @workgroup_size(64, 1, 1)
fn cs_fine_objects(@builtin(global_invocation_id) gid: vec3<u32>) {
    let i = min(gid.y * 65535u * 64u + gid.x, P.tiles.w - 1u);
    let packed = work[i];
    let slot = gid.y * 65535u * 64u + gid.x;
    uniform_view();
    // The soft-shadow lattice's points (P.soft_v.w == -1): the item's lattice point (a, b) = (x,
    // y), or with bit 31 the centre of quad (a, b). llvmpipe runs a branch's code under a lane
    // mask whether or not a lane takes it: the pixels' loops below get no trips instead.
    let lattice = P.soft_v.w == -1.0;
    if (lattice) {
        let point = vec2<f32>(f32(packed & 0x7fffu), f32((packed >> 16u) & 0x7fffu)) * f32(QUAD) - 0.5;
        out_vals[slot] = lattice_share(point + select(0.0, 0.5 * f32(QUAD), (packed >> 31u) == 1u));
        out_hard[slot] = 0u;
    }
    let axis = (packed >> 15u) & 1u;
    let grid = (packed >> 31u) == 1u;
    let q = vec2<f32>(f32(packed & 0x7fffu), f32((packed >> 16u) & 0x7fffu));
    let centre = pixel_ray(q);
    // The frustum: the pixel's corners, a hundredth of a pixel wider (the sub-samples' rays are
    // the same linearisation, or for a fisheye each its own inversion: margin for its bending).
    var c: array<vec3<f32>, 4>;
    let corner = array<vec2<f32>, 4>(vec2<f32>(-0.51, -0.51), vec2<f32>(0.51, -0.51), vec2<f32>(0.51, 0.51), vec2<f32>(-0.51, 0.51));
    for (var k = 0u; k < 4u; k = k + 1u) {
        c[k] = ray_at(centre, corner[k]);
        if (wide()) { c[k] = ray_d(pixel_ray(q + corner[k] * 1.02)); }
    }
    cand_count = 0u;
    // Under an area light the sheet's samples stay unscaled (class 0): see acc_sheet.
    soft = vec2<f32>(0.0, 1.0);
    acc_sheet = 0.0;
    var gathered = centre.ok;
    for (var k = 0u; k < select(P.obj.x, 0u, lattice); k = k + 1u) {
        gathered = gathered && gather_instance(k, c, ray_d(centre));
    }
    // Per-lane trip counts: a lane runs its own loop only (llvmpipe leaves a loop when no lane
    // is active in it).
    let lines = select(select(P.obj.z, 0u, grid), 0u, lattice);
    var acc = 0.0;
    for (var j = 0u; j < lines; j = j + 1u) {
        acc = acc + scan_line(q, centre, gathered, axis, (f32(j) + 0.5) / f32(lines) - 0.5);
    }
    let n = select(select(0u, P.obj.w, grid), 0u, lattice);
    let inv = 1.0 / f32(max(n, 1u));
    for (var k = 0u; k < n * n; k = k + 1u) {
        let m = see(q, centre, (vec2<f32>(f32(k % n), f32(k / n)) + 0.5) * inv - 0.5, gathered);
        acc = acc + m.v * inv;
        acc_sheet = acc_sheet + m.v * m.sheet * inv;
    }
    if (!lattice) {
        out_vals[slot] = select(acc / f32(max(lines, 1u)), acc * inv, grid);
        out_hard[slot] = bitcast<u32>(select(acc_sheet / f32(max(lines, 1u)), acc_sheet * inv, grid));
    }
}
