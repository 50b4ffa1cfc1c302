// ---------------------------------------------------------------- objects (meshes)
// Appended to render.wgsl (src/render/renderer.rs concatenates the two). The user's meshes, each
// an instance of a mesh whose BVH and triangles live in `objs` (src/render/objects.rs lays it out):
//   instance i (at P.obj.y + 5 i): rows 0..2 the affine map from the camera frame to the mesh
//     frame (object_from_cam / scale: xyz = matrix row, w = offset); row 3 = (node offset,
//     triangle offset, texture offset, texture width) as u32 bits; row 4 = (albedo, texture
//     height as u32 bits, flags: bit 0 head light, 0).
//   node (4 rows): (lo0, child0), (hi0, child1), (lo1, 0), (hi1, 0); a child with bit 31 set is
//     a triangle (src/mesh/bvh.rs).
//   triangle (4 rows): (v0, albedo: >= 0 its material, -1 the instance's, -2 textured),
//     (e1, uv0.x), (e2, uv0.y), (uv1, uv2).
//   texture: per row, the prefix sums of its texels (width + 1 each), four per row of objs.
// Every ray is the camera ray of the existing per-pixel lens inversion (pixel_ray), so objects
// are exact under every lens model. Targets and objects occlude each other by ray parameter:
// the target sheet (P.sheet, in its plane P.plane) is at t = c / (n . d).
// Mirrors: src/scene/objects.rs (CPU, f64).

@group(0) @binding(8) var<storage, read> objs: array<vec4<f32>>;

const LEAF_BIT: u32 = 0x80000000u;
// Traversal stack; the CPU refuses meshes whose hierarchy is deeper (src/render/objects.rs).
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
    let pv = cross(d, e2);
    let det = dot(e1, pv);
    let inv = 1.0 / det;
    let s = o - v0;
    let u = dot(s, pv) * inv;
    let q = cross(s, e1);
    let v = dot(d, q) * inv;
    let t = dot(e2, q) * inv;
    if (det != 0.0 && u >= 0.0 && v >= 0.0 && u + v <= 1.0 && t > 0.0 && t < best.t) {
        return MeshHit(t, inst, k, vec2<f32>(u, v));
    }
    return best;
}

// The ray t d_cam (camera centre origin) in instance `inst`'s mesh frame: origin, direction.
fn instance_ray(inst: u32, d_cam: vec3<f32>) -> array<vec3<f32>, 2> {
    let base = P.obj.y + 5u * inst;
    let r0 = objs[base];
    let r1 = objs[base + 1u];
    let r2 = objs[base + 2u];
    return array<vec3<f32>, 2>(vec3<f32>(r0.w, r1.w, r2.w), vec3<f32>(dot(r0.xyz, d_cam), dot(r1.xyz, d_cam), dot(r2.xyz, d_cam)));
}

