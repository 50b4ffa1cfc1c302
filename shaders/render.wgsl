// synthcam renderer: compute passes over work lists built on the CPU.
//
// llvmpipe (lavapipe) runs every branch of a shader under a lane mask, so skipping work takes
// separate dispatches: the CPU fills tiles that hold no edge (flat tiles); the coarse pass runs
// one invocation per pixel of the other tiles and flags "hard" pixels; the fine pass runs one
// invocation per hard pixel.
//
// Per pixel: the pixel centre (OpenCV convention: pixel (x, y) is centred at (x, y)) is mapped to
// normalised distorted coordinates with K^-1, the lens model is inverted (Newton's method, the GPU
// twin of camera::Lens::undistort) to the pixel's ray d (camera frame: (xu, yu, 1), or a fisheye's
// unit vector, which may point behind the camera plane), and the local Jacobian d(d)/d(q) of that
// inverse gives every sub-sample of the pixel without another inversion. Shading is a box filter
// over the pixel square:
//   - chessboard: one line across the (locally affine) pixel footprint, the closed-form area of a
//     half-plane; corners and every other pixel near an edge, the exact area of the footprint in
//     each square, the margin and the board (Green's theorem over the clipped boundary lines; supersampled only when the
//     footprint meets more than MAX_CELLS squares per axis: squares of about a pixel);
//   - dot grid: flat pixels take one sample, pixels near a disc or plate edge the exact area of the
//     pixel on the plate and in each disc (the disc's image ellipse mapped onto the unit circle);
//   - S-path: flat pixels one ray; the sphere's outline in closed form; one smooth dot boundary
//     in closed form; elsewhere near a dot the grey seen (beads) or the caps' change plus the
//     outline in closed form (caps), integrated along scan lines sampled also inside each near
//     dot's chord and next to the outline, crossings bisected on exact rays (nearest hit among
//     the sphere and the pixel's dots), adaptive Simpson across the lines (from `samples`).
// Mirrors: src/scene/trace.rs (CPU, f64). Uniform layout: src/render/uniforms.rs `Params`.

struct Params {
    size: vec4<u32>,     // width, height, kind (0 chessboard, 1 dot grid, 2 s-path, 4 coded board), samples per axis
    tiles: vec4<u32>,    // tiles_x, tiles_y, dot style (0 bead, 1 disc), fine-pass work length
    intr: vec4<f32>,     // fx, fy, cx, cy
    intr2: vec4<f32>,    // skew, r2_max (undistorted r^2 beyond which the lens folds), has_distortion, 0
    dist0: vec4<f32>,    // OpenCV: k1, k2, p1, p2 | fisheye: k1..k4 | double sphere: xi, alpha
    dist1: vec4<f32>,    // OpenCV: k3, k4, k5, k6 | fisheye: theta_max, split radii 2x2, 4x4
    dist2: vec4<f32>,    // OpenCV: s1, s2, s3, s4
    tilt0: vec4<f32>,    // OpenCV tilt matrix rows (xyz; used when LENS_TILT)
    tilt1: vec4<f32>,
    tilt2: vec4<f32>,
    h0: vec4<f32>,       // rows of H: (X, Y, W) = H d, target plane from the ray (W > 0: in front): the first view's
    h1: vec4<f32>,
    h2: vec4<f32>,
    board: vec4<f32>,    // chessboard: nx, ny, square, margin | dot grid: n, edge, radius, margin | coded: cells x, y, per period, margin
    grey: vec4<f32>,     // dark, light, margin, background
    sphere: vec4<f32>,   // s-path: sphere centre (camera frame), radius
    lat: vec4<f32>,      // coded boards: lattice period, origin, first sub-interval, cell
    lat2: vec4<f32>,     // coded boards: board end x, end y, narrowest cell, 0
    vw: vec4<u32>,       // planar targets: views per pixel, one set per row (1) or one for all (0), the views' spread (px, f32 bits), 0
    obj: vec4<u32>,      // objects: instances, first instance row in objs, fine samples per axis, 0 (objects.wgsl)
    plane: vec4<f32>,    // planar targets: the plane n . x = c in the camera frame (n, c)
    sheet: vec4<f32>,    // planar targets: the printed sheet in the plane, x0, y0, x1, y1 (metres)
};

@group(0) @binding(0) var<uniform> P: Params;
// Output values, one per work item (coarse: 64 per tile of the work list; fine: one per pixel).
@group(0) @binding(1) var<storage, read_write> out_vals: array<f32>;
@group(0) @binding(2) var<storage, read> dots: array<vec4<f32>>;
@group(0) @binding(3) var<storage, read> tile_start: array<u32>;
@group(0) @binding(4) var<storage, read> tile_items: array<u32>;
// Work list: coarse pass, tile indices; fine pass, pixels packed as x | (y << 16).
@group(0) @binding(5) var<storage, read> work: array<u32>;
// Coarse pass: 1 where the pixel needs the fine pass.
@group(0) @binding(6) var<storage, read_write> out_hard: array<u32>;
// Planar targets: the views a pixel integrates (exposure time and aperture samples, per row under
// a rolling shutter), each the three rows of its plane homography H (src/render/views.rs).
@group(0) @binding(7) var<storage, read> views: array<vec4<f32>>;

// The homography of the view being shaded (set_view): rows of H, (X, Y, W) = H d.
var<private> H0: vec4<f32>;
var<private> H1: vec4<f32>;
var<private> H2: vec4<f32>;

// The index in `views` of the first row of view s of row y.
fn view_index(y: u32, s: u32) -> u32 {
    return 3u * (select(0u, y * P.vw.x, P.vw.y == 1u) + s);
}

// Make view s of the views of row y the current one.
fn set_view(y: u32, s: u32) {
    let k = view_index(y, s);
    H0 = views[k];
    H1 = views[k + 1u];
    H2 = views[k + 2u];
}

// ---------------------------------------------------------------- exact-order arithmetic
// The built-in dot/length/normalize are lowered differently by Mesa's SPIR-V (Vulkan) and GLSL (GL)
// front ends, which changes the last bits and, after quantisation, a few pixels. Written out
// left to right they compile identically, so Vulkan and GL renders are bit-identical.

fn dot2(a: vec2<f32>, b: vec2<f32>) -> f32 { return a.x * b.x + a.y * b.y; }
fn dot3(a: vec3<f32>, b: vec3<f32>) -> f32 { return a.x * b.x + a.y * b.y + a.z * b.z; }
fn len2(a: vec2<f32>) -> f32 { return sqrt(dot2(a, a)); }
fn len3(a: vec3<f32>) -> f32 { return sqrt(dot3(a, a)); }

// ---------------------------------------------------------------- lens model
// Pipeline constants: the lens model and whether the OpenCV sensor is tilted. llvmpipe runs every
// side of a branch under a lane mask, so a uniform `if` on the model would run all three models'
// code per call; as constants, the compiler removes the other models (one pipeline per model).
override LENS_MODEL: u32 = 0u;
override LENS_TILT: bool = false;

// Three models (LENS_MODEL; src/render/gpu_scene.rs LENS_VARIANTS): 0 OpenCV (camera::Distortion:
// rational radial, tangential, thin prism, tilt) and 2 Double Sphere (camera::DoubleSphere) behind
// distort / distort_jac, with rays (xu, 1); 1 OpenCV fisheye (camera::Fisheye) in fisheye_ray, with
// unit rays at any angle it reaches.

fn opencv_untilted(p: vec2<f32>) -> vec2<f32> {
    let r2 = dot2(p, p);
    let g = (1.0 + r2 * (P.dist0.x + r2 * (P.dist0.y + r2 * P.dist1.x))) / (1.0 + r2 * (P.dist1.y + r2 * (P.dist1.z + r2 * P.dist1.w)));
    let xy = p.x * p.y;
    return vec2<f32>(
        g * p.x + 2.0 * P.dist0.z * xy + P.dist0.w * (r2 + 2.0 * p.x * p.x) + r2 * (P.dist2.x + P.dist2.y * r2),
        g * p.y + P.dist0.z * (r2 + 2.0 * p.y * p.y) + 2.0 * P.dist0.w * xy + r2 * (P.dist2.z + P.dist2.w * r2));
}

fn tilt_v(p0: vec2<f32>) -> vec3<f32> {
    return vec3<f32>(
        P.tilt0.x * p0.x + P.tilt0.y * p0.y + P.tilt0.z,
        P.tilt1.x * p0.x + P.tilt1.y * p0.y + P.tilt1.z,
        P.tilt2.x * p0.x + P.tilt2.y * p0.y + P.tilt2.z);
}

fn fisheye_theta_d(th: f32) -> vec2<f32> { // theta_d and its derivative
    let t2 = th * th;
    let poly = 1.0 + t2 * (P.dist0.x + t2 * (P.dist0.y + t2 * (P.dist0.z + t2 * P.dist0.w)));
    let dpoly = 1.0 + t2 * (3.0 * P.dist0.x + t2 * (5.0 * P.dist0.y + t2 * (7.0 * P.dist0.z + t2 * 9.0 * P.dist0.w)));
    return vec2<f32>(th * poly, dpoly);
}

// Double sphere: denominator, and its gradient with respect to xu (z = 1).
struct DsDen { den: f32, grad: vec2<f32> };
fn ds_den(p: vec2<f32>) -> DsDen {
    let xi = P.dist0.x; let al = P.dist0.y;
    let d1 = sqrt(p.x * p.x + p.y * p.y + 1.0);
    let e = xi * d1 + 1.0;
    let d2 = sqrt(p.x * p.x + p.y * p.y + e * e);
    let de = p * (xi / d1);
    let dd2 = (p + de * e) / d2;
    var r: DsDen;
    r.den = al * d2 + (1.0 - al) * e;
    r.grad = dd2 * al + de * (1.0 - al);
    return r;
}

fn distort(p: vec2<f32>) -> vec2<f32> {
    if (LENS_MODEL == 2u) {
        return p / ds_den(p).den;
    }
    let p0 = opencv_untilted(p);
    if (!LENS_TILT) { return p0; }
    let v = tilt_v(p0);
    return vec2<f32>(v.x / v.z, v.y / v.z);
}

fn opencv_untilted_jac(p: vec2<f32>) -> mat2x2<f32> {
    let r2 = dot2(p, p);
    let k1 = P.dist0.x; let k2 = P.dist0.y; let p1 = P.dist0.z; let p2 = P.dist0.w; let k3 = P.dist1.x;
    let num = 1.0 + r2 * (k1 + r2 * (k2 + r2 * k3));
    let den = 1.0 + r2 * (P.dist1.y + r2 * (P.dist1.z + r2 * P.dist1.w));
    let g = num / den;
    let dnum = k1 + r2 * (2.0 * k2 + 3.0 * k3 * r2);
    let dden = P.dist1.y + r2 * (2.0 * P.dist1.z + 3.0 * P.dist1.w * r2);
    let dg = (dnum - g * dden) / den; // dg/d(r2)
    let sx = P.dist2.x + 2.0 * P.dist2.y * r2;
    let sy = P.dist2.z + 2.0 * P.dist2.w * r2;
    let dxdx = g + 2.0 * p.x * p.x * dg + 2.0 * p1 * p.y + 6.0 * p2 * p.x + 2.0 * p.x * sx;
    let dxdy = 2.0 * p.x * p.y * dg + 2.0 * p1 * p.x + 2.0 * p2 * p.y + 2.0 * p.y * sx;
    let dydx = 2.0 * p.x * p.y * dg + 2.0 * p1 * p.x + 2.0 * p2 * p.y + 2.0 * p.x * sy;
    let dydy = g + 2.0 * p.y * p.y * dg + 6.0 * p1 * p.y + 2.0 * p2 * p.x + 2.0 * p.y * sy;
    return mat2x2<f32>(vec2<f32>(dxdx, dydx), vec2<f32>(dxdy, dydy));
}

