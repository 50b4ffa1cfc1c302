// ---------------------------------------------------------------- exact pixel coverage
// Areas of the pixel square S = [-0.5, 0.5]^2 (pixel offsets d) inside regions of the target
// plane, with no arrays (llvmpipe lowers indexed local arrays into long code, and LLVM then
// takes seconds to compile it). A board rectangle is the intersection of four half-planes
// n.d >= c (board_line, exact under the homography; only the distortion is linearised over the
// pixel); its area inside S follows from Green's theorem: the sum over the eight boundary lines
// (four of S, four of the rectangle) of the part of each line inside the other seven. A dot-grid
// disc is the ellipse it images to, mapped onto the unit circle. The CPU reference
// crates/scene/src/exact.rs computes the same areas independently, in f64, by polygon clipping.

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
    let sg = shaded_greys(pc.x, pc.y);
    let v = P.grey.w * (1.0 - a_margin) + sg.z * (a_margin - a_board) + sg.x * dark + sg.y * (a_board - dark);
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
    let sg = shaded_greys(pc.x, pc.y);
    let v = P.grey.w * (1.0 - a_plate) + sg.y * (a_plate - dark) + sg.x * dark;
    let sup = plane_supersample(ray, select(P.size.w, 0u, exact));
    return select(sup, v, exact);
}