// The closest hit of instance `inst` nearer than best.t: nearer child first, the other pushed
// (Aila and Laine 2009), leaves tested as they are met.
fn cast_instance(inst: u32, d_cam: vec3<f32>, best_in: MeshHit) -> MeshHit {
    let info = bitcast<vec4<u32>>(objs[P.obj.y + 5u * inst + 3u]);
    let od = instance_ray(inst, d_cam);
    let o = od[0];
    let d = od[1];
    let inv = 1.0 / select(d, vec3<f32>(1e-30, 1e-30, 1e-30), abs(d) < vec3<f32>(1e-30, 1e-30, 1e-30));
    var best = best_in;
    var stack: array<u32, MESH_STACK>;
    var sp = 0u;
    var node = 0u;
    loop {
        let nb = info.x + 4u * node;
        let a = objs[nb];
        let b = objs[nb + 1u];
        let t0 = box_entry(a.xyz, b.xyz, o, inv, best.t);
        let t1 = box_entry(objs[nb + 2u].xyz, objs[nb + 3u].xyz, o, inv, best.t);
        let c0 = bitcast<u32>(a.w);
        let c1 = bitcast<u32>(b.w);
        var go0 = t0 >= 0.0;
        var go1 = t1 >= 0.0;
        if (go0 && (c0 & LEAF_BIT) != 0u) { best = hit_triangle(info.y, c0 & ~LEAF_BIT, o, d, best, inst); go0 = false; }
        if (go1 && (c1 & LEAF_BIT) != 0u) { best = hit_triangle(info.y, c1 & ~LEAF_BIT, o, d, best, inst); go1 = false; }
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

// The target sheet's ray parameter along d (the shader's ray d: (xu, yu, 1) or a unit vector),
// or 3e38 where the ray misses the sheet (its margin included) or meets its plane behind.
fn target_t(d: vec3<f32>) -> f32 {
    let pp = plane_point(d);
    let s = P.sheet;
    let on = pp.z > 0.0 && pp.x >= s.x && pp.x < s.z && pp.y >= s.y && pp.y < s.w;
    let nd = P.plane.x * d.x + P.plane.y * d.y + P.plane.z * d.z;
    return select(3e38, P.plane.w / nd, on && nd != 0.0);
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

// Lambert factor of hit h under the head light (1 unlit), from the triangle's normal and the ray
// in the mesh frame (a similarity of the camera frame: angles are kept).
fn hit_light(h: MeshHit, d_cam: vec3<f32>) -> f32 {
    let flags = bitcast<u32>(objs[P.obj.y + 5u * h.inst + 4u].z);
    if ((flags & 1u) == 0u) { return 1.0; }
    let info = bitcast<vec4<u32>>(objs[P.obj.y + 5u * h.inst + 3u]);
    let b = info.y + 4u * h.tri;
    let n = cross(objs[b + 1u].xyz, objs[b + 2u].xyz);
    let d = instance_ray(h.inst, d_cam)[1];
    return abs(dot(n, d)) / (length(n) * length(d));
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

// ---- coarse pass: the 9 x 9 pixel-corner rays of the tile, shared in workgroup memory.
var<workgroup> corner_inst: array<u32, 81>;
var<workgroup> corner_tri: array<u32, 81>;
var<workgroup> corner_val: array<f32, 81>;
var<workgroup> corner_st: array<vec2<f32>, 81>;

fn object_corner(tile_xy: vec2<u32>, c: u32) {
    let q = vec2<f32>(f32(tile_xy.x * 8u + c % 9u) - 0.5, f32(tile_xy.y * 8u + c / 9u) - 0.5);
    let ray = pixel_ray(q);
    let d = ray_d(ray);
    var h = no_hit(0.0);
    if (ray.ok) { h = cast_objects(d, target_t(d)); }
    corner_inst[c] = h.inst;
    corner_tri[c] = h.tri;
    var val = 0.0;
    var st = vec2<f32>(0.0, 0.0);
    if (h.inst != NO_OBJECT) {
        let a = hit_albedo(h);
        val = a * hit_light(h, d);
        if (a == -2.0) {
            st = hit_texel(h);
            val = -2.0 - hit_light(h, d);  // textured: the light, encoded below -2
        }
    }
    corner_val[c] = val;
    corner_st[c] = st;
}

// The mean texture over the pixel whose corners (k: top-left, top-right, bottom-left,
// bottom-right) map to texels corner_st: 4 x 4 sub-pixels, each box-filtered over the bounding
// box of its (bilinearly interpolated) footprint.
fn texture_subpixels(inst: u32, k: array<u32, 4>) -> f32 {
    let s00 = corner_st[k[0]];
    let s10 = corner_st[k[1]];
    let s01 = corner_st[k[2]];
    let s11 = corner_st[k[3]];
    var acc = 0.0;
    for (var j = 0u; j < 4u; j = j + 1u) {
        let v0 = f32(j) * 0.25;
        let v1 = v0 + 0.25;
        let a0 = mix(s00, s01, v0);
        let b0 = mix(s10, s11, v0);
        let a1 = mix(s00, s01, v1);
        let b1 = mix(s10, s11, v1);
        for (var i = 0u; i < 4u; i = i + 1u) {
            let u0 = f32(i) * 0.25;
            let u1 = u0 + 0.25;
            let p00 = mix(a0, b0, u0);
            let p10 = mix(a0, b0, u1);
            let p01 = mix(a1, b1, u0);
            let p11 = mix(a1, b1, u1);
            acc = acc + texture_box(inst, min(min(p00, p10), min(p01, p11)), max(max(p00, p10), max(p01, p11)));
        }
    }
    return acc * 0.0625;
}

// The pixel's value from its four corners (k: their indices), and 0 keep the target's value,
// 1 use this value, 2 needs the fine pass.
fn corner_pixel(k: array<u32, 4>) -> vec2<f32> {
    let i0 = corner_inst[k[0]];
    var same = true;
    var same_tri = true;
    var lo = 1e30;
    var hi = -1e30;
    var st_lo = vec2<f32>(1e30, 1e30);
    var st_hi = vec2<f32>(-1e30, -1e30);
    var light = 0.0;
    for (var j = 0u; j < 4u; j = j + 1u) {
        same = same && corner_inst[k[j]] == i0;
        same_tri = same_tri && corner_tri[k[j]] == corner_tri[k[0]];
        let v = corner_val[k[j]];
        lo = min(lo, v);
        hi = max(hi, v);
        st_lo = min(st_lo, corner_st[k[j]]);
        st_hi = max(st_hi, corner_st[k[j]]);
        light = light + max(-2.0 - v, 0.0);
    }
    if (!same) { return vec2<f32>(0.0, 2.0); }
    if (i0 == NO_OBJECT) { return vec2<f32>(0.0, 0.0); }
    if (lo <= -2.0) {
        // Textured: one triangle (one continuous uv map) is box-filtered over the footprints of
        // 4 x 4 sub-pixels (the box of each bounds its footprint's parallelogram closely).
        if (!same_tri || hi > -2.0) { return vec2<f32>(0.0, 2.0); }
        return vec2<f32>(0.25 * light * texture_subpixels(i0, k), 1.0);
    }
    if (hi - lo > 0.25) { return vec2<f32>(0.0, 2.0); }
    return vec2<f32>(0.25 * (corner_val[k[0]] + corner_val[k[1]] + corner_val[k[2]] + corner_val[k[3]]), 1.0);
}

@compute @workgroup_size(8, 8, 1)
fn cs_coarse_objects(@builtin(workgroup_id) wg: vec3<u32>, @builtin(local_invocation_id) lid: vec3<u32>) {
    let px = coarse_pixel(wg, lid);
    uniform_view();
    let tile_xy = vec2<u32>(px.x / 8u, px.y / 8u);
    let me = lid.y * 8u + lid.x;
    object_corner(tile_xy, me);
    // The 17 corners past the first 64, on consecutive lanes (llvmpipe runs lanes in groups).
    for (var c = 64u + me; c < 81u; c = c + 64u) { object_corner(tile_xy, c); }
    workgroupBarrier();
    let c = lid.y * 9u + lid.x;
    let r = corner_pixel(array<u32, 4>(c, c + 1u, c + 9u, c + 10u));
    let slot = (wg.y * 65535u + wg.x) * 64u + me;
    out_vals[slot] = r.x;
    out_hard[slot] = u32(r.y);
}

// ---- fine pass: P.obj.z^2 sub-samples, each its own exact ray; the nearer of the objects
// and the target (point-sampled) at each.
@compute @workgroup_size(64, 1, 1)
fn cs_fine_objects(@builtin(global_invocation_id) gid: vec3<u32>) {
    let it = fine_item(gid);
    uniform_view();
    let n = P.obj.z;
    let inv = 1.0 / f32(n);
    var acc = 0.0;
    let q = vec2<f32>(f32(it.x), f32(it.y));
    let centre = pixel_ray(q);
    for (var k = 0u; k < n * n; k = k + 1u) {
        let o = (vec2<f32>(f32(k % n), f32(k / n)) + 0.5) * inv - 0.5;
        // A fisheye's rays bend across the pixel: each its own inversion; the other models'
        // pixels are linear to 1e-4 px (the target passes' assumption too).
        var ray = centre;
        var d = ray_at(centre, o);
        if (wide()) {
            ray = pixel_ray(q + o);
            d = ray_d(ray);
        }
        let pp = plane_point(d);
        var v = select(P.grey.w, plane_value(pp.xy), pp.z > 0.0);
        if (ray.ok) {
            let h = cast_objects(d, target_t(d));
            if (h.inst != NO_OBJECT) { v = hit_point_value(h, d); }
        } else {
            v = P.grey.w;
        }
        acc = acc + v;
    }
    out_vals[gid.y * 65535u * 64u + gid.x] = acc * inv * inv;
}