// d(distort)/d(p), column-major: columns d/dx, d/dy.
fn distort_jac(p: vec2<f32>) -> mat2x2<f32> {
    if (LENS_MODEL == 2u) {
        let d = ds_den(p);
        let m = p / (d.den * d.den);
        return mat2x2<f32>(vec2<f32>(1.0 / d.den, 0.0) - m * d.grad.x, vec2<f32>(0.0, 1.0 / d.den) - m * d.grad.y);
    }
    let j0 = opencv_untilted_jac(p);
    if (!LENS_TILT) { return j0; }
    let v = tilt_v(opencv_untilted(p));
    let iz = 1.0 / v.z;
    // d(v.xy / v.z)/d(p0) = [I | -v.xy / v.z] / v.z times the tilt matrix's first two columns.
    let c0 = vec2<f32>(P.tilt0.x - v.x * iz * P.tilt2.x, P.tilt1.x - v.y * iz * P.tilt2.x) * iz;
    let c1 = vec2<f32>(P.tilt0.y - v.x * iz * P.tilt2.y, P.tilt1.y - v.y * iz * P.tilt2.y) * iz;
    return mat2x2<f32>(c0, c1) * j0;
}

fn inverse2(m: mat2x2<f32>) -> mat2x2<f32> {
    let det = m[0].x * m[1].y - m[1].x * m[0].y;
    return mat2x2<f32>(vec2<f32>(m[1].y, -m[0].y), vec2<f32>(-m[1].x, m[0].x)) * (1.0 / det);
}

struct Ray {
    d: vec3<f32>,         // the pixel centre's ray: (xu, yu, 1), or a fisheye's unit vector
    dd_dq: mat2x3<f32>,   // d(d)/d(pixel): columns d/dqx, d/dqy
    ok: bool,             // false beyond the fold of the lens model
    parts: u32,           // the fine pass splits the pixel into parts x parts sub-pixels (planar_fine)
};

// The ray (xu, 1) and its Jacobian from d(xu)/d(q).
fn planar_ray(xu: vec2<f32>, j: mat2x2<f32>) -> Ray {
    var r: Ray;
    r.d = vec3<f32>(xu, 1.0);
    r.dd_dq = mat2x3<f32>(vec3<f32>(j[0], 0.0), vec3<f32>(j[1], 0.0));
    r.ok = true;
    r.parts = 1u;
    return r;
}

// Fisheye: Newton on theta (theta_d is monotonic up to theta_max = dist1.x, which may pass 90
// degrees: fields of view beyond 180), the unit ray (sin(theta) u, cos(theta)) with u = xd / |xd|,
// and its Jacobian: d(d.xy)/d(xd) = s I + (cos(theta) theta' - s) u u^T with s = sin(theta) / |xd|,
// d(d.z)/d(xd) = -sin(theta) theta' u^T, theta' = 1 / theta_d'(theta).
fn fisheye_ray(xd: vec2<f32>, kinv: mat2x2<f32>) -> Ray {
    let rd = len2(xd);
    if (rd < 1e-10) { return planar_ray(xd, kinv); }
    var th = min(rd, P.dist1.x);
    for (var i = 0; i < 8; i = i + 1) {
        let td = fisheye_theta_d(th);
        th = clamp(th - (td.x - rd) / td.y, 0.0, P.dist1.x);
    }
    let td = fisheye_theta_d(th);
    let u = xd / rd;
    let st = sin(th);
    let ct = cos(th);
    let dth = 1.0 / td.y;
    let s = st / rd;
    let a = ct * dth - s;
    let c0 = vec3<f32>(s + a * u.x * u.x, a * u.x * u.y, -st * dth * u.x);
    let c1 = vec3<f32>(a * u.x * u.y, s + a * u.y * u.y, -st * dth * u.y);
    var r: Ray;
    r.d = vec3<f32>(u * st, ct);
    r.dd_dq = mat2x3<f32>(c0, c1) * kinv;
    r.ok = th < P.dist1.x && td.y > 0.0 && abs(td.x - rd) < 1e-4 * (1.0 + rd);
    r.parts = select(select(1u, 2u, rd > P.dist1.y), 4u, rd > P.dist1.z);
    return r;
}

// Sub-pixel k of the pixel at q split into parts x parts (row-major): its own exact ray, and the
// Jacobian scaled so that the sub-pixel is the unit square of its offsets.
fn sub_ray(q: vec2<f32>, parts: u32, k: u32) -> Ray {
    let n = f32(parts);
    let o = (vec2<f32>(f32(k % parts), f32(k / parts)) + 0.5) / n - 0.5;
    var r = pixel_ray(q + o);
    r.dd_dq = r.dd_dq * (1.0 / n);
    return r;
}

// Rays near the pixel centre's. Only the fisheye's rays are general 3-vectors; the other models'
// keep z = 1 and their offsets z = 0 as literals (LENS_MODEL is a pipeline constant, so each
// pipeline compiles one side): arithmetic on a z the compiler knows is folded differently by
// Mesa's SPIR-V and GLSL paths, and Vulkan and GL renders must stay bit-identical.
fn wide() -> bool { return LENS_MODEL == 1u; }

// d(xy)/d(q) of a ray (xu, 1).
fn jac2(ray: Ray) -> mat2x2<f32> { return mat2x2<f32>(ray.dd_dq[0].xy, ray.dd_dq[1].xy); }

// The pixel centre's ray.
fn ray_d(ray: Ray) -> vec3<f32> {
    if (wide()) { return ray.d; }
    return vec3<f32>(ray.d.xy, 1.0);
}

// Column k of d(d)/d(q).
fn ray_col(ray: Ray, k: u32) -> vec3<f32> {
    let c = select(ray.dd_dq[0], ray.dd_dq[1], k == 1u);
    if (wide()) { return c; }
    return vec3<f32>(c.xy, 0.0);
}

// The change of the ray over the pixel offset t.
fn ray_step(ray: Ray, t: vec2<f32>) -> vec3<f32> {
    if (wide()) { return ray.dd_dq * t; }
    return vec3<f32>(jac2(ray) * t, 0.0);
}

// The centre ray plus a change v (from ray_step or a column of dd_dq).
fn ray_plus(ray: Ray, v: vec3<f32>) -> vec3<f32> {
    if (wide()) { return ray.d + v; }
    return vec3<f32>(ray.d.xy + v.xy, 1.0);
}

// The ray through pixel offset o (distortion linearised over the pixel).
fn ray_at(ray: Ray, o: vec2<f32>) -> vec3<f32> {
    return ray_plus(ray, ray_step(ray, o));
}

// dot(g, v) for v a change of the ray (z = 0 unless wide).
fn dot_step(g: vec3<f32>, v: vec3<f32>) -> f32 {
    if (wide()) { return dot3(g, v); }
    return dot2(g.xy, v.xy);
}

fn pixel_ray(q: vec2<f32>) -> Ray {
    let yd = (q.y - P.intr.w) / P.intr.y;
    let xd = vec2<f32>((q.x - P.intr.z - P.intr2.x * yd) / P.intr.x, yd);
    let kinv = mat2x2<f32>(vec2<f32>(1.0 / P.intr.x, 0.0), vec2<f32>(-P.intr2.x / (P.intr.x * P.intr.y), 1.0 / P.intr.y));
    if (P.intr2.z == 0.0) { return planar_ray(xd, kinv); }
    if (wide()) { return fisheye_ray(xd, kinv); }
    let rd2 = dot2(xd, xd);
    var xu = xd;
    if (LENS_MODEL == 2u) {
        // Double sphere: closed form (Usenko et al. 2018, eq. 45-47); z <= 0 fails the r2_max test.
        let xi = P.dist0.x; let al = P.dist0.y;
        let q = max(1.0 - (2.0 * al - 1.0) * rd2, 0.0);
        let mz = (1.0 - al * al * rd2) / (al * sqrt(q) + 1.0 - al);
        let s = (mz * xi + sqrt(max(mz * mz + (1.0 - xi * xi) * rd2, 0.0))) / (mz * mz + rd2);
        let z = s * mz - xi;
        // Rays at or behind 90 degrees: a finite point far outside r2_max (no NaN or infinity
        // reaches the tests below, which GL and Vulkan may compile differently for NaN).
        xu = vec2<f32>(1e6, 1e6);
        if (z > 1e-6) {
            xu = xd * (s / z);
        }
    } else {
        // First-order start, then Newton (quadratic convergence; 4 steps reach f32 precision).
        xu = xd / (1.0 + rd2 * (P.dist0.x + rd2 * (P.dist0.y + rd2 * P.dist1.x)));
        if (!(dot2(xu, xu) < P.intr2.y)) { xu = xd; }
        for (var i = 0; i < 4; i = i + 1) {
            let j = distort_jac(xu);
            xu = xu - inverse2(j) * (distort(xu) - xd);
        }
    }
    let j = distort_jac(xu);
    let det = j[0].x * j[1].y - j[1].x * j[0].y;
    let res = len2(distort(xu) - xd);
    // d(xd)/d(q) = K^-1 (2x2 part)
    var r = planar_ray(xu, inverse2(j) * kinv);
    r.ok = det > 0.0 && dot2(xu, xu) < P.intr2.y && res < 1e-4 * (1.0 + sqrt(rd2));
    return r;
}

// ---------------------------------------------------------------- planar targets

fn chess_value(x: f32, y: f32) -> f32 {
    let s = P.board.z; let m = P.board.w;
    let w = P.board.x * s; let h = P.board.y * s;
    if (x >= 0.0 && x < w && y >= 0.0 && y < h) {
        let ij = i32(floor(x / s)) + i32(floor(y / s));
        return select(P.grey.y, P.grey.x, (ij & 1) == 0);
    }
    if (x >= -m && x < w + m && y >= -m && y < h + m) { return P.grey.z; }
    return P.grey.w;
}

fn grid_value(x: f32, y: f32) -> f32 {
    let n = P.board.x; let hh = 0.5 * P.board.y; let rad = P.board.z; let outer = hh + P.board.w;
    if (x < -outer || x >= outer || y < -outer || y >= outer) { return P.grey.w; }
    let pitch = P.board.y / (n - 1.0);
    let ix = clamp(round((x + hh) / pitch), 0.0, n - 1.0);
    let iy = clamp(round((y + hh) / pitch), 0.0, n - 1.0);
    let d = vec2<f32>(x + hh - pitch * ix, y + hh - pitch * iy);
    return select(P.grey.y, P.grey.x, dot2(d, d) < rad * rad);
}

fn plane_value(b: vec2<f32>) -> f32 {
    if (P.size.z == 4u) { return coded_value(b.x, b.y); }
    return select(grid_value(b.x, b.y), chess_value(b.x, b.y), P.size.z == 0u);
}

// ---------------------------------------------------------------- coded boards (cell lattice)
// Every edge of a coded board (ChArUco: squares, marker borders and bits) lies on one lattice,
// the same along x and y (src/target/lattice.rs CellLattice): periods of P.lat.x from P.lat.y,
// each cut at P.lat.z and then every P.lat.w; sub-interval 0 is [0, lat.z), the last ends at the
// period's end. Global index g = period * P.board.z + sub; the board holds g in
// [0, P.board.x) x [0, P.board.y) and spans [lat.y, lat2.x) x [lat.y, lat2.y). Dark cells: bit
// gy * board.x + gx of tile_items.

fn lat_index(x: f32) -> i32 {
    let per = i32(P.board.z);
    let t = floor((x - P.lat.y) / P.lat.x);
    let u = x - P.lat.y - t * P.lat.x;
    var sub = 0;
    if (u >= P.lat.z) { sub = min(1 + i32(floor((u - P.lat.z) / P.lat.w)), per - 1); }
    return i32(t) * per + sub;
}

// [lo, hi] of sub-interval g.
fn lat_bounds(g: i32) -> vec2<f32> {
    let per = i32(P.board.z);
    let period = g / per;
    let sub = g - period * per;
    let start = P.lat.y + f32(period) * P.lat.x;
    let lo = select(P.lat.z + f32(sub - 1) * P.lat.w, 0.0, sub == 0);
    let hi = select(select(P.lat.z + f32(sub) * P.lat.w, P.lat.z, sub == 0), P.lat.x, sub == per - 1);
    return vec2<f32>(start + lo, start + hi);
}

fn coded_dark(gx: i32, gy: i32) -> bool {
    let k = u32(gy) * u32(P.board.x) + u32(gx);
    return ((tile_items[k >> 5u] >> (k & 31u)) & 1u) == 1u;
}

