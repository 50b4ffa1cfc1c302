// ---------------------------------------------------------------- background (panorama, image on a plane)
// What rays that miss the target and the objects see (crates/scene/src/background.rs: the
// mapping, mirrored here in f32; crates/render/src/background.rs: the pass and how it is mixed
// with the target). `bg_data` holds the image's texels (row-major, top row first), then per row
// its prefix sums (width + 1 each). P.bg: kind (1 panorama, 2 plane), width, height, 0;
// P.bg0..2: rows of the background's frame from the camera's (xyz) and, for a plane, the camera
// centre in the plane's frame (w); P.bg_size: the plane image's width and height, metres.

@group(0) @binding(9) var<storage, read> bg_data: array<f32>;

const BG_PANORAMA: f32 = 1.0;
const BG_PI: f32 = 3.14159265;
// A row span over at most this many texels sums them; a wider one takes the prefix sums (whose
// f32 rounding grows with the row's total).
const BG_DIRECT_TEXELS: u32 = 8u;

// Texel coordinates (s, t) of the background along camera direction d, and whether the ray
// meets its plane in front (z; always for a panorama).
fn bg_texel(d: vec3<f32>) -> vec3<f32> {
    let e = vec3<f32>(dot3(P.bg0.xyz, d), dot3(P.bg1.xyz, d), dot3(P.bg2.xyz, d));
    let size = P.bg.yz;
    if (P.bg.x == BG_PANORAMA) {
        let lon = atan2(e.x, e.z);
        let lat = atan2(e.y, len2(e.xz));
        return vec3<f32>((lon / (2.0 * BG_PI) + 0.5) * size.x, (lat / BG_PI + 0.5) * size.y, 1.0);
    }
    let o = vec3<f32>(P.bg0.w, P.bg1.w, P.bg2.w);
    let t = -o.z / e.z;
    let st = ((o.xy + t * e.xy) / P.bg_size.xy + 0.5) * size;
    return vec3<f32>(st, select(0.0, 1.0, t > 0.0));
}

// Row j's prefix sum at x (0 <= x <= width; the texels are piecewise constant).
fn bg_prefix(j: u32, x: f32) -> f32 {
    let w = u32(P.bg.y);
    let base = w * u32(P.bg.z) + j * (w + 1u);
    let i = min(u32(x), w - 1u);
    let s0 = bg_data[base + i];
    return s0 + (x - f32(i)) * (bg_data[base + i + 1u] - s0);
}

// The sum of row j over [a, b] (0 <= a <= b <= width).
fn bg_row(j: u32, a: f32, b: f32) -> f32 {
    let w = u32(P.bg.y);
    let i0 = min(u32(a), w - 1u);
    let i1 = max(min(u32(ceil(b)), w), i0 + 1u);
    if (i1 - i0 > BG_DIRECT_TEXELS) { return bg_prefix(j, b) - bg_prefix(j, a); }
    var acc = 0.0;
    for (var i = i0; i < i1; i = i + 1u) {
        acc = acc + max(min(b, f32(i + 1u)) - max(a, f32(i)), 0.0) * bg_data[j * w + i];
    }
    return acc;
}

// The sum of row j over [lo, hi]: a panorama's rows wrap around, a plane image's end (beyond
// them, nothing: the caller adds the background grey for the area outside).
fn bg_span(j: u32, lo: f32, hi: f32) -> f32 {
    let w = P.bg.y;
    if (P.bg.x != BG_PANORAMA) { return bg_row(j, clamp(lo, 0.0, w), clamp(hi, 0.0, w)); }
    if (hi - lo >= w) { return bg_row(j, 0.0, w) * (hi - lo) / w; }
    let a = lo - w * floor(lo / w);
    let b = a + (hi - lo);
    if (b <= w) { return bg_row(j, a, b); }
    return bg_row(j, a, w) + bg_row(j, 0.0, b - w);
}

