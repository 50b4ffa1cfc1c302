// ---------------------------------------------------------------- coded boards (cell lattice)
// Every edge of a coded board (ChArUco: squares, marker borders and bits) lies on one lattice,
// the same along x and y (crates/core/src/target/lattice.rs CellLattice): periods of P.lat.x from P.lat.y,
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
    let g = shaded_greys(x, y);
    if (x >= o && x < P.lat2.x && y >= o && y < P.lat2.y) {
        let gx = clamp(lat_index(x), 0, i32(P.board.x) - 1);
        let gy = clamp(lat_index(y), 0, i32(P.board.y) - 1);
        return select(g.y, g.x, coded_dark(gx, gy));
    }
    if (x >= o - m && x < P.lat2.x + m && y >= o - m && y < P.lat2.y + m) { return g.z; }
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

