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
// Mirrors: crates/scene/src/trace.rs (CPU, f64). Uniform layout: crates/render/src/uniforms.rs `Params`.
//
// One WGSL module in ten files, joined in this order by crates/render/src/shader.rs (`SHADER`):
// bindings (this: bindings, the uniform `Params`, the current view), arithmetic (exact-order
// sums), lens (the per-pixel lens inversion and its Jacobian), planar (plane colours), coded
// (the cell lattice of ChArUco and AprilGrid boards), coverage (exact pixel coverage), s_path,
// entries (the compute entry points of the target passes), objects (meshes: BVH, occlusion),
// background (a panorama or an image on a plane behind everything).

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
    vw: vec4<u32>,       // planar targets: views per pixel, one set per row (1) or one for all (0), 0, 0
    obj: vec4<u32>,      // objects: instances, first instance row in objs, fine samples per axis, 0 (objects.wgsl)
    plane: vec4<f32>,    // planar targets: the plane n . x = c in the camera frame (n, c)
    sheet: vec4<f32>,    // planar targets: the printed sheet in the plane, x0, y0, x1, y1 (metres)
    warp: vec4<f32>,     // warped boards: kx, ky (metres), lambda (H = [r1 r2 t]^-1 / lambda), 1 when warped (planar.wgsl warp_view)
    warp_c: vec4<f32>,   // warped boards: the feature extent's centre xc, yc and scales sx, sy (u = (x - xc) sx)
    tfc0: vec4<f32>,     // warped boards: rows of target_from_cam's rotation (xyz) and the camera centre in the target frame (w)
    tfc1: vec4<f32>,
    tfc2: vec4<f32>,
    shade: vec4<f32>,    // planar targets under a point or area light: constant shading (ambient + directional), 1 point / 2 area light, gloss F0, roughness (0: none) (planar.wgsl shaded_greys)
    lamp: vec4<f32>,     // the point light in the target frame: x, y, z, intensity; an area light: a corner of its polygon above the board's horizon, radiance
    area1: vec4<f32>,    // the polygon's other corners, target frame (xyz; the last repeated to five)
    area2: vec4<f32>,
    area3: vec4<f32>,
    area4: vec4<f32>,
    area_e: vec4<f32>,   // the emitter's plane, target frame: normal towards where it emits (xyz), its offset (w)
    eye: vec4<f32>,      // the camera centre in the target frame, the camera-side normal's z (+-1)
    bg: vec4<f32>,       // background: kind (0 none, 1 panorama, 2 plane), image width, height, 0 (background.wgsl)
    bg0: vec4<f32>,      // rows of the background's frame from the camera's (xyz); a plane: the camera centre in its frame (w)
    bg1: vec4<f32>,
    bg2: vec4<f32>,
    bg_size: vec4<f32>,  // a plane image's width and height, metres, 0, 0
    sun: vec4<f32>,      // objects' shadows: the direction towards the light (camera frame; 0: none), shadowed / lit shading (objects.wgsl)
    soft_c: vec4<f32>,   // objects' soft shadows (area light): a corner in the camera frame, the ambient term
    soft_u: vec4<f32>,   // its edges, camera frame; w: 1 when on (soft_u), 0
    soft_v: vec4<f32>,   // its other edge; w: the soft-shadow lattice's first row in objs (0: none, -1: computing its points; objects.wgsl lattice_at)
    obj_sun: vec4<f32>,  // lit objects: the directional light's irradiance times the unit direction towards it (camera frame; 0: none), the ambient term (objects.wgsl sun_on)
};

// Pass kinds (crates/render/src/gpu_scene.rs `PassKind`; the test
// `uniforms::tests::shader_kinds_are_the_rust_ones` compares them): the target's kind is `P.size.z`,
// the pipeline's is the `PASS_KIND` override constant (shaders/entries.wgsl).
const KIND_CHESSBOARD: u32 = 0u;
const KIND_DOT_GRID: u32 = 1u;
const KIND_SPATH: u32 = 2u;
const KIND_SPATH_LIMB: u32 = 3u;
const KIND_CODED: u32 = 4u;
const KIND_CHESSBOARD_VIEWS: u32 = 5u;
const KIND_DOT_GRID_VIEWS: u32 = 6u;
const KIND_CODED_VIEWS: u32 = 7u;
const KIND_OBJECTS: u32 = 8u;
const KIND_BACKGROUND: u32 = 9u;

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
// a rolling shutter), each the three rows of its plane homography H (crates/render/src/views.rs).
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

