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
    if (kind != KIND_DOT_GRID) { return cells_coarse_views(ray, px.y, kind == KIND_CODED); }
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

// How far (board units, per axis) the views of row y put the board point of ray d from the first
// view's `pc`: exact at the pixel's centre; 1e30 where a view does not see the plane.
fn views_spread(d: vec3<f32>, y: u32, pc: vec3<f32>) -> vec2<f32> {
    var m = vec2<f32>(0.0);
    for (var s = 1u; s < P.vw.x; s = s + 1u) {
        let k = view_index(y, s);
        let w = h_dot(views[k + 2u].xyz, d);
        let b = vec2<f32>(h_dot(views[k].xyz, d), h_dot(views[k + 1u].xyz, d)) / w;
        m = select(vec2<f32>(1e30), max(m, abs(b - pc.xy)), w > 0.0 && m.x < 1e29);
    }
    return m;
}

// Boards of cells with views. Every view's footprint lies within the first view's grown by the
// views' spread at this pixel (views_spread, x 1.25, plus half a pixel through the board
// Jacobian for its change across the footprint), plus 10 %. No line in that region: every view
// sees one cell. One line: the mean over the views of each view's exact half-plane coverage of it
// (the two cells beside it are the same for every view). Otherwise each view's own coarse value
// (cells_coarse), hard when any view's is. The loops run only for the lanes that need them
// (llvmpipe leaves a loop when no lane is active).
fn cells_coarse_views(ray: Ray, y: u32, coded: bool) -> Coarse {
    set_view(y, 0u);
    let pc = plane_point(ray_d(ray));
    let a = board_jacobian(pc, ray);
    let per_px = vec2<f32>(abs(a[0].x) + abs(a[1].x), abs(a[0].y) + abs(a[1].y));
    let m = views_spread(ray_d(ray), y, pc);
    let spread = max(m.x, m.y);
    let own = footprint_extent(a);
    let ext = 1.1 * (own + 1.25 * m + 0.5 * per_px);
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

// The pass kind of this pipeline (KIND_*, shaders/bindings.wgsl), set when the renderer creates it
// (crates/render/src/gpu_scene.rs `PassKind`). A constant at compile time, so each pipeline keeps
// the branch of its own kind only (llvmpipe would otherwise run every branch under a lane mask).
override PASS_KIND: u32 = 0u;

// The planar target kind of a planar pass kind (chessboard 0, dot grid 1, coded boards 4), with or
// without views: an override too, so that it is a constant at compile time.
override PLANAR_KIND: u32 = select(select(PASS_KIND, PASS_KIND - KIND_CHESSBOARD_VIEWS, PASS_KIND >= KIND_CHESSBOARD_VIEWS), KIND_CODED, PASS_KIND == KIND_CODED_VIEWS);

// Coarse pass of the sharp planar targets (chessboard, dot grid, coded boards). The passes with views
// have their own entry points: lavapipe compiles every function an entry point reaches before it
// drops the branches a constant rules out, so one entry for both costs start-up time.
@compute @workgroup_size(8, 8, 1)
fn cs_coarse_planar(@builtin(workgroup_id) wg: vec3<u32>, @builtin(local_invocation_id) lid: vec3<u32>) {
    let px = coarse_pixel(wg, lid);
    uniform_view();
    let ray = pixel_ray(vec2<f32>(f32(px.x), f32(px.y)));
    warp_view(ray);
    if (PLANAR_KIND == KIND_DOT_GRID) {
        write_coarse(wg, lid, grid_coarse(ray));
    } else {
        write_coarse(wg, lid, cells_coarse(ray, PLANAR_KIND == KIND_CODED));
    }
}

// Coarse pass of the planar targets with views (defocus, motion).
@compute @workgroup_size(8, 8, 1)
fn cs_coarse_planar_views(@builtin(workgroup_id) wg: vec3<u32>, @builtin(local_invocation_id) lid: vec3<u32>) {
    write_coarse(wg, lid, planar_coarse_views(coarse_pixel(wg, lid), PLANAR_KIND));
}

// Coarse pass of the S-path's tiles with dots.
@compute @workgroup_size(8, 8, 1)
fn cs_coarse_spath(@builtin(workgroup_id) wg: vec3<u32>, @builtin(local_invocation_id) lid: vec3<u32>) {
    let px = coarse_pixel(wg, lid);
    write_coarse(wg, lid, spath_coarse(pixel_ray(vec2<f32>(f32(px.x), f32(px.y))), px.z));
}

// Coarse pass of the S-path's tiles that no dot reaches (the sphere's outline only; its own entry
// point for the reason above); their hard pixels go to cs_fine_spath.
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
// (crates/render/src/bend.rs): the mean of its sub-pixels, each with its own ray (a sub-pixel beyond the
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

// The fine value of pass kind `kind` (a literal at each call) along `r` (a warped board's
// tangent plane for the ray first: warp_view).
fn planar_fine_ray(r: Ray, kind: u32) -> f32 {
    warp_view(r);
    if (kind == KIND_CODED) { return cells_fine(r, true); }
    if (kind == KIND_CHESSBOARD) { return cells_fine(r, false); }
    return grid_fine(r);
}

// Fine pass of the sharp planar targets.
@compute @workgroup_size(64, 1, 1)
fn cs_fine_planar(@builtin(global_invocation_id) gid: vec3<u32>) {
    let it = fine_item(gid);
    out_vals[gid.y * 65535u * 64u + gid.x] = planar_fine(vec2<f32>(f32(it.x), f32(it.y)), PLANAR_KIND);
}

// Fine pass of the planar targets with views.
@compute @workgroup_size(64, 1, 1)
fn cs_fine_planar_views(@builtin(global_invocation_id) gid: vec3<u32>) {
    let it = fine_item(gid);
    out_vals[gid.y * 65535u * 64u + gid.x] = planar_fine_views(vec2<f32>(f32(it.x), f32(it.y)), PLANAR_KIND);
}

// Fine pass of the S-path (both of its coarse kinds).
@compute @workgroup_size(64, 1, 1)
fn cs_fine_spath(@builtin(global_invocation_id) gid: vec3<u32>) {
    let it = fine_item(gid);
    out_vals[gid.y * 65535u * 64u + gid.x] = spath_fine(pixel_ray(vec2<f32>(f32(it.x), f32(it.y))), it.z);
}