fn coded_value(x: f32, y: f32) -> f32 {
    let o = P.lat.y; let m = P.board.w;
    if (x >= o && x < P.lat2.x && y >= o && y < P.lat2.y) {
        let gx = clamp(lat_index(x), 0, i32(P.board.x) - 1);
        let gy = clamp(lat_index(y), 0, i32(P.board.y) - 1);
        return select(P.grey.y, P.grey.x, coded_dark(gx, gy));
    }
    if (x >= o - m && x < P.lat2.x + m && y >= o - m && y < P.lat2.y + m) { return P.grey.z; }
    return P.grey.w;
}

// The lattice's lines of the coded board along one axis in [lo, hi] (the board's edges
// included): count and the first (the only one when the count is 1).
fn coded_lines(lo: f32, hi: f32, end: f32, cells: f32) -> Lines {
    var l: Lines;
    // Index -1: before the board; cells: after it (lines o and end between them and the board).
    let g0 = clamp(lat_index(lo), -1, i32(cells));
    let g1 = clamp(lat_index(hi), -1, i32(cells));
    l.count = u32(g1 - g0);
    l.first = select(lat_bounds(max(g1, 0)).x, end, g1 == i32(cells));
    return l;
}

// Target-plane point of the ray d (any length and direction: H is linear); z < 0 when the ray
// misses (plane behind).
fn plane_point(d: vec3<f32>) -> vec3<f32> {
    let hw = h_dot(H2.xyz, d);
    return vec3<f32>(h_dot(H0.xyz, d) / hw, h_dot(H1.xyz, d) / hw, hw);
}

// A homography row times the ray d (the z = 1 of a non-wide ray as a literal, see wide()).
fn h_dot(h: vec3<f32>, d: vec3<f32>) -> f32 {
    if (wide()) { return h.x * d.x + h.y * d.y + h.z * d.z; }
    return h.x * d.x + h.y * d.y + h.z;
}

// Box filter by brute force: samples^2 sub-samples, each mapped with the local inverse Jacobian
// (no further inversion) and intersected exactly with the plane.
// `n` may differ per lane (0 = skip): llvmpipe runs both sides of every `if` under a lane mask but
// leaves a loop as soon as no lane is active, so rare expensive work lives in loops with per-lane
// trip counts.
fn plane_supersample(ray: Ray, n: u32) -> f32 {
    let inv = 1.0 / f32(n);
    var acc = 0.0;
    for (var j = 0u; j < n; j = j + 1u) {
        for (var i = 0u; i < n; i = i + 1u) {
            let d = vec2<f32>((f32(i) + 0.5) * inv - 0.5, (f32(j) + 0.5) * inv - 0.5);
            let pp = plane_point(ray_at(ray, d));
            acc = acc + select(P.grey.w, plane_value(pp.xy), pp.z > 0.0);
        }
    }
    return acc * inv * inv;
}

// Area of the unit pixel square [-0.5, 0.5]^2 where dot(n, d) >= c, in closed form: dot(n, d) over
// the square is distributed as the sum of two uniform variables (a trapezoid), so the area is its
// complementary CDF at c.
fn halfplane_area(n: vec2<f32>, c: f32) -> f32 {
    let a = max(abs(n.x), abs(n.y));
    let b = min(abs(n.x), abs(n.y));
    if (a <= 0.0) { return select(0.0, 1.0, c <= 0.0); }
    let cc = abs(c);
    var g = 0.0;
    if (cc < 0.5 * (a - b)) {
        g = 0.5 - cc / a;
    } else if (cc < 0.5 * (a + b)) {
        let d = 0.5 * (a + b) - cc;
        g = d * d / (2.0 * a * b);
    }
    return select(1.0 - g, g, c >= 0.0);
}

// The square lines of the chessboard along one axis that fall in [lo, hi]: count and the first.
struct Lines { count: u32, first: f32, };

fn chess_lines(lo: f32, hi: f32, n_squares: f32) -> Lines {
    var l: Lines;
    let s = P.board.z;
    let j0 = max(ceil(lo / s), 0.0);
    let j1 = min(floor(hi / s), n_squares);
    l.count = u32(max(j1 - j0 + 1.0, 0.0));
    l.first = j0 * s;
    return l;
}

// d(board)/d(pixel) at the plane point pc of the pixel centre: the homography's Jacobian chained
// with d(d)/d(q). Columns: d(board)/d(qx), d(board)/d(qy).
fn board_jacobian(pc: vec3<f32>, ray: Ray) -> mat2x2<f32> {
    let dbdxy = mat2x2<f32>(
        vec2<f32>(H0.x - pc.x * H2.x, H1.x - pc.y * H2.x) / pc.z,
        vec2<f32>(H0.y - pc.x * H2.y, H1.y - pc.y * H2.y) / pc.z);
    if (!wide()) { return dbdxy * jac2(ray); }
    let dbdz = vec2<f32>(H0.z - pc.x * H2.z, H1.z - pc.y * H2.z) / pc.z;
    let j0 = ray_col(ray, 0u);
    let j1 = ray_col(ray, 1u);
    return dbdxy * jac2(ray) + mat2x2<f32>(dbdz * j0.z, dbdz * j1.z);
}

// ---------------------------------------------------------------- exact pixel coverage
// Areas of the pixel square S = [-0.5, 0.5]^2 (pixel offsets d) inside regions of the target
// plane, with no arrays (llvmpipe lowers indexed local arrays into long code, and LLVM then
// takes seconds to compile it). A board rectangle is the intersection of four half-planes
// n.d >= c (board_line, exact under the homography; only the distortion is linearised over the
// pixel); its area inside S follows from Green's theorem: the sum over the eight boundary lines
// (four of S, four of the rectangle) of the part of each line inside the other seven. A dot-grid
// disc is the ellipse it images to, mapped onto the unit circle. The CPU reference
// src/scene/exact.rs computes the same areas independently, in f64, by polygon clipping.

// The board line {board coordinate `axis` = v} in pixel offsets d: board coordinate >= v where
// dot(l.xy, d) >= l.z. (The affine footprint would put the centre's pc for v in the normal.)
fn board_line(axis: u32, v: f32, pc: vec3<f32>, ray: Ray) -> vec3<f32> {
    let h = select(H0, H1, axis == 1u);
    let g = (h.xyz - v * H2.xyz) / pc.z;
    return vec3<f32>(dot_step(g, ray_col(ray, 0u)), dot_step(g, ray_col(ray, 1u)), v - select(pc.x, pc.y, axis == 1u));
}

// Clip the parameter interval st of the line p0 + s u to the half-plane dot(l.xy, d) >= l.z.
fn clip_param(st: vec2<f32>, p0: vec2<f32>, u: vec2<f32>, l: vec3<f32>) -> vec2<f32> {
    let rate = dot2(l.xy, u);
    let gap = dot2(l.xy, p0) - l.z;
    let scale = len2(l.xy);
    // Parallel (the line itself, or a parallel side): all of it or none of it.
    if (abs(rate) <= 1e-6 * scale) { return select(vec2<f32>(1.0, 0.0), st, gap >= -1e-5 * scale); }
    let s = -gap / rate;
    return select(vec2<f32>(st.x, min(st.y, s)), vec2<f32>(max(st.x, s), st.y), rate > 0.0);
}

// Half-plane k of the region S (k = 0..3: x >= -0.5, x <= 0.5, y >= -0.5, y <= 0.5) intersected
// with the rectangle r0..r3 (k = 4..7), as dot(l.xy, d) >= l.z. Chosen by select, not from an
// array: the loops below then compile to one copy of their body.
fn region_line(k: u32, r0: vec3<f32>, r1: vec3<f32>, r2: vec3<f32>, r3: vec3<f32>) -> vec3<f32> {
    let sx = select(-1.0, 1.0, k == 0u);
    let sy = select(-1.0, 1.0, k == 2u);
    let square = select(vec3<f32>(0.0, sy, -0.5), vec3<f32>(sx, 0.0, -0.5), k < 2u);
    let rect = select(select(r3, r2, k == 6u), select(r1, r0, k == 4u), k < 6u);
    return select(rect, square, k < 4u);
}

// Twice the signed area term of the part of the boundary line of region half-plane `k` that lies
// in all the others, traversed with the region on its left.
fn line_term(k: u32, r0: vec3<f32>, r1: vec3<f32>, r2: vec3<f32>, r3: vec3<f32>) -> f32 {
    let l = region_line(k, r0, r1, r2, r3);
    let nn = dot2(l.xy, l.xy);
    let p0 = l.xy * (l.z / max(nn, 1e-30));
    let u = vec2<f32>(l.y, -l.x) / sqrt(max(nn, 1e-30));
    var st = vec2<f32>(-1e30, 1e30);
    for (var j = 0u; j < 8u; j = j + 1u) {
        st = clip_param(st, p0, u, region_line(j, r0, r1, r2, r3));
    }
    return select(0.0, max(st.y - st.x, 0.0) * (p0.x * u.y - p0.y * u.x), nn > 0.0);
}

// Area of S whose board points lie in the rectangle [lo, hi] (board coordinates).
fn rect_area(lo: vec2<f32>, hi: vec2<f32>, pc: vec3<f32>, ray: Ray) -> f32 {
    let a = board_line(0u, lo.x, pc, ray);
    let b = -board_line(0u, hi.x, pc, ray);
    let c = board_line(1u, lo.y, pc, ray);
    let d = -board_line(1u, hi.y, pc, ray);
    var s = 0.0;
    for (var k = 0u; k < 8u; k = k + 1u) {
        s = s + line_term(k, a, b, c, d);
    }
    return clamp(0.5 * s, 0.0, 1.0);
}

// Twice the signed area between the chord e -> s of the unit circle and its arc, going round in
// the direction sigma (1 counter-clockwise, -1 clockwise), plus the chord's shoelace term. The
// segment's (theta - sin theta) comes from a series for short arcs: through atan2 it would lose
// the few ulps that are the whole of a pixel's share of a circle 100 pixels across.
fn arc_term(e: vec2<f32>, s: vec2<f32>, sigma: f32) -> f32 {
    let cr = e.x * s.y - e.y * s.x;
    let h = 0.5 * len2(s - e);
    var seg = 0.0;
    if (h < 0.1 && sigma * cr >= 0.0) {
        let h2 = h * h;
        let theta = 2.0 * h * (1.0 + h2 * (1.0 / 6.0 + h2 * (3.0 / 40.0)));
        let t2 = theta * theta;
        seg = theta * t2 * (1.0 / 6.0 - t2 * (1.0 / 120.0 - t2 * (1.0 / 5040.0)));
    } else {
        var theta = atan2(sigma * cr, dot2(e, s));
        theta = select(theta, theta + 6.2831853, theta < 0.0);
        seg = theta - sin(theta);
    }
    return cr + sigma * seg;
}

// Corner k (counter-clockwise) of S.
fn square_corner(k: u32) -> vec2<f32> {
    return vec2<f32>(select(-0.5, 0.5, k == 1u || k == 2u), select(-0.5, 0.5, k >= 2u));
}

// Area of S inside the unit circle after the affine map d -> m (d - o) (m upper triangular:
// m.x, m.y first row, m.z second row's diagonal), in mapped units, from the boundary of the
// intersection: the parts of S's mapped edges inside the circle (shoelace terms) and, from each
// point where the boundary leaves the circle to the point where it next enters, the arc.
fn unit_disc_area(o: vec2<f32>, m: vec3<f32>) -> f32 {
    var s = 0.0;
    var exit = vec2<f32>(0.0);
    var first_entry = vec2<f32>(0.0);
    var have_exit = false;
    var have_first = false;
    var crossings = 0u;
    var origin_inside = true;
    let sigma = 1.0; // the map keeps orientation (positive diagonal)
    for (var i = 0u; i < 4u; i = i + 1u) {
        let ea = square_corner(i) - o;
        let eb = square_corner((i + 1u) & 3u) - o;
        let a = vec2<f32>(m.x * ea.x + m.y * ea.y, m.z * ea.y);
        let b = vec2<f32>(m.x * eb.x + m.y * eb.y, m.z * eb.y);
        let d = b - a;
        origin_inside = origin_inside && (a.x * d.y - a.y * d.x) >= 0.0;
        let qa = dot2(d, d);
        let qb = 2.0 * dot2(a, d);
        let qc = dot2(a, a) - 1.0;
        let disc = qb * qb - 4.0 * qa * qc;
        if (qa > 0.0 && disc > 0.0) {
            let sq = sqrt(disc);
            let t0 = (-qb - sq) / (2.0 * qa);
            let t1 = (-qb + sq) / (2.0 * qa);
            let lo = max(t0, 0.0);
            let hi = min(t1, 1.0);
            if (lo < hi) {
                let pin = a + d * lo;
                let pout = a + d * hi;
                if (t0 > 0.0) {
                    if (have_exit) { s = s + arc_term(exit, pin, sigma); have_exit = false; }
                    else { first_entry = pin; have_first = true; }
                    crossings = crossings + 1u;
                }
                s = s + (pin.x * pout.y - pin.y * pout.x);
                if (t1 < 1.0) { exit = pout; have_exit = true; crossings = crossings + 1u; }
            }
        }
    }
    if (have_exit && have_first) { s = s + arc_term(exit, first_entry, sigma); }
    // No crossing and no edge inside: the circle is inside S, or they are apart.
    let whole = crossings == 0u && s == 0.0 && origin_inside;
    return select(abs(0.5 * s), 3.14159265, whole);
}

