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

// Area of the pixel square inside the image of painted cap b when the centre ray sees the dot
// exactly where it passes inside the rim (`rim`: rim_conic of the pixel); negative otherwise.
fn cap_area(ray: Ray, b: vec4<f32>, rim: vec2<f32>) -> f32 {
    let consistent = (rim.y == 1.0) == dot_covers(ray_d(ray), b);
    return select(-1.0, rim.x, rim.x >= 0.0 && consistent);
}

// The image of painted cap b's rim (the sphere's points b.w from the dot centre b.xyz, which lies
// on the sphere) over the pixel: the rim is the circle of centre m, radius rho in the plane
// p.nu = h, and the rays through it satisfy |h d - (d.nu) m| <= rho |d.nu|. x: the area of the
// pixel square inside it, negative when the cap is not wholly on the side of the sphere the
// camera sees (its image is then not that ellipse) or the conic is no ellipse; y: 1 when the
// centre ray passes inside it.
fn rim_conic(ray: Ray, b: vec4<f32>) -> vec2<f32> {
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
    return vec2<f32>(select(-1.0, area, front), select(0.0, 1.0, lv <= t));
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

// Inside a bead's silhouette the bead and the sphere meet along the circle where the two spheres
// meet: a painted cap's rim (cap_area's ellipse in pixel offsets), whose arc on the bead's far
// side the bead itself hides. Its visible arc is the only boundary of a pixel the silhouette does
// not cross, with the bead inside the ellipse, when at the four corners the bead shows exactly
// where the rays pass inside the rim (the sphere's hit point lies in the cap): the ellipse's
// interior is convex, so a boundary that left every corner on the side the ray sees there cannot
// cross the pixel (cap_area checks the centre). Where the hidden arc crosses the pixel some
// corner outside it sees the bead: the fine pass takes the pixel.
fn bead_rim_agrees(ray: Ray, b: vec4<f32>) -> bool {
    var ok = true;
    for (var k = 0u; k < 4u; k = k + 1u) {
        let d = ray_at(ray, vec2<f32>(select(-0.5, 0.5, (k & 1u) == 1u), select(-0.5, 0.5, k >= 2u)));
        ok = ok && ((dot_boundary(2u, d, b) < 0.0) == dot_covers(d, b));
    }
    return ok;
}

// A bead's pixel that the image of its rim (`rim`: rim_conic of the pixel) does not reach: inside
// the silhouette the bead either shows everywhere or nowhere (the rim's visible arc is the only
// boundary between the bead and the sphere there), so the pixel is the silhouette's closed form or
// none of it. 1 when a sample point (the centre, then the corners) sees the bead, 0 when it does
// not; -1 when the rim reaches the pixel (more than 1e-5 of it: 0.003 grey levels) or no sample
// point answers surely.
// A sure answer: the point lies a twentieth of a pixel or more inside the silhouette (`sil`: its
// linearised distance; a ray that grazes the bead gives its entry to f32's few digits) and its
// bead and sphere entries differ by more than 1e-5 of the bead's distance (near the rim they
// meet, and f32 cannot order them: a sure-looking sample saw a hidden bead, 80 grey levels off).
fn bead_beside_rim(ray: Ray, b: vec4<f32>, sil: vec3<f32>, rim: vec2<f32>) -> f32 {
    let inside = -0.05 * len2(sil.yz);
    let apart = 1e-5 * len3(b.xyz);
    var seen = -1.0;
    for (var k = 0u; k < 5u; k = k + 1u) {
        let o = select(vec2<f32>(select(-0.5, 0.5, (k & 1u) == 1u), select(-0.5, 0.5, k >= 3u)), vec2<f32>(0.0), k == 0u);
        let d = ray_at(ray, o);
        let cut = bead_cut(d, b);
        let first = seen < 0.0 && dot_boundary(0u, d, b) < inside && abs(cut) > apart;
        seen = select(seen, select(0.0, 1.0, cut < 0.0), first);
    }
    return select(-1.0, seen, rim.x >= 0.0 && rim.x <= 1e-5);
}

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
    // A bead's pixel wholly inside its silhouette (lin: the silhouette's linearised distance) that
    // the curve where it enters the sphere crosses: see bead_rim_agrees.
    let rim = !disc && !sil_only && lin.x < -MARGIN_PX * len2(lin.yz) && bead_rim_agrees(ray, b);
    // Exact: a bead's silhouette, a wholly visible cap's rim and the part of that rim a bead shows
    // are ellipses in pixel offsets.
    // Beside the rim: the silhouette's closed form where the bead shows, none of it where not.
    let rim_image = rim_conic(ray, b);
    let beside = select(-1.0, bead_beside_rim(ray, b, lin, rim_image), !disc && !sil_only);
    let sil = ball_silhouette_area(ray, b.xyz, b.w);
    let conic = select(select(select(-1.0, sil * beside, beside >= 0.0), cap_area(ray, b, rim_image), disc || rim), sil, sil_only);
    let exact = conic >= 0.0;
    let single = n_touch == 1u && !limb && (sil_only || off_sphere || (disc && (exact || cap_rim_linear(ray, b, lin))) || ((rim || beside >= 0.0) && exact));
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

