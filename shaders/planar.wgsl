// ---------------------------------------------------------------- planar targets

// The grey levels at board point (x, y): as given, or under a point light (P.shade.y == 1) the
// surface levels (dark, light, margin) times the shading there (the constant part plus the
// lamp's inverse-square term) plus the glossy coating's GGX reflection of the lamp
// (crates/scene/src/gloss.rs); under an area light (P.shade.y == 2) the constant part plus its
// closed-form term (area_irradiance). The background is not a surface.
fn shaded_greys(x: f32, y: f32) -> vec4<f32> {
    if (P.shade.y == 0.0) { return P.grey; }
    if (P.shade.y == 2.0) { return vec4<f32>(P.grey.xyz * (P.shade.x + area_irradiance(vec2<f32>(x, y))), P.grey.w); }
    let to_l = P.lamp.xyz - vec3<f32>(x, y, 0.0);
    let r2 = dot(to_l, to_l);
    let l = to_l / sqrt(r2);
    let s = P.shade.x + P.lamp.w * max(P.eye.w * l.z, 0.0) / r2;
    return vec4<f32>(P.grey.xyz * s + vec3<f32>(ggx_grey(l, x, y) * P.lamp.w / r2), P.grey.w);
}

// The area light's irradiance at board point b (target frame): the radiance times the projected
// solid angle of its rectangle, Lambert's polygon formula (crates/scene/src/area_light.rs, which
// this mirrors); 0 behind the emitter. The part of the rectangle below the board's horizon is the
// same for every board point (the horizon is the board's plane), so the CPU clips it once and
// passes the polygon: P.lamp and P.area1..4 (up to five corners, the last repeated to pad; a
// repeated corner adds nothing) and the emitter's plane P.area_e.
fn area_irradiance(b: vec2<f32>) -> f32 {
    let p = vec3<f32>(b, 0.0);
    if (dot(P.area_e.xyz, p) <= P.area_e.w) { return 0.0; }
    let v0 = P.lamp.xyz - p;
    let v1 = P.area1.xyz - p;
    let v2 = P.area2.xyz - p;
    let v3 = P.area3.xyz - p;
    let v4 = P.area4.xyz - p;
    let sum = edge_angle(v0, v1) + edge_angle(v1, v2) + edge_angle(v2, v3) + edge_angle(v3, v4) + edge_angle(v4, v0);
    return P.lamp.w * 0.5 * abs(sum);
}

// One edge's term of Lambert's formula, theta (a x e / |a x e|) . n with the board's camera-side
// normal n = (0, 0, P.eye.w); 0 for a degenerate edge.
fn edge_angle(a: vec3<f32>, e: vec3<f32>) -> f32 {
    let axe = cross(a, e);
    let s = length(axe);
    return select(0.0, atan2(s, dot(a, e)) * P.eye.w * axe.z / max(s, 1e-30), s > 0.0);
}

// The coating's specular grey level per unit lamp irradiance (Cook-Torrance with GGX, Smith-
// Schlick G with k = alpha / 2, Schlick's Fresnel; times pi 255: lighting.rs `Gloss`).
fn ggx_grey(l: vec3<f32>, x: f32, y: f32) -> f32 {
    let rough = P.shade.w;
    if (rough == 0.0) { return 0.0; }
    let v = normalize(P.eye.xyz - vec3<f32>(x, y, 0.0));
    let nz = P.eye.w;
    let nl = nz * l.z; let nv = nz * v.z;
    if (nl <= 0.0 || nv <= 0.0) { return 0.0; }
    let h = normalize(l + v);
    let a = rough * rough; let a2 = a * a;
    let nh = max(nz * h.z, 0.0);
    let q = nh * nh * (a2 - 1.0) + 1.0;
    let d = a2 / (3.14159265 * q * q);
    let k = 0.5 * a;
    let g = nl / (nl * (1.0 - k) + k) * nv / (nv * (1.0 - k) + k);
    let f = P.shade.z + (1.0 - P.shade.z) * pow(1.0 - max(dot(v, h), 0.0), 5.0);
    return 3.14159265 * 255.0 * d * g * f / (4.0 * nv);
}

fn chess_value(x: f32, y: f32) -> f32 {
    let s = P.board.z; let m = P.board.w;
    let w = P.board.x * s; let h = P.board.y * s;
    let g = shaded_greys(x, y);
    if (x >= 0.0 && x < w && y >= 0.0 && y < h) {
        let ij = i32(floor(x / s)) + i32(floor(y / s));
        return select(g.y, g.x, (ij & 1) == 0);
    }
    if (x >= -m && x < w + m && y >= -m && y < h + m) { return g.z; }
    return P.grey.w;
}