// Most cells (chessboard squares, dot-grid discs) per axis the exact fine pass handles;
// larger footprints (squares or dots of about a pixel or less) are supersampled.
const MAX_CELLS: f32 = 6.0;

// The affine footprint's board extent, widened to hold the exact (projective) footprint: they
// differ at second order, by far less than 2 % over one pixel.
const FOOTPRINT_SLACK: f32 = 1.02;

// Half-extent along board x and y of the pixel's footprint (a = board_jacobian), widened by
// FOOTPRINT_SLACK.
fn footprint_extent(a: mat2x2<f32>) -> vec2<f32> {
    return FOOTPRINT_SLACK * 0.5 * vec2<f32>(abs(a[0].x) + abs(a[1].x), abs(a[0].y) + abs(a[1].y));
}

struct Coarse { value: f32, hard: bool, };

// Boards of axis-aligned cells, each dark or light: the chessboard (cells: its squares; P.board
// nx, ny, square, margin) and coded boards (cells: the lattice's; P.board cells x, y, per period,
// margin). `coded` is a literal at each call, so each entry point compiles one kind.

fn cell_value(x: f32, y: f32, coded: bool) -> f32 {
    if (coded) { return coded_value(x, y); }
    return chess_value(x, y);
}

// The narrowest cell, board units.
fn min_cell(coded: bool) -> f32 { return select(P.board.z, P.lat2.z, coded); }

// The board's extent (the margin lies around it).
fn board_lo(coded: bool) -> vec2<f32> { return select(vec2<f32>(0.0, 0.0), vec2<f32>(P.lat.y, P.lat.y), coded); }
fn board_hi(coded: bool) -> vec2<f32> { return select(vec2<f32>(P.board.x * P.board.z, P.board.y * P.board.z), P.lat2.xy, coded); }

// The board's lines along `axis` in [lo, hi], and its margin's outer edges: count and the first
// (the only one when the count is 1).
fn board_lines(lo: f32, hi: f32, axis: u32, coded: bool) -> Lines {
    let n = select(P.board.x, P.board.y, axis == 1u);
    let start = select(board_lo(coded).x, board_lo(coded).y, axis == 1u);
    let end = select(board_hi(coded).x, board_hi(coded).y, axis == 1u);
    var l: Lines;
    if (coded) { l = coded_lines(lo, hi, end, n); } else { l = chess_lines(lo, hi, n); }
    let m = P.board.w;
    if (m > 0.0) {
        if (start - m >= lo && start - m <= hi) { l.count = l.count + 1u; l.first = start - m; }
        if (end + m >= lo && end + m <= hi) { l.count = l.count + 1u; l.first = end + m; }
    }
    return l;
}

// The cell holding board coordinate v along `axis`, clamped to the board.
fn cell_of(v: f32, axis: u32, coded: bool) -> i32 {
    let n = select(P.board.x, P.board.y, axis == 1u);
    if (coded) { return clamp(lat_index(v), 0, i32(n) - 1); }
    return i32(clamp(floor(v / P.board.z), 0.0, n - 1.0));
}

// [lo, hi] of cell g along an axis.
fn cell_bounds(g: i32, coded: bool) -> vec2<f32> {
    if (coded) { return lat_bounds(g); }
    let lo = f32(g) * P.board.z;
    return vec2<f32>(lo, lo + P.board.z);
}

fn cell_dark(gx: i32, gy: i32, coded: bool) -> bool {
    if (coded) { return coded_dark(gx, gy); }
    return ((u32(gx) + u32(gy)) & 1u) == 0u;
}

// Coarse: flat pixels and pixels crossed by one line (exact closed-form coverage); corners,
// several lines or a large footprint are hard.
fn cells_coarse(ray: Ray, coded: bool) -> Coarse {
    var out: Coarse;
    let pc = plane_point(ray_d(ray));
    let a = board_jacobian(pc, ray);
    let ext = footprint_extent(a);
    let ex = ext.x;
    let ey = ext.y;
    let s = min_cell(coded);
    let small = ex < 0.25 * s && ey < 0.25 * s;
    let lx = board_lines(pc.x - ex, pc.x + ex, 0u, coded);
    let ly = board_lines(pc.y - ey, pc.y + ey, 1u, coded);
    let hasx = lx.count == 1u;
    let line = board_line(select(1u, 0u, hasx), select(ly.first, lx.first, hasx), pc, ray);
    let area = halfplane_area(line.xy, line.z);
    // Representative board points on both sides, midway between the line and the footprint edge.
    let e = select(ey, ex, hasx);
    let l0 = select(ly.first, lx.first, hasx);
    let cen = select(pc.y, pc.x, hasx);
    let plus = 0.5 * (l0 + cen + e);
    let minus = 0.5 * (l0 + cen - e);
    let vp = select(cell_value(pc.x, plus, coded), cell_value(plus, pc.y, coded), hasx);
    let vm = select(cell_value(pc.x, minus, coded), cell_value(minus, pc.y, coded), hasx);
    let nlines = lx.count + ly.count;
    let v = select(vp * area + vm * (1.0 - area), cell_value(pc.x, pc.y, coded), nlines == 0u);
    out.value = select(P.grey.w, v, pc.z > 0.0 && ray.ok);
    out.hard = ray.ok && pc.z > 0.0 && (!small || nlines > 1u || (nlines > 0u && ray.parts > 1u));
    return out;
}

// Fine: the exact area of the pixel square whose board points fall in the margin, on the board
// and in every dark cell it meets (rect_area); supersampled only when the pixel meets more than
// MAX_CELLS cells per axis. One loop over the rectangles keeps the code small.
fn cells_fine(ray: Ray, coded: bool) -> f32 {
    let pc = plane_point(ray_d(ray));
    let a = board_jacobian(pc, ray);
    let ext = footprint_extent(a);
    let m = P.board.w;
    let blo = board_lo(coded);
    let bhi = board_hi(coded);
    let i0 = cell_of(pc.x - ext.x, 0u, coded);
    let i1 = cell_of(pc.x + ext.x, 0u, coded);
    let j0 = cell_of(pc.y - ext.y, 1u, coded);
    let j1 = cell_of(pc.y + ext.y, 1u, coded);
    let exact = f32(i1 - i0) < MAX_CELLS && f32(j1 - j0) < MAX_CELLS;
    let ni = u32(i1 - i0) + 1u;
    let cells = select(0u, ni * (u32(j1 - j0) + 1u), exact);
    // Rectangle 0: the margin's outline; 1: the board; 2..: the cells (dark ones only).
    var a_margin = 0.0; var a_board = 0.0; var dark = 0.0;
    for (var k = 0u; k < 2u + cells; k = k + 1u) {
        let c = k - 2u;
        let i = i0 + i32(c % ni);
        let j = j0 + i32(c / ni);
        let bx = cell_bounds(i, coded);
        let by = cell_bounds(j, coded);
        var lo = vec2<f32>(bx.x, by.x);
        var hi = vec2<f32>(bx.y, by.y);
        lo = select(lo, blo, k == 1u);
        hi = select(hi, bhi, k == 1u);
        lo = select(lo, blo - vec2<f32>(m, m), k == 0u);
        hi = select(hi, bhi + vec2<f32>(m, m), k == 0u);
        let is_dark = k < 2u || cell_dark(i, j, coded);
        var area = 0.0;
        if (is_dark) { area = rect_area(lo, hi, pc, ray); }
        a_margin = select(a_margin, area, k == 0u);
        a_board = select(a_board, area, k == 1u);
        dark = dark + select(0.0, area, k >= 2u);
    }
    let v = P.grey.w * (1.0 - a_margin) + P.grey.z * (a_margin - a_board) + P.grey.x * dark + P.grey.y * (a_board - dark);
    let sup = plane_supersample(ray, select(P.size.w, 0u, exact));
    return select(sup, v, exact);
}

// Dot grid, coarse: pixels near a disc or plate edge are hard.
fn grid_coarse(ray: Ray) -> Coarse {
    var out: Coarse;
    let pc = plane_point(ray_d(ray));
    let a = board_jacobian(pc, ray);
    let ext = 0.75 * (len2(a[0]) + len2(a[1])) + 1e-7;
    let n = P.board.x; let hh = 0.5 * P.board.y; let rad = P.board.z; let outer = hh + P.board.w;
    let pitch = P.board.y / (n - 1.0);
    let ix = clamp(round((pc.x + hh) / pitch), 0.0, n - 1.0);
    let iy = clamp(round((pc.y + hh) / pitch), 0.0, n - 1.0);
    let dd = len2(vec2<f32>(pc.x + hh - pitch * ix, pc.y + hh - pitch * iy));
    let near_dot = abs(dd - rad) < ext;
    let near_edge = abs(abs(pc.x) - outer) < ext || abs(abs(pc.y) - outer) < ext;
    out.hard = ray.ok && pc.z > 0.0 && (near_dot || near_edge || ext > 0.25 * rad);
    out.value = select(P.grey.w, grid_value(pc.x, pc.y), pc.z > 0.0 && ray.ok);
    return out;
}

// Area of S whose board points lie in the disc of radius r, where u0 is the pixel centre's board
// point minus the disc's centre, a = board_jacobian and g the gradient of the homography's w over
// the pixel divided by w: the board point of offset d is (u0 + (a + u0 g^T) d) / (1 + g.d) (exact
// under the homography), so the disc is the ellipse |u0 + M d|^2 <= r^2 (1 + g.d)^2 in offsets,
// mapped here onto the unit circle (unit_disc_area). Negative when the conic is no ellipse (then
// the pixel is supersampled).
fn disc_in_pixels(u0: vec2<f32>, a: mat2x2<f32>, g: vec2<f32>, r: f32) -> f32 {
    let m0 = a[0] + u0 * g.x;
    let m1 = a[1] + u0 * g.y;
    let r2 = r * r;
    let q00 = dot2(m0, m0) - r2 * g.x * g.x;
    let q01 = dot2(m0, m1) - r2 * g.x * g.y;
    let q11 = dot2(m1, m1) - r2 * g.y * g.y;
    let b = vec2<f32>(dot2(m0, u0) - r2 * g.x, dot2(m1, u0) - r2 * g.y);
    let lu = len2(u0);
    return ellipse_area(vec3<f32>(q00, q01, q11), b, (lu - r) * (lu + r));
}

// Area of the pixel square where o^T Q o + 2 b.o + c <= 0 (Q = (q.x, q.y; q.y, q.z)), when that
// is an ellipse: mapped onto the unit circle (unit_disc_area). Negative when it is no ellipse.
fn ellipse_area(q: vec3<f32>, b: vec2<f32>, c: f32) -> f32 {
    let det = q.x * q.z - q.y * q.y;
    if (!(det > 0.0 && q.x > 0.0)) { return -1.0; }
    // Centre -qb, then (o + qb)^T Q (o + qb) <= k; Q / k = L^T L with L upper triangular.
    let qb = vec2<f32>(q.z * b.x - q.y * b.y, q.x * b.y - q.y * b.x) / det;
    let k = dot2(b, qb) - c;
    if (!(k > 0.0)) { return 0.0; }
    let l11 = sqrt(q.x / k);
    let l12 = q.y / (k * l11);
    let l22 = sqrt(max(q.z / k - l12 * l12, 1e-30));
    return unit_disc_area(-qb, vec3<f32>(l11, l12, l22)) / (l11 * l22);
}

