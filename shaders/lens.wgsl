// ---------------------------------------------------------------- lens model
// Pipeline constants: the lens model and whether the OpenCV sensor is tilted. llvmpipe runs every
// side of a branch under a lane mask, so a uniform `if` on the model would run all three models'
// code per call; as constants, the compiler removes the other models (one pipeline per model).
override LENS_MODEL: u32 = 0u;
override LENS_TILT: bool = false;

// Three models (LENS_MODEL; crates/render/src/gpu_scene.rs LENS_VARIANTS): 0 OpenCV (camera::Distortion:
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