fn grid_value(x: f32, y: f32) -> f32 {
    let n = P.board.x; let hh = 0.5 * P.board.y; let rad = P.board.z; let outer = hh + P.board.w;
    if (x < -outer || x >= outer || y < -outer || y >= outer) { return P.grey.w; }
    let pitch = P.board.y / (n - 1.0);
    let ix = clamp(round((x + hh) / pitch), 0.0, n - 1.0);
    let iy = clamp(round((y + hh) / pitch), 0.0, n - 1.0);
    let d = vec2<f32>(x + hh - pitch * ix, y + hh - pitch * iy);
    let g = shaded_greys(x, y);
    return select(g.y, g.x, dot2(d, d) < rad * rad);
}

fn plane_value(b: vec2<f32>) -> f32 {
    if (P.size.z == KIND_CODED) { return coded_value(b.x, b.y); }
    return select(grid_value(b.x, b.y), chess_value(b.x, b.y), P.size.z == KIND_CHESSBOARD);
}


// A warped board (mrcal's sag, crates/core/src/target/warp.rs): the homography of the pixel's own
// tangent plane. The ray d meets the paraboloid z = kx (1 - u^2) + ky (1 - v^2) (u = (x - xc) sx,
// v = (y - yc) sy) of the board frame at s (the root of A s^2 + B s + C next to the flat plane's,
// in the form that stays exact as the warp goes to 0); the tangent plane there is
// z = gx x + gy y + c, so the camera point of the board point (x, y) on it is
// (M + r3 g^T) (x, y, 1), M = [r1 r2 t], g = (gx, gy, c), and with H = M^-1 / lambda (the
// uniform homography, rows scaled) Sherman-Morrison gives the tangent plane's
// H' = H - (H r3)(g^T H) / (lambda + g^T H r3), scaled as H. Over a pixel's footprint the tangent
// plane departs from the paraboloid by curvature x footprint^2 (1e-7 m for a 3 mm sag over 30 cm
// and a 1 mm footprint). Only in the pipelines compiled WARPED (crates/render/src/gpu_scene.rs
// `pipeline_variant`; no views, no objects: scene validation).
override WARPED: bool = false;

fn warp_view(ray: Ray) {
    if (!WARPED) { return; }
    let d = ray_d(ray);
    let o = vec3<f32>(P.tfc0.w, P.tfc1.w, P.tfc2.w);
    let dir = vec3<f32>(dot(P.tfc0.xyz, d), dot(P.tfc1.xyz, d), dot(P.tfc2.xyz, d));
    let kx = P.warp.x; let ky = P.warp.y;
    let ax = (o.x - P.warp_c.x) * P.warp_c.z; let bx = dir.x * P.warp_c.z;
    let ay = (o.y - P.warp_c.y) * P.warp_c.w; let by = dir.y * P.warp_c.w;
    let qa = kx * bx * bx + ky * by * by;
    let qb = dir.z + 2.0 * (kx * ax * bx + ky * ay * by);
    let qc = o.z - kx - ky + kx * ax * ax + ky * ay * ay;
    let disc = max(qb * qb - 4.0 * qa * qc, 0.0);
    let s = -2.0 * qc / (qb + select(-1.0, 1.0, qb >= 0.0) * sqrt(disc));
    let hit = o + s * dir;
    let gx = -2.0 * kx * (hit.x - P.warp_c.x) * P.warp_c.z * P.warp_c.z;
    let gy = -2.0 * ky * (hit.y - P.warp_c.y) * P.warp_c.w * P.warp_c.w;
    let g = vec3<f32>(gx, gy, hit.z - gx * hit.x - gy * hit.y);
    let r3 = P.tfc2.xyz;
    let hr3 = vec3<f32>(dot(P.h0.xyz, r3), dot(P.h1.xyz, r3), dot(P.h2.xyz, r3));
    let gh = g.x * P.h0.xyz + g.y * P.h1.xyz + g.z * P.h2.xyz;
    let inv = 1.0 / (P.warp.z + dot(g, hr3));
    H0 = vec4<f32>(P.h0.xyz - hr3.x * inv * gh, 0.0);
    H1 = vec4<f32>(P.h1.xyz - hr3.y * inv * gh, 0.0);
    H2 = vec4<f32>(P.h2.xyz - hr3.z * inv * gh, 0.0);
}