// Dot grid, fine: the exact area of the pixel square whose board points fall on the plate
// (rect_area) and in every disc within reach (disc_in_pixels); supersampled only when more than
// MAX_CELLS discs per axis are in reach.
fn grid_fine(ray: Ray) -> f32 {
    let pc = plane_point(ray_d(ray));
    let a = board_jacobian(pc, ray);
    let ext = footprint_extent(a);
    let ex = ext.x;
    let ey = ext.y;
    let n = P.board.x; let hh = 0.5 * P.board.y; let rad = P.board.z; let outer = hh + P.board.w;
    let pitch = P.board.y / (n - 1.0);
    let i0 = clamp(ceil((pc.x - ex + hh - rad) / pitch), 0.0, n - 1.0);
    let i1 = clamp(floor((pc.x + ex + hh + rad) / pitch), 0.0, n - 1.0);
    let j0 = clamp(ceil((pc.y - ey + hh - rad) / pitch), 0.0, n - 1.0);
    let j1 = clamp(floor((pc.y + ey + hh + rad) / pitch), 0.0, n - 1.0);
    var exact = i1 - i0 < MAX_CELLS && j1 - j0 < MAX_CELLS && pc.z > 0.0;
    let g = vec2<f32>(dot_step(H2.xyz, ray_col(ray, 0u)), dot_step(H2.xyz, ray_col(ray, 1u))) / pc.z;
    let a_plate = rect_area(vec2<f32>(-outer, -outer), vec2<f32>(outer, outer), pc, ray);
    let ni = select(0u, u32(max(i1 - i0 + 1.0, 0.0)), exact);
    let nj = select(0u, u32(max(j1 - j0 + 1.0, 0.0)), exact);
    var dark = 0.0;
    for (var jj = 0u; jj < nj; jj = jj + 1u) {
        for (var ii = 0u; ii < ni; ii = ii + 1u) {
            let c = vec2<f32>(pitch * (i0 + f32(ii)) - hh, pitch * (j0 + f32(jj)) - hh);
            // Discs lie inside the plate (margin_m >= dot_radius_m is validated).
            let area = disc_in_pixels(pc.xy - c, a, g, rad);
            exact = exact && area >= 0.0;
            dark = dark + max(area, 0.0);
        }
    }
    let v = P.grey.w * (1.0 - a_plate) + P.grey.y * (a_plate - dark) + P.grey.x * dark;
    let sup = plane_supersample(ray, select(P.size.w, 0u, exact));
    return select(sup, v, exact);
}

// ---------------------------------------------------------------- S-path

// Smallest positive distance t along the ray direction d (any length) with |t d/|d| - c| = r, or -1.
// The discriminant is formed from the perpendicular distance of c from the ray, not as
// b^2 - |c|^2 + r^2: in f32 that difference of numbers ~|c|^2 would cost ~0.02 px on a 6 mm bead
// 1.5 m away.
fn hit_sphere(d: vec3<f32>, c: vec3<f32>, r: f32) -> f32 {
    let n = d / len3(d);
    let along = dot3(n, c);
    let perp = c - n * along;
    let disc = r * r - dot3(perp, perp);
    let sq = sqrt(max(disc, 0.0));
    let t0 = along - sq;
    let t1 = along + sq;
    let t = select(select(-1.0, t1, t1 > 0.0), t0, t0 > 0.0);
    return select(t, -1.0, disc < 0.0);
}

// What a ray has met among the dots so far: the nearest bead entry, and whether its sphere hit
// point h lies in a painted cap.
struct Seen { best: f32, in_cap: bool, };

fn see_dot(s: Seen, d: vec3<f32>, h: vec3<f32>, b: vec4<f32>) -> Seen {
    var out: Seen;
    let t = hit_sphere(d, b.xyz, b.w);
    out.best = select(s.best, t, t > 0.0 && t < s.best);
    let dh = h - b.xyz;
    out.in_cap = s.in_cap || dot3(dh, dh) < b.w * b.w;
    return out;
}

// Grey level of a ray that hits the sphere at distance ts (<= 0: misses) and met the dots `s`.
fn spath_grey(ts: f32, s: Seen) -> f32 {
    let sphere_or_bg = select(P.grey.w, P.grey.y, ts > 0.0);
    let bead = select(sphere_or_bg, P.grey.x, s.best < 1e30 && (ts <= 0.0 || s.best <= ts));
    let disc = select(sphere_or_bg, P.grey.x, ts > 0.0 && s.in_cap);
    return select(bead, disc, P.tiles.z == 1u);
}

// Grey level seen along d (camera frame) with the dots k in [t_begin, t_end) of the tile list.
fn spath_sample(d: vec3<f32>, t_begin: u32, t_end: u32) -> f32 {
    return spath_grey_among(d, hit_sphere(d, P.sphere.xyz, P.sphere.w), t_begin, t_end);
}

// spath_sample with the ray's sphere hit ts already known.
fn spath_grey_among(d: vec3<f32>, ts: f32, t_begin: u32, t_end: u32) -> f32 {
    let h = d / len3(d) * ts;
    var s = Seen(1e30, false);
    for (var k = t_begin; k < t_end; k = k + 1u) {
        s = see_dot(s, d, h, dots[tile_items[k]]);
    }
    return spath_grey(ts, s);
}

// The dots a fine-pass pixel's rays can meet (gather_near). llvmpipe ends every loop of an
// invocation once the iterations of all its loops together reach 65 535 (gallivm's
// LP_MAX_TGSI_LOOP_ITERATIONS, counted per SIMD batch and shared by every loop of the shader),
// silently: scan lines that looped over a whole tile's dots for every sample, and over the
// bisection steps, ran past it and lost part of the pixel (up to 47 grey levels, measured).
// So the fine pass tests its pixel's first NEAR_SLOTS dots without a loop (only a pixel near
// more dots than that loops over them) and stops refining at LINE_BUDGET scan lines.
const NEAR_SLOTS: u32 = 4u;
// A dot no ray meets: behind the camera, radius 0.
const NO_DOT: vec4<f32> = vec4<f32>(0.0, 0.0, -1.0, 0.0);
var<private> near_dots: array<vec4<f32>, NEAR_SLOTS>;
var<private> near_count: u32;
var<private> near_begin: u32;
var<private> near_end: u32;

fn gather_near(ray: Ray, t_begin: u32, t_end: u32) {
    let d = ray_d(ray);
    let alpha = pixel_cone(ray);
    near_count = 0u;
    near_begin = t_begin;
    near_end = t_end;
    near_dots = array<vec4<f32>, NEAR_SLOTS>(NO_DOT, NO_DOT, NO_DOT, NO_DOT);
    for (var k = t_begin; k < t_end; k = k + 1u) {
        let b = dots[tile_items[k]];
        if cone_near_ball(d, alpha, b.xyz, b.w, true) {
            if near_count < NEAR_SLOTS { near_dots[near_count] = b; }
            near_count = near_count + 1u;
        }
    }
}

// spath_grey_among over the gathered dots (the whole tile when more than NEAR_SLOTS were near),
// for a ray whose sphere hit ts is known.
fn spath_sample_near(d: vec3<f32>, ts: f32) -> f32 {
    if near_count > NEAR_SLOTS { return spath_grey_among(d, ts, near_begin, near_end); }
    let h = d / len3(d) * ts;
    var s = Seen(1e30, false);
    s = see_dot(s, d, h, near_dots[0]);
    s = see_dot(s, d, h, near_dots[1]);
    s = see_dot(s, d, h, near_dots[2]);
    s = see_dot(s, d, h, near_dots[3]);
    return spath_grey(ts, s);
}

// Half-angle of a cone about the pixel's centre ray that holds the rays of the whole pixel
// square: its half-diagonal plus 10 %.
fn pixel_cone(ray: Ray) -> f32 {
    let a = ray_col(ray, 0u) + ray_col(ray, 1u);
    let b = ray_col(ray, 0u) - ray_col(ray, 1u);
    let half_diag = 0.5 * select(max(len2(a.xy), len2(b.xy)), max(len3(a), len3(b)), wide());
    return 1.1 * half_diag / len3(ray_d(ray));
}

// Does the cone of rays through the pixel (axis d, half-angle alpha >= the pixel's half-diagonal) reach the
// outline of the ball (c, r)? `inside` also counts rays that pass through the ball.
fn cone_near_ball(d: vec3<f32>, alpha: f32, c: vec3<f32>, r: f32, inside: bool) -> bool {
    let n = (d / len3(d));
    let along = dot3(n, c);
    let dist = len3(c - n * along);
    let slack = alpha * len3(c) + 1e-6 * r;
    let near = select(abs(dist - r) < slack, dist < r + slack, inside);
    return along > 0.0 && near;
}

// S-path, coarse: one ray per pixel. A pixel is hard when the cone of its rays reaches the outline
// of the sphere or of a dot, or when its centre and corner rays disagree (the outline of the part
// of a bead the sphere does not hide).

// Signed distance (metres, at the sphere) of the ray d from the outline of the sphere: negative
// inside.
fn limb_distance(d: vec3<f32>) -> f32 {
    let n = d / len3(d);
    let c = P.sphere.xyz;
    return len3(c - n * dot3(n, c)) - P.sphere.w;
}

// Coverage of the pixel by {g < 0} for a smooth boundary g, from g0 = g(centre), its gradient
// (per pixel) and its second derivative along the boundary's tangent (per pixel^2): the closed-form
// area of the linearised half-plane, minus the sliver between the tangent line and the curved
// boundary, kappa (s_hi^3 - s_lo^3) / 6 over the tangent's chord [s_lo, s_hi] inside the pixel.
fn smooth_coverage(g0: f32, grad: vec2<f32>, gtt: f32) -> f32 {
    let gn = len2(grad);
    let n = grad / max(gn, 1e-30);
    let dist = g0 / max(gn, 1e-30);
    let a_lin = halfplane_area(-n, dist);
    let p0 = -dist * n;
    let t = vec2<f32>(-n.y, n.x);
    // Chord of the line p0 + s t inside [-0.5, 0.5]^2 (slab clipping).
    let tx = select(t.x, 1e-20, abs(t.x) < 1e-20);
    let ty = select(t.y, 1e-20, abs(t.y) < 1e-20);
    let sx0 = (-0.5 - p0.x) / tx; let sx1 = (0.5 - p0.x) / tx;
    let sy0 = (-0.5 - p0.y) / ty; let sy1 = (0.5 - p0.y) / ty;
    let s_lo = max(min(sx0, sx1), min(sy0, sy1));
    let s_hi = min(max(sx0, sx1), max(sy0, sy1));
    let kappa = gtt / max(gn, 1e-30);
    let sag = select(0.0, kappa * (s_hi * s_hi * s_hi - s_lo * s_lo * s_lo) / 6.0, s_hi > s_lo);
    return clamp(a_lin - sag, 0.0, 1.0);
}

// Boundary functions of dot b along the ray d (negative = dark side): which 0, the bead's
// silhouette; otherwise the distance of the sphere hit point from the dot centre minus its radius
// (painted cap).
fn dot_boundary(which: u32, d: vec3<f32>, b: vec4<f32>) -> f32 {
    let n = d / len3(d);
    let ts = hit_sphere(n, P.sphere.xyz, P.sphere.w);
    let sil = len3(b.xyz - n * dot3(n, b.xyz)) - b.w;
    let cap = len3(n * ts - b.xyz) - b.w;
    return select(cap, sil, which == 0u);
}

// Cut function of bead b along the ray d: bead entry minus sphere entry, continued outside the
// silhouette with the ray's closest approach to the bead's centre so that it stays continuous
// (negative where the bead is in front).
fn bead_cut(d: vec3<f32>, b: vec4<f32>) -> f32 {
    let n = d / len3(d);
    let ts = hit_sphere(n, P.sphere.xyz, P.sphere.w);
    let along = dot3(n, b.xyz);
    let perp = b.xyz - n * along;
    let tb = along - sqrt(max(b.w * b.w - dot3(perp, perp), 0.0));
    return select(tb - ts, -1.0, ts <= 0.0);
}