// The mean of the background over the texel box lo..hi: exact for up to 64 rows (a taller box
// takes 64 evenly spaced rows); a plane image's box beyond the image sees the background grey
// there; a panorama's box beyond a pole is cut at it.
fn bg_box(lo: vec2<f32>, hi_in: vec2<f32>) -> f32 {
    let h = P.bg.z;
    let hi = max(hi_in, lo + vec2<f32>(1e-4, 1e-4));
    let y0 = clamp(lo.y, 0.0, h);
    let y1 = max(clamp(hi.y, 0.0, h), y0);
    let j0 = min(u32(y0), u32(h) - 1u);
    let j1 = max(min(u32(ceil(y1)), u32(h)), j0 + 1u);
    let step = max((j1 - j0 + 63u) / 64u, 1u);
    var acc = 0.0;
    var rows = 0.0;
    for (var j = j0; j < j1; j = j + step) {
        let cover = max(min(y1, f32(j + 1u)) - max(y0, f32(j)), 0.0) * f32(step);
        acc = acc + cover * bg_span(j, lo.x, hi.x);
        rows = rows + cover;
    }
    let area = (hi.x - lo.x) * (hi.y - lo.y);
    if (P.bg.x == BG_PANORAMA) { return acc / max(rows * (hi.x - lo.x), 1e-12); }
    let inside = rows * (min(hi.x, P.bg.y) - max(lo.x, 0.0));
    return (acc + max(area - max(inside, 0.0), 0.0) * P.grey.w) / area;
}

// The texel coordinates' change along the camera-ray change v at direction d (their Jacobian,
// from the mapping of bg_texel: d(lon) = (e.z de.x - e.x de.z) / rho^2, d(lat) = (rho de.y -
// e.y d(rho)) / |e|^2; a plane's point moves by t (de - e de.z / e.z)).
fn bg_texel_step(d: vec3<f32>, v: vec3<f32>) -> vec2<f32> {
    let e = vec3<f32>(dot3(P.bg0.xyz, d), dot3(P.bg1.xyz, d), dot3(P.bg2.xyz, d));
    let de = vec3<f32>(dot3(P.bg0.xyz, v), dot3(P.bg1.xyz, v), dot3(P.bg2.xyz, v));
    let size = P.bg.yz;
    if (P.bg.x == BG_PANORAMA) {
        let rho2 = e.x * e.x + e.z * e.z;
        let rho = sqrt(rho2);
        let dlon = (e.z * de.x - e.x * de.z) / rho2;
        let drho = (e.x * de.x + e.z * de.z) / rho;
        let dlat = (rho * de.y - e.y * drho) / (rho2 + e.y * e.y);
        return vec2<f32>(dlon / (2.0 * BG_PI) * size.x, dlat / BG_PI * size.y);
    }
    let t = -P.bg2.w / e.z;
    return t * (de.xy - e.xy * (de.z / e.z)) / P.bg_size.xy * size;
}

// The background box-filtered over the footprint of the pixel whose centre ray is `ray`: the
// bounding box in texel space of the parallelogram the pixel's square maps to (the texel
// coordinates linearised over the pixel, as the lens is: ray_col).
fn bg_pixel(ray: Ray) -> f32 {
    if (!ray.ok) { return P.grey.w; }
    let d = ray_d(ray);
    let c = bg_texel(d);
    if (c.z == 0.0) { return P.grey.w; }
    let ext = 0.5 * (abs(bg_texel_step(d, ray_col(ray, 0u))) + abs(bg_texel_step(d, ray_col(ray, 1u))));
    return bg_box(c.xy - ext, c.xy + ext);
}

// The background seen along d at one point (the objects' sub-samples): its texel, or the
// background grey where the ray misses the image.
fn bg_point(d: vec3<f32>) -> f32 {
    let st = bg_texel(d);
    let w = P.bg.y;
    let h = P.bg.z;
    if (P.bg.x == 0.0 || st.z == 0.0 || st.x < 0.0 || st.y < 0.0 || st.x > w || st.y > h) { return P.grey.w; }
    let i = min(u32(st.x), u32(w) - 1u);
    let j = min(u32(st.y), u32(h) - 1u);
    return bg_data[j * u32(w) + i];
}

// The background pass: one invocation per pixel of its work list (x | y << 16), the pixel's
// box-filtered background.
@compute @workgroup_size(64, 1, 1)
fn cs_background(@builtin(global_invocation_id) gid: vec3<u32>) {
    let it = fine_item(gid);
    out_vals[gid.y * 65535u * 64u + gid.x] = bg_pixel(pixel_ray(vec2<f32>(f32(it.x), f32(it.y))));
}