// dot_boundary `which` of dot b linearised over the pixel: (value at the centre, central
// differences per pixel along x and y).
fn boundary_linear(which: u32, ray: Ray, b: vec4<f32>) -> vec3<f32> {
    let g0 = dot_boundary(which, ray_d(ray), b);
    let gx = dot_boundary(which, ray_plus(ray, 0.5 * ray_col(ray, 0u)), b) - dot_boundary(which, ray_plus(ray, -0.5 * ray_col(ray, 0u)), b);
    let gy = dot_boundary(which, ray_plus(ray, 0.5 * ray_col(ray, 1u)), b) - dot_boundary(which, ray_plus(ray, -0.5 * ray_col(ray, 1u)), b);
    return vec3<f32>(g0, gx, gy);
}

// Is the painted cap's rim function (dot_boundary 2, linearised as `lin`) linear over the pixel?
// Its values at the four corners must match the linearisation within 0.1 px. Near the sphere's
// outline the sphere hit point, and so the cap function, bends sharply: there a sliver cap's two
// sides can fall in one pixel, which the single-boundary closed form cannot represent.
fn cap_rim_linear(ray: Ray, b: vec4<f32>, lin: vec3<f32>) -> bool {
    let tol = 0.1 * len2(lin.yz);
    var ok = true;
    for (var k = 0u; k < 4u; k = k + 1u) {
        let o = vec2<f32>(select(-0.5, 0.5, (k & 1u) == 1u), select(-0.5, 0.5, k >= 2u));
        let g = dot_boundary(2u, ray_at(ray, o), b);
        ok = ok && abs(g - (lin.x + lin.y * o.x + lin.z * o.y)) <= tol;
    }
    return ok;
}

// Coverage of the pixel by {dot_boundary < 0}: value and gradient from `lin`
// (boundary_linear), second derivative along the tangent from two more samples.
fn dot_coverage(which: u32, ray: Ray, b: vec4<f32>, lin: vec3<f32>) -> f32 {
    let g0 = lin.x;
    let gx = lin.y;
    let gy = lin.z;
    let grad = vec2<f32>(gx, gy);
    let t = vec2<f32>(-gy, gx) / max(len2(grad), 1e-30);
    let dt = ray_step(ray, t);
    let gtt = (dot_boundary(which, ray_plus(ray, 0.5 * dt), b) + dot_boundary(which, ray_plus(ray, -0.5 * dt), b) - 2.0 * g0) * 4.0;
    return smooth_coverage(g0, grad, gtt);
}

// S-path, coarse pass over tiles without dots: flat pixels, and the sphere's outline (radius
// hundreds of pixels) by the closed-form coverage of its linearised distance function.
fn spath_coarse_limb(ray: Ray) -> Coarse {
    var out: Coarse;
    let d = ray_d(ray);
    let ts = hit_sphere(d, P.sphere.xyz, P.sphere.w);
    let g0 = limb_distance(ray_d(ray));
    let gx = limb_distance(ray_plus(ray, 0.5 * ray_col(ray, 0u))) - limb_distance(ray_plus(ray, -0.5 * ray_col(ray, 0u)));
    let gy = limb_distance(ray_plus(ray, 0.5 * ray_col(ray, 1u))) - limb_distance(ray_plus(ray, -0.5 * ray_col(ray, 1u)));
    let inside = smooth_coverage(g0, vec2<f32>(gx, gy), 0.0);
    out.value = select(P.grey.w, P.grey.y * inside + P.grey.w * (1.0 - inside), ray.ok && ts > 0.0 || abs(g0) < 1.0);
    out.value = select(P.grey.w, out.value, ray.ok);
    out.hard = false;
    return out;
}

fn cross3(a: vec3<f32>, b: vec3<f32>) -> vec3<f32> {
    return vec3<f32>(a.y * b.z - a.z * b.y, a.z * b.x - a.x * b.z, a.x * b.y - a.y * b.x);
}

// The pixel's rays as d(o) = d0 + o.x c0 + o.y c1 (camera frame, distortion linearised).
struct PixelRays { d0: vec3<f32>, c0: vec3<f32>, c1: vec3<f32>, };

fn pixel_rays(ray: Ray) -> PixelRays {
    var r: PixelRays;
    r.d0 = ray_d(ray);
    r.c0 = ray_col(ray, 0u);
    r.c1 = ray_col(ray, 1u);
    return r;
}

// Area of the pixel square inside the silhouette of the ball (c, r): in a frame whose third axis
// points at the centre, the silhouette cone is x^2 + y^2 <= s^2 z^2 with s^2 = r^2 / (|c|^2 - r^2),
// formed from the rays' small components (no difference of two squared distances near |c|^2).
fn ball_silhouette_area(ray: Ray, c: vec3<f32>, r: f32) -> f32 {
    let l = len3(c);
    let u = c / l;
    let helper = select(vec3<f32>(1.0, 0.0, 0.0), vec3<f32>(0.0, 1.0, 0.0), abs(u.x) > 0.9);
    let e1r = cross3(helper, u);
    let e1 = e1r / len3(e1r);
    let e2 = cross3(u, e1);
    let pr = pixel_rays(ray);
    let p0 = vec3<f32>(dot3(e1, pr.d0), dot3(e2, pr.d0), dot3(u, pr.d0));
    let p1 = vec3<f32>(dot3(e1, pr.c0), dot3(e2, pr.c0), dot3(u, pr.c0));
    let p2 = vec3<f32>(dot3(e1, pr.c1), dot3(e2, pr.c1), dot3(u, pr.c1));
    let s2 = r * r / ((l - r) * (l + r));
    let q = vec3<f32>(p1.x * p1.x + p1.y * p1.y - s2 * p1.z * p1.z, p1.x * p2.x + p1.y * p2.y - s2 * p1.z * p2.z, p2.x * p2.x + p2.y * p2.y - s2 * p2.z * p2.z);
    let b = vec2<f32>(p1.x * p0.x + p1.y * p0.y - s2 * p1.z * p0.z, p2.x * p0.x + p2.y * p0.y - s2 * p2.z * p0.z);
    let rho = len2(p0.xy);
    let t = sqrt(s2) * p0.z;
    return ellipse_area(q, b, (rho - t) * (rho + t));
}

// Area of the pixel square inside the image of painted cap b (the sphere's points within b.w of
// the dot centre b.xyz, which lies on the sphere): its rim is the circle of centre m, radius rho
// in the plane p.nu = h, and the rays through it satisfy |h d - (d.nu) m| <= rho |d.nu|. Negative
// when the cap is not wholly on the side of the sphere the camera sees (its image is then not
// that ellipse) or the conic is no ellipse.
fn cap_area(ray: Ray, b: vec4<f32>) -> f32 {
    let cs = P.sphere.xyz;
    let rs = P.sphere.w;
    let r = b.w;
    let nr = b.xyz - cs;
    let nu = nr / len3(nr);
    let m = cs + nu * (rs - r * r / (2.0 * rs));
    let rho = r * sqrt(max(1.0 - r * r / (4.0 * rs * rs), 0.0));
    let h = dot3(m, nu);
    let view = dot3(nu, b.xyz) / len3(b.xyz);
    let front = view < -(2.0 * r / rs + 2.0 * r / len3(b.xyz));
    let pr = pixel_rays(ray);
    let w0 = dot3(pr.d0, nu);
    let g = vec2<f32>(dot3(pr.c0, nu), dot3(pr.c1, nu));
    let v0 = pr.d0 * h - m * w0;
    let v1 = pr.c0 * h - m * g.x;
    let v2 = pr.c1 * h - m * g.y;
    let r2 = rho * rho;
    let q = vec3<f32>(dot3(v1, v1) - r2 * g.x * g.x, dot3(v1, v2) - r2 * g.x * g.y, dot3(v2, v2) - r2 * g.y * g.y);
    let bb = vec2<f32>(dot3(v1, v0) - r2 * w0 * g.x, dot3(v2, v0) - r2 * w0 * g.y);
    let lv = len3(v0);
    let t = rho * abs(w0);
    let area = ellipse_area(q, bb, (lv - t) * (lv + t));
    // The pixel centre's side of the rim must be what the centre ray sees (inside: the dot).
    let consistent = (lv <= t) == dot_covers(pr.d0, b);
    return select(-1.0, area, front && consistent);
}

// Does the ray d see dot b (a bead in front of the sphere, or a painted cap)?
fn dot_covers(d: vec3<f32>, b: vec4<f32>) -> bool {
    let ts = hit_sphere(d, P.sphere.xyz, P.sphere.w);
    let tb = hit_sphere(d, b.xyz, b.w);
    let dh = d / len3(d) * ts - b.xyz;
    let in_cap = ts > 0.0 && dot3(dh, dh) < b.w * b.w;
    let bead = tb > 0.0 && (ts <= 0.0 || tb <= ts);
    return select(bead, in_cap, P.tiles.z == 1u);
}

// Distance (px) beyond which a linearised boundary cannot cross the pixel: the half-diagonal 0.707
// plus room for the boundary's curvature.
const MARGIN_PX: f32 = 0.9;

// S-path, coarse pass over tiles with dots. Pixels whose colour is explained by one smooth boundary
// (a bead's silhouette, the curve where a bead enters the sphere, or a cap's rim), checked at the
// centre and the four corners, get its closed-form coverage; pixels near the sphere's outline or
// near two boundaries are hard.
fn spath_coarse(ray: Ray, tile: u32) -> Coarse {
    var out: Coarse;
    let d = ray_d(ray);
    let alpha = pixel_cone(ray);
    let t_begin = tile_start[tile];
    let t_end = tile_start[tile + 1u];
    let limb = cone_near_ball(d, alpha, P.sphere.xyz, P.sphere.w, false);
    var n_touch = 0u;
    var b = vec4<f32>(0.0);
    for (var k = t_begin; k < t_end; k = k + 1u) {
        let bk = dots[tile_items[k]];
        let touch = cone_near_ball(d, alpha, bk.xyz, bk.w, true);
        n_touch = n_touch + select(0u, 1u, touch);
        b = select(b, bk, touch);
    }
    let centre = spath_sample(d, t_begin, t_end);
    // One bead: which of its two boundaries crosses the pixel? Both functions at the centre and
    // the corners give values and gradients (per pixel); a boundary whose linearised distance from
    // the centre exceeds MARGIN_PX does not cross the pixel.
    let v0 = bead_cut(ray_d(ray), b);
    let v00 = bead_cut(ray_at(ray, vec2<f32>(-0.5, -0.5)), b);
    let v10 = bead_cut(ray_at(ray, vec2<f32>(0.5, -0.5)), b);
    let v01 = bead_cut(ray_at(ray, vec2<f32>(-0.5, 0.5)), b);
    let v11 = bead_cut(ray_at(ray, vec2<f32>(0.5, 0.5)), b);
    let gxv = 0.5 * ((v10 + v11) - (v00 + v01));
    let gyv = 0.5 * ((v01 + v11) - (v00 + v10));
    let dist_cut = v0 / max(len2(vec2<f32>(gxv, gyv)), 1e-30);
    let disc = P.tiles.z == 1u;
    // The bead is in front wherever it is hit: its silhouette is the only boundary. Pixels the
    // curve where a bead enters the sphere may cross (the linearised tests misjudge it on 1-2 px
    // beads: up to 6.8 grey levels off) take the fine pass's scan lines.
    let sil_only = !disc && dist_cut < -MARGIN_PX;
    let which = select(0u, 2u, disc);
    let ts = hit_sphere(d, P.sphere.xyz, P.sphere.w);
    // A cap off the outline's neighbourhood: the whole pixel misses the sphere (background), or
    // the cap's rim is close enough to a straight line over the pixel for the closed form.
    let off_sphere = disc && ts <= 0.0;
    let lin = boundary_linear(which, ray, b);
    // Exact: a bead's silhouette and a wholly visible cap's rim are ellipses in pixel offsets.
    // (The curve where a bead enters the sphere is the same circle as a cap's rim, but which
    // side of it shows the bead depends on the view.)
    let conic = select(select(-1.0, cap_area(ray, b), disc), ball_silhouette_area(ray, b.xyz, b.w), sil_only);
    let exact = conic >= 0.0;
    let single = n_touch == 1u && !limb && (sil_only || off_sphere || (disc && (exact || cap_rim_linear(ray, b, lin))));
    let cov = select(select(dot_coverage(which, ray, b, lin), conic, exact), 0.0, off_sphere);
    // The other side of the boundary: the sphere (or the background) as the centre ray sees it.
    let other = select(P.grey.w, P.grey.y, ts > 0.0);
    let analytic = P.grey.x * cov + other * (1.0 - cov);
    // The sphere's outline with no dot near: as in the tiles without dots.
    let limb_only = limb && n_touch == 0u;
    let limb_value = spath_coarse_limb(ray).value;
    out.value = select(select(centre, analytic, single), limb_value, limb_only);
    out.hard = ray.ok && (n_touch > 0u || limb) && !single && !limb_only;
    out.value = select(P.grey.w, out.value, ray.ok);
    return out;
}

// What the fine pass integrates at pixel offset o (the pixel's gathered dots): beads, the grey
// seen (a bead hides the sphere's outline behind it); painted caps, what the caps change from the
// bare sphere or background (the outline is added in closed form: no band between a cap's rim
// and the outline for the scan lines to resolve).
fn spath_at(ray: Ray, o: vec2<f32>) -> f32 {
    let d = ray_at(ray, o);
    let ts = hit_sphere(d, P.sphere.xyz, P.sphere.w);
    let seen = spath_sample_near(d, ts);
    let bare = select(P.grey.w, P.grey.y, ts > 0.0);
    return select(seen, seen - bare, P.tiles.z == 1u);
}

// Samples per scan line of the S-path's fine pass (ends included) and bisection steps per change.
const LINE_SAMPLES: u32 = 17u;
const LINE_BISECTIONS: u32 = 10u;
// Adaptive integration across the scan lines: an interval whose Simpson estimate changes by more
// than LINE_TOLERANCE (grey levels x pixel area) when halved is halved, at most LINE_DEPTH times.
const LINE_TOLERANCE: f32 = 0.02;
const LINE_DEPTH: u32 = 6u;
// At most this many scan lines per pixel: with 17 + 4 x 8 + 2 x 10 samples and 10 bisection
// steps per change, a few hundred loop iterations each, below llvmpipe's 65 535 (see
// gather_near; 160 lines ran past it on a bead view).
const LINE_BUDGET: u32 = 96u;

// One bisection step of a change of spath_at along line y: (a, b) holds it, g0 is the value at a.
fn bisect(ray: Ray, y: f32, ab: vec2<f32>, g0: f32) -> vec2<f32> {
    let m = 0.5 * (ab.x + ab.y);
    let same = spath_at(ray, vec2<f32>(m, y)) == g0;
    return select(vec2<f32>(ab.x, m), vec2<f32>(m, ab.y), same);
}

// Where along the scan line at offset y (x in [-0.5, 0.5]) the rays pass through the balls of
// the gathered dots (radius + 5 %, which holds a bead and a cap): per slot (start, end), start > end
// when the line misses it. The ray d(x) = p + x c is in ball (b, r) where (b.d)^2 > (|b|^2 - r^2)
// |d|^2: a quadratic in x. Only a guide for where to sample (f32 loses digits in it); the
// crossings themselves are bisected on exact rays.
fn dot_chords(ray: Ray, y: f32) -> array<vec2<f32>, 4> {
    var out = array<vec2<f32>, 4>(vec2<f32>(1.0, -1.0), vec2<f32>(1.0, -1.0), vec2<f32>(1.0, -1.0), vec2<f32>(1.0, -1.0));
    for (var s = 0u; s < min(near_count, NEAR_SLOTS); s = s + 1u) {
        let b = near_dots[s];
        out[s] = clamp(ball_chord(ray, y, b.xyz, 1.05 * b.w), vec2<f32>(-0.5), vec2<f32>(0.5));
    }
    return out;
}

// The chord (start, end; start > end: none) of line y whose rays pass through the ball (b, r)
// (see dot_chords), not clipped to the pixel.
fn ball_chord(ray: Ray, y: f32, b: vec3<f32>, r: f32) -> vec2<f32> {
    let p = ray_plus(ray, ray_col(ray, 1u) * y);
    let c = ray_col(ray, 0u);
    let k = dot3(b, b) - r * r;
    let b0 = dot3(b, p);
    let b1 = dot3(b, c);
    let qa = b1 * b1 - k * dot3(c, c);
    let qb = 2.0 * (b0 * b1 - k * dot3(p, c));
    let qc = b0 * b0 - k * dot3(p, p);
    let disc = qb * qb - 4.0 * qa * qc;
    let sq = sqrt(max(disc, 0.0));
    let u0 = (-qb + sq) / (2.0 * qa);
    let u1 = (-qb - sq) / (2.0 * qa);
    let out = select(vec2<f32>(min(u0, u1), max(u0, u1)), vec2<f32>(-1e6, 1e6), qa >= 0.0);
    return select(out, vec2<f32>(1.0, -1.0), qa < 0.0 && disc <= 0.0);
}

// Samples per dot chord on a scan line (interior points, evenly spread), and per crossing of
// the sphere's outline (geometric).
const CHORD_SAMPLES: u32 = 8u;
const LIMB_SAMPLES: u32 = 10u;

// spath_at along the scan line at offset y, integrated over x in [-0.5, 0.5]: sampled at
// LINE_SAMPLES points plus CHORD_SAMPLES within each gathered dot's chord (dot_chords: a cap
// seen edge-on, or a bead's sliver behind the sphere's outline, can be narrower than the
// 1/16 px spacing: up to 1.8 grey levels missed, measured), merged in order; every change between
// two consecutive samples is located by bisection, so the integral is exact up to features
// narrower than the spacing.
fn spath_line(ray: Ray, y: f32) -> f32 {
    let step = 1.0 / f32(LINE_SAMPLES - 1u);
    let ch = dot_chords(ray, y);
    let lo = vec4<f32>(ch[0].x, ch[1].x, ch[2].x, ch[3].x);
    let len = vec4<f32>(ch[0].y, ch[1].y, ch[2].y, ch[3].y) - lo;
    var idx = select(vec4<u32>(0u), vec4<u32>(CHORD_SAMPLES), len <= vec4<f32>(0.0));
    // Painted caps: from where the line crosses the sphere's outline (within the pixel or not),
    // samples 2^-9 .. 1 px inside it (those in the pixel), where a cap's image is compressed most
    // (a bead hides the outline behind it).
    let limb = ball_chord(ray, y, P.sphere.xyz, P.sphere.w);
    let caps = P.tiles.z == 1u;
    let crosses = limb.x < limb.y;
    var il = select(vec2<u32>(LIMB_SAMPLES), vec2<u32>(0u), vec2<bool>(caps && crosses && limb.x < 0.5, caps && crosses && limb.y > -0.5));
    var iu = 0u;
    var acc = 0.0;
    var x0 = -0.5;
    var g0 = 0.0;
    var first = true;
    loop {
        // The next sample: the least of the uniform stream's and the four chords' heads.
        let cand = select(lo + len * (vec4<f32>(idx) + 0.5) / f32(CHORD_SAMPLES), vec4<f32>(2.0), idx >= vec4<u32>(CHORD_SAMPLES));
        let m = min(min(cand.x, cand.y), min(cand.z, cand.w));
        let xu = select(-0.5 + f32(iu) * step, 2.0, iu >= LINE_SAMPLES);
        let lc = clamp(vec2<f32>(limb.x + exp2(-9.0 + f32(il.x)), limb.y - exp2(0.0 - f32(il.y))), vec2<f32>(-0.5), vec2<f32>(0.5));
        let lcand = select(lc, vec2<f32>(2.0), il >= vec2<u32>(LIMB_SAMPLES));
        let x1 = min(min(m, xu), min(lcand.x, lcand.y));
        if x1 > 1.0 { break; }
        iu = iu + select(0u, 1u, xu == x1);
        idx = idx + select(vec4<u32>(0u), vec4<u32>(1u), cand == vec4<f32>(x1));
        il = il + select(vec2<u32>(0u), vec2<u32>(1u), lcand == vec2<f32>(x1));
        let g1 = spath_at(ray, vec2<f32>(x1, y));
        var ab = vec2<f32>(x0, x1);
        let steps = select(0u, LINE_BISECTIONS, !first && g1 != g0);
        for (var i = 0u; i < steps; i = i + 1u) {
            ab = bisect(ray, y, ab, g0);
        }
        let c = 0.5 * (ab.x + ab.y);
        acc = acc + select(g0 * (c - x0) + g1 * (x1 - c), 0.0, first);
        first = false;
        x0 = x1;
        g0 = g1;
    }
    return acc;
}

// S-path, fine: the integral over y of the exact scan-line integrals (spath_line), by adaptive
// Simpson over samples / 2 base intervals (lines 1/samples px apart to start with), plus for
// painted caps the sphere's outline in closed form (as in the tiles without dots). The line
// integral is only piecewise smooth in y (it jumps where an edge runs along the lines and has
// square-root ends where a rim is tangent to them): a fixed set of lines is off there by up to
// half a line spacing times the contrast (2-3 grey levels at 16 lines, measured).
fn spath_fine(ray: Ray, tile: u32) -> f32 {
    gather_near(ray, tile_start[tile], tile_start[tile + 1u]);
    let n = max(P.size.w / 2u, 1u);
    let h = 1.0 / f32(n);
    var acc = 0.0;
    // Pending intervals, depth first: (y0, h, l0, lm) and (l1, depth). One flat loop takes the
    // base intervals in turn and refines each; every pass evaluates two scan lines (one call
    // site: llvmpipe compiles each inlined copy of spath_line, seconds apiece).
    var st_a: array<vec4<f32>, 8>;
    var st_b: array<vec2<f32>, 8>;
    var l0 = spath_line(ray, -0.5);
    var lines = 1u;
    var j = 0u;
    var top = 0u;
    loop {
        let base = top == 0u;
        if base && j >= n { break; }
        let y0 = -0.5 + f32(j) * h;
        let sa = select(st_a[max(top, 1u) - 1u], vec4<f32>(y0, h, l0, 0.0), base);
        let half = 0.5 * sa.y;
        // Base: the interval's far end and middle; refinement: its quarter points.
        let ya = select(sa.x + 0.5 * half, y0 + h, base);
        let yb = select(sa.x + 1.5 * half, y0 + half, base);
        var l = vec2<f32>(0.0);
        for (var q = 0u; q < 2u; q = q + 1u) {
            l[q] = spath_line(ray, select(ya, yb, q == 1u));
        }
        lines = lines + 2u;
        if base {
            st_a[0] = vec4<f32>(y0, h, l0, l.y);
            st_b[0] = vec2<f32>(l.x, 0.0);
            l0 = l.x;
            j = j + 1u;
            top = 1u;
            continue;
        }
        top = top - 1u;
        let sb = st_b[top];
        let whole = sa.y * (sa.z + 4.0 * sa.w + sb.x) / 6.0;
        let halves = half * (sa.z + 4.0 * l.x + 2.0 * sa.w + 4.0 * l.y + sb.x) / 6.0;
        if abs(halves - whole) <= LINE_TOLERANCE || sb.y >= f32(LINE_DEPTH) || lines + 2u * (n - j) >= LINE_BUDGET {
            acc = acc + halves;
        } else {
            st_a[top] = vec4<f32>(sa.x + half, half, sa.w, l.y);
            st_b[top] = vec2<f32>(sb.x, sb.y + 1.0);
            st_a[top + 1u] = vec4<f32>(sa.x, half, sa.z, l.x);
            st_b[top + 1u] = vec2<f32>(sa.w, sb.y + 1.0);
            top = top + 2u;
        }
    }
    return acc + select(0.0, spath_coarse_limb(ray).value, P.tiles.z == 1u);
}

// ---------------------------------------------------------------- entry points

// The sharp image's view: the scene's own homography, from the uniforms (llvmpipe keeps these
// values scalar). Every planar entry point without views starts here.
fn uniform_view() {
    H0 = P.h0;
    H1 = P.h1;
    H2 = P.h2;
}

// The coarse value of a planar target's pixel px of pass kind `kind` (a literal at each call) with
// views (defocus, motion; P.vw.x per pixel): their mean, hard when any view is. Separate entry
// points (`*_views`): llvmpipe runs both sides of a branch, so the sharp passes hold no loop.
fn planar_coarse_views(px: vec3<u32>, kind: u32) -> Coarse {
    let ray = pixel_ray(vec2<f32>(f32(px.x), f32(px.y)));
    if (kind != 1u) { return cells_coarse_views(ray, px.y, kind == 4u); }
    var out: Coarse;
    out.value = 0.0;
    out.hard = false;
    for (var s = 0u; s < P.vw.x; s = s + 1u) {
        set_view(px.y, s);
        let c = grid_coarse(ray);
        out.value = out.value + c.value;
        out.hard = out.hard || c.hard;
    }
    out.value = out.value / f32(P.vw.x);
    return out;
}

// The coverage of the pixel by {board coordinate `axis` >= v} in view s of row y: board_line
// without the board point. With L = H_axis - v H_2 (rows of the view's homography), the line in
// pixel offsets is (L.c0, L.c1, -L.d) / W, W = H_2.d > 0, and the half-plane area does not
// change with a positive scale, so W only decides whether the view sees the plane (else 0).
fn view_line_area(ray: Ray, y: u32, s: u32, axis: u32, v: f32) -> f32 {
    let k = view_index(y, s);
    let h2 = views[k + 2u];
    let l = views[k + axis].xyz - v * h2.xyz;
    let d = ray_d(ray);
    let w = h_dot(h2.xyz, d);
    let ld = h_dot(l, d);
    let n = vec2<f32>(dot_step(l, ray_col(ray, 0u)), dot_step(l, ray_col(ray, 1u)));
    return select(0.0, halfplane_area(n, -ld), w > 0.0);
}

// Boards of cells with views. Every view's footprint lies within the first view's, grown by the
// views' spread (P.vw.z, pixels; src/scene/views.rs) through the board Jacobian, plus 10 %. No
// line in that region: every view sees one cell. One line: the mean over the views of each
// view's exact half-plane coverage of it (the two cells beside it are the same for every view).
// Otherwise each view's own coarse value (cells_coarse), hard when any view's is. The loops run
// only for the lanes that need them (llvmpipe leaves a loop when no lane is active).
fn cells_coarse_views(ray: Ray, y: u32, coded: bool) -> Coarse {
    set_view(y, 0u);
    let pc = plane_point(ray_d(ray));
    let a = board_jacobian(pc, ray);
    let spread = bitcast<f32>(P.vw.z);
    let per_px = vec2<f32>(abs(a[0].x) + abs(a[1].x), abs(a[0].y) + abs(a[1].y));
    let own = footprint_extent(a);
    let ext = 1.1 * (own + spread * per_px);
    let lx = board_lines(pc.x - ext.x, pc.x + ext.x, 0u, coded);
    let ly = board_lines(pc.y - ext.y, pc.y + ext.y, 1u, coded);
    let nlines = lx.count + ly.count;
    let small = 1.1 * max(own.x, own.y) < 0.25 * min_cell(coded);
    let simple = ray.ok && pc.z > 0.0 && spread < 1e29 && small && ray.parts == 1u && nlines <= 1u;
    let hasx = lx.count == 1u;
    let l0 = select(ly.first, lx.first, hasx);
    let axis = select(1u, 0u, hasx);
    let cen = select(pc.y, pc.x, hasx);
    let e = select(ext.y, ext.x, hasx);
    let plus = 0.5 * (l0 + cen + e);
    let minus = 0.5 * (l0 + cen - e);
    let vp = select(cell_value(pc.x, plus, coded), cell_value(plus, pc.y, coded), hasx);
    let vm = select(cell_value(pc.x, minus, coded), cell_value(minus, pc.y, coded), hasx);
    var out: Coarse;
    out.hard = false;
    let n_line = select(0u, P.vw.x, simple && nlines == 1u);
    var area = 0.0;
    for (var s = 0u; s < n_line; s = s + 1u) {
        area = area + view_line_area(ray, y, s, axis, l0);
    }
    area = area / f32(max(n_line, 1u));
    let n_full = select(P.vw.x, 0u, simple);
    var full = 0.0;
    for (var s = 0u; s < n_full; s = s + 1u) {
        set_view(y, s);
        let c = cells_coarse(ray, coded);
        full = full + c.value;
        out.hard = out.hard || c.hard;
    }
    full = full / f32(max(n_full, 1u));
    let v = select(cell_value(pc.x, pc.y, coded), vp * area + vm * (1.0 - area), nlines == 1u);
    out.value = select(full, v, simple);
    return out;
}

// Pixel and tile index of a coarse-pass invocation: tile work[workgroup] = tx | (ty << 16), 8 x 8 pixels.
fn coarse_pixel(wg: vec3<u32>, lid: vec3<u32>) -> vec3<u32> {
    let packed = work[wg.y * 65535u + wg.x];
    let tx = packed & 0xffffu;
    let ty = packed >> 16u;
    return vec3<u32>(tx * 8u + lid.x, ty * 8u + lid.y, ty * P.tiles.x + tx);
}

fn write_coarse(wg: vec3<u32>, lid: vec3<u32>, c: Coarse) {
    let slot = (wg.y * 65535u + wg.x) * 64u + lid.y * 8u + lid.x;
    out_vals[slot] = c.value;
    out_hard[slot] = select(0u, 1u, c.hard);
}

@compute @workgroup_size(8, 8, 1)
fn cs_coarse_chessboard(@builtin(workgroup_id) wg: vec3<u32>, @builtin(local_invocation_id) lid: vec3<u32>) {
    let px = coarse_pixel(wg, lid);
    uniform_view();
    write_coarse(wg, lid, cells_coarse(pixel_ray(vec2<f32>(f32(px.x), f32(px.y))), false));
}

@compute @workgroup_size(8, 8, 1)
fn cs_coarse_dot_grid(@builtin(workgroup_id) wg: vec3<u32>, @builtin(local_invocation_id) lid: vec3<u32>) {
    let px = coarse_pixel(wg, lid);
    uniform_view();
    write_coarse(wg, lid, grid_coarse(pixel_ray(vec2<f32>(f32(px.x), f32(px.y)))));
}

@compute @workgroup_size(8, 8, 1)
fn cs_coarse_spath(@builtin(workgroup_id) wg: vec3<u32>, @builtin(local_invocation_id) lid: vec3<u32>) {
    let px = coarse_pixel(wg, lid);
    write_coarse(wg, lid, spath_coarse(pixel_ray(vec2<f32>(f32(px.x), f32(px.y))), px.z));
}

@compute @workgroup_size(8, 8, 1)
fn cs_coarse_spath_limb(@builtin(workgroup_id) wg: vec3<u32>, @builtin(local_invocation_id) lid: vec3<u32>) {
    let px = coarse_pixel(wg, lid);
    write_coarse(wg, lid, spath_coarse_limb(pixel_ray(vec2<f32>(f32(px.x), f32(px.y)))));
}

// Fine passes: one invocation per hard pixel (the tail of the last workgroup repeats the last
// pixel, so every lane does the same work and no lane is idle).
fn fine_item(gid: vec3<u32>) -> vec3<u32> {
    let i = min(gid.y * 65535u * 64u + gid.x, P.tiles.w - 1u);
    let packed = work[i];
    let x = packed & 0xffffu;
    let y = packed >> 16u;
    return vec3<u32>(x, y, (y >> 3u) * P.tiles.x + (x >> 3u));
}

// The fine value of a planar target's pixel at q: cells_fine (chessboard, coded board) or grid_fine (`kind` is a
// literal at each call, so the compiler keeps one). A fisheye far off its axis bends the rays across the pixel
// (src/render/bend.rs): the mean of its sub-pixels, each with its own ray (a sub-pixel beyond the
// lens's reach or the plane's horizon: background).
fn planar_fine(q: vec2<f32>, kind: u32) -> f32 {
    uniform_view();
    return planar_fine_view(q, kind);
}

// planar_fine with views: their mean.
fn planar_fine_views(q: vec2<f32>, kind: u32) -> f32 {
    var acc = 0.0;
    for (var s = 0u; s < P.vw.x; s = s + 1u) {
        set_view(u32(q.y), s);
        acc = acc + planar_fine_view(q, kind);
    }
    return acc / f32(P.vw.x);
}

// planar_fine for the current view.
fn planar_fine_view(q: vec2<f32>, kind: u32) -> f32 {
    if (!wide()) {
        return planar_fine_ray(pixel_ray(q), kind);
    }
    let parts = pixel_ray(q).parts;
    var acc = 0.0;
    for (var k = 0u; k < parts * parts; k = k + 1u) {
        let r = sub_ray(q, parts, k);
        acc = acc + select(P.grey.w, planar_fine_ray(r, kind), r.ok && plane_point(ray_d(r)).z > 0.0);
    }
    return acc / f32(parts * parts);
}

// The fine value of pass kind `kind` (a literal at each call) along `r`.
fn planar_fine_ray(r: Ray, kind: u32) -> f32 {
    if (kind == 4u) { return cells_fine(r, true); }
    if (kind == 0u) { return cells_fine(r, false); }
    return grid_fine(r);
}

@compute @workgroup_size(64, 1, 1)
fn cs_fine_chessboard(@builtin(global_invocation_id) gid: vec3<u32>) {
    let it = fine_item(gid);
    out_vals[gid.y * 65535u * 64u + gid.x] = planar_fine(vec2<f32>(f32(it.x), f32(it.y)), 0u);
}

@compute @workgroup_size(64, 1, 1)
fn cs_fine_dot_grid(@builtin(global_invocation_id) gid: vec3<u32>) {
    let it = fine_item(gid);
    out_vals[gid.y * 65535u * 64u + gid.x] = planar_fine(vec2<f32>(f32(it.x), f32(it.y)), 1u);
}

@compute @workgroup_size(64, 1, 1)
fn cs_fine_spath(@builtin(global_invocation_id) gid: vec3<u32>) {
    let it = fine_item(gid);
    out_vals[gid.y * 65535u * 64u + gid.x] = spath_fine(pixel_ray(vec2<f32>(f32(it.x), f32(it.y))), it.z);
}

@compute @workgroup_size(8, 8, 1)
fn cs_coarse_coded(@builtin(workgroup_id) wg: vec3<u32>, @builtin(local_invocation_id) lid: vec3<u32>) {
    let px = coarse_pixel(wg, lid);
    uniform_view();
    write_coarse(wg, lid, cells_coarse(pixel_ray(vec2<f32>(f32(px.x), f32(px.y))), true));
}

@compute @workgroup_size(64, 1, 1)
fn cs_fine_coded(@builtin(global_invocation_id) gid: vec3<u32>) {
    let it = fine_item(gid);
    out_vals[gid.y * 65535u * 64u + gid.x] = planar_fine(vec2<f32>(f32(it.x), f32(it.y)), 4u);
}

// With views (defocus, motion): pass kinds 5, 6, 7 (chessboard, dot grid, coded boards).
@compute @workgroup_size(8, 8, 1)
fn cs_coarse_chessboard_views(@builtin(workgroup_id) wg: vec3<u32>, @builtin(local_invocation_id) lid: vec3<u32>) {
    write_coarse(wg, lid, planar_coarse_views(coarse_pixel(wg, lid), 0u));
}

@compute @workgroup_size(64, 1, 1)
fn cs_fine_chessboard_views(@builtin(global_invocation_id) gid: vec3<u32>) {
    let it = fine_item(gid);
    out_vals[gid.y * 65535u * 64u + gid.x] = planar_fine_views(vec2<f32>(f32(it.x), f32(it.y)), 0u);
}

@compute @workgroup_size(8, 8, 1)
fn cs_coarse_dot_grid_views(@builtin(workgroup_id) wg: vec3<u32>, @builtin(local_invocation_id) lid: vec3<u32>) {
    write_coarse(wg, lid, planar_coarse_views(coarse_pixel(wg, lid), 1u));
}

@compute @workgroup_size(64, 1, 1)
fn cs_fine_dot_grid_views(@builtin(global_invocation_id) gid: vec3<u32>) {
    let it = fine_item(gid);
    out_vals[gid.y * 65535u * 64u + gid.x] = planar_fine_views(vec2<f32>(f32(it.x), f32(it.y)), 1u);
}

@compute @workgroup_size(8, 8, 1)
fn cs_coarse_coded_views(@builtin(workgroup_id) wg: vec3<u32>, @builtin(local_invocation_id) lid: vec3<u32>) {
    write_coarse(wg, lid, planar_coarse_views(coarse_pixel(wg, lid), 4u));
}

@compute @workgroup_size(64, 1, 1)
fn cs_fine_coded_views(@builtin(global_invocation_id) gid: vec3<u32>) {
    let it = fine_item(gid);
    out_vals[gid.y * 65535u * 64u + gid.x] = planar_fine_views(vec2<f32>(f32(it.x), f32(it.y)), 4u);
}
