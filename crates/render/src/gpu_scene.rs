//! Scene to GPU inputs: the uniform block and, for the S-path, the dots (camera frame) and their
//! 16x16-pixel tile lists. Pure CPU code, f64 to f32 at the last step.

use synthcam_core::camera::{CameraModel, Lens};

use super::tiles::{TileCornerRays, TILE_PX};
use super::uniforms::Params;
use super::RenderError;
use synthcam_core::target::{CellLattice, DotStyle, SPathDots, Target, Warp};
use synthcam_scene::trace::dot_bbox_px;
use synthcam_scene::Scene;

/// The shader's lens variants: its `LENS_MODEL` and `LENS_TILT` pipeline constants
/// (`shaders/entries.wgsl`), indexed by [`lens_variant`].
pub const LENS_VARIANTS: [(f64, bool); 4] = [(0.0, false), (0.0, true), (1.0, false), (2.0, false)];

/// The index in [`LENS_VARIANTS`] of a lens: OpenCV, OpenCV with a tilted sensor, fisheye,
/// Double Sphere.
pub fn lens_variant(lens: &Lens) -> usize {
    match lens {
        Lens::OpenCv(d) => usize::from(d.has_tilt()),
        Lens::Fisheye(_) => 2,
        Lens::DoubleSphere(_) => 3,
    }
}

/// Pipeline variants: each lens variant, flat or warped board (the shader's `WARPED` pipeline
/// constant: llvmpipe runs a branch under a lane mask even when no lane takes it, so the warp's
/// tangent planes cost flat boards nothing only when compiled out).
pub const PIPELINE_VARIANTS: usize = 2 * LENS_VARIANTS.len();

/// The index of `scene`'s pipeline variant: its [`lens_variant`], plus [`LENS_VARIANTS`]`.len()`
/// for a warped board.
pub fn pipeline_variant(scene: &Scene) -> usize {
    lens_variant(&scene.camera.lens) + LENS_VARIANTS.len() * usize::from(scene.target.warp().is_some())
}

/// Everything the compute pass reads.
#[derive(Debug, Clone, PartialEq)]
pub struct GpuScene {
    /// Uniform block.
    pub params: Params,
    /// The scene's pipeline variant ([`pipeline_variant`]).
    pub lens_variant: usize,
    /// Dots: centre (camera frame, metres) and radius.
    pub dots: Vec<[f32; 4]>,
    /// Per tile, the start of its list in `tile_items` (`tiles + 1` entries).
    pub tile_start: Vec<u32>,
    /// Dot indices per tile (S-path); coded boards: the dark-cell bits of the lattice
    /// ([`synthcam_core::target::CellLattice::dark_bits`]).
    pub tile_items: Vec<u32>,
    /// Per tile, its grey level when the whole tile is one flat region, else -1.
    pub tile_flat: Vec<f32>,
    /// Planar targets: the views' homographies, three rows each (`super::views`).
    pub views: Vec<[f32; 4]>,
}

/// The renderer's passes, one per target kind (and per planar kind with views, and the objects'):
/// each runs a coarse / fine pair of the shader's entry points ([`PassKind::entry_points`]: sharp
/// planar, planar with views, S-path with its dotless tiles' own coarse entry, objects), the kind
/// set per pipeline through the shader's `PASS_KIND` override constant. The discriminants are the
/// shader's numbers (`KIND_*` in `shaders/bindings.wgsl`, compared by `uniforms`' naga test).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum PassKind {
    /// Chessboards (`KIND_CHESSBOARD`).
    Chessboard = 0,
    /// Dot grids (`KIND_DOT_GRID`).
    DotGrid = 1,
    /// The S-path's tiles with dots (`KIND_SPATH`).
    SPath = 2,
    /// The S-path's tiles that no dot reaches: the sphere's outline only (`KIND_SPATH_LIMB`).
    SPathLimb = 3,
    /// Coded boards (ChArUco, AprilGrid), shaded on their cell lattice (`KIND_CODED`).
    Coded = 4,
    /// Chessboards integrated over views (defocus, motion; `KIND_CHESSBOARD_VIEWS`).
    ChessboardViews = 5,
    /// Dot grids over views (`KIND_DOT_GRID_VIEWS`).
    DotGridViews = 6,
    /// Coded boards over views (`KIND_CODED_VIEWS`).
    CodedViews = 7,
    /// The objects (meshes), run after the target's (`shaders/objects.wgsl`).
    Objects = 8,
    /// The background behind the target (`shaders/background.wgsl`; one entry point, run as a
    /// fine pass over a pixel list).
    Background = 9,
}

impl PassKind {
    /// Number of pass kinds.
    pub const COUNT: usize = 10;
    /// Every pass kind, in discriminant order.
    pub const ALL: [PassKind; Self::COUNT] = [
        PassKind::Chessboard,
        PassKind::DotGrid,
        PassKind::SPath,
        PassKind::SPathLimb,
        PassKind::Coded,
        PassKind::ChessboardViews,
        PassKind::DotGridViews,
        PassKind::CodedViews,
        PassKind::Objects,
        PassKind::Background,
    ];

    /// The shader's entry points of this pass, coarse then fine.
    pub fn entry_points(self) -> [&'static str; 2] {
        match self {
            PassKind::SPath => ["cs_coarse_spath", "cs_fine_spath"],
            PassKind::SPathLimb => ["cs_coarse_spath_limb", "cs_fine_spath"],
            PassKind::Objects => ["cs_coarse_objects", "cs_fine_objects"],
            PassKind::Background => ["cs_background", "cs_background"],
            PassKind::ChessboardViews | PassKind::DotGridViews | PassKind::CodedViews => ["cs_coarse_planar_views", "cs_fine_planar_views"],
            PassKind::Chessboard | PassKind::DotGrid | PassKind::Coded => ["cs_coarse_planar", "cs_fine_planar"],
        }
    }

    /// The kind integrated over views (defocus, motion): planar kinds only, others unchanged.
    pub fn with_views(self) -> Self {
        match self {
            PassKind::Chessboard => PassKind::ChessboardViews,
            PassKind::DotGrid => PassKind::DotGridViews,
            PassKind::Coded => PassKind::CodedViews,
            k => k,
        }
    }
}

/// The pass kind of a target (also the shader's `P.size.z`).
pub fn pass_kind(target: &Target) -> PassKind {
    match target {
        Target::Chessboard(_) => PassKind::Chessboard,
        Target::DotGrid(_) => PassKind::DotGrid,
        Target::SPath(_) => PassKind::SPath,
        Target::Charuco(_) | Target::AprilGrid(_) => PassKind::Coded,
    }
}

/// The pass kind of a scene: [`pass_kind`], or for a planar target integrated over views
/// (defocus, motion) its views kind ([`PassKind::with_views`]).
pub fn scene_pass_kind(scene: &Scene) -> PassKind {
    let kind = pass_kind(&scene.target);
    if scene.render.effects.needs_views() {
        kind.with_views()
    } else {
        kind
    }
}

/// Build the GPU inputs of `scene`; `grid` must belong to `scene.camera`.
///
/// # Errors
/// [`RenderError::Degenerate`] when the target plane contains the camera centre (seen edge-on).
pub fn gpu_scene(scene: &Scene, grid: &TileCornerRays) -> Result<GpuScene, RenderError> {
    let cam = &scene.camera;
    let (w, h) = (cam.size.width, cam.size.height);
    let k = &cam.intrinsics;
    let tiles_x = w.div_ceil(TILE_PX);
    let tiles_y = h.div_ceil(TILE_PX);
    let mut p = Params {
        size: [w, h, pass_kind(&scene.target) as u32, scene.render.samples],
        tiles: [tiles_x, tiles_y, 0, 0],
        intr: [k.fx as f32, k.fy as f32, k.cx as f32, k.cy as f32],
        ..Default::default()
    };
    lens_params(&mut p, cam, grid.split_radii);
    // A coded board's lattice, built once per frame for the uniforms and the flat tiles.
    let lattice = scene.target.lattice();
    let view_set = synthcam_scene::views::view_set(scene);
    let mut views = Vec::new();
    let (mut dots, tile_start, mut tile_items) = match &scene.target {
        Target::Chessboard(_) | Target::DotGrid(_) | Target::Charuco(_) | Target::AprilGrid(_) => {
            let bits = planar_params(&mut p, scene, lattice.as_ref())?;
            views = super::views::gpu_views(&view_set)?;
            if let [h0, h1, h2, ..] = views[..] {
                (p.h0, p.h1, p.h2) = (h0, h1, h2);
            }
            p.vw = [view_set.samples, u32::from(view_set.per_row), 0, 0];
            if let Some(sharp) = view_set.views.first() {
                warp_params(&mut p, scene, sharp)?;
            }
            lamp_params(&mut p, scene);
            (Vec::new(), vec![0u32; (tiles_x * tiles_y + 1) as usize], bits)
        }
        Target::SPath(s) => s_path_params(&mut p, scene, s, (tiles_x, tiles_y)),
    };
    super::background::background_params(&mut p, scene);
    let tile_flat = super::flat::classify_tiles(scene, grid, (tiles_x, tiles_y), &tile_start, lattice.as_ref(), &view_set);
    // Storage buffers may not be empty.
    if dots.is_empty() {
        dots.push([0.0; 4]);
    }
    if tile_items.is_empty() {
        tile_items.push(0);
    }
    if views.is_empty() {
        views.push([0.0; 4]);
    }
    Ok(GpuScene { params: p, lens_variant: pipeline_variant(scene), dots, tile_start, tile_items, tile_flat, views })
}

/// A point or area light's uniforms (`Params::shade`, `lamp`, `area1..4`, `area_e`), in the target
/// frame; nothing when the lighting is uniform over the board (the grey levels were scaled on the
/// CPU by `synthcam_scene::lighting::shade`).
fn lamp_params(p: &mut Params, scene: &Scene) {
    let lighting = scene.render.lighting;
    let n_cam = synthcam_scene::lighting::camera_side_normal(scene);
    let target_from_cam = scene.cam_from_target.inverse();
    let f32s = |v: &nalgebra::Vector3<f64>, w: f64| [v.x as f32, v.y as f32, v.z as f32, w as f32];
    let constant = lighting.factor(&n_cam, &scene.cam_from_target);
    if let Some(area) = lighting.area {
        // The part of the light above the board's plane (the horizon of every board point).
        let rect = area.rectangle_in_camera(&scene.cam_from_target).moved(&target_from_cam);
        let n_t = target_from_cam.rotation * n_cam;
        let mut polygon = rect.part_above(&nalgebra::Point3::origin(), &nalgebra::Vector3::new(0.0, 0.0, n_t.z.signum()));
        let last = polygon.last().copied().unwrap_or(rect.corner);
        polygon.resize(5, last);
        let emit = rect.u.cross(&rect.v).normalize();
        p.shade = [constant as f32, 2.0, 0.0, 0.0];
        p.lamp = f32s(&polygon[0].coords, area.radiance());
        [p.area1, p.area2, p.area3, p.area4] = [1, 2, 3, 4].map(|k| f32s(&polygon[k].coords, 0.0));
        p.area_e = f32s(&emit, emit.dot(&rect.corner.coords));
    } else if let Some(lamp) = lighting.points.iter().flatten().next() {
        let l_t = target_from_cam * nalgebra::Point3::from(synthcam_scene::lighting::Lighting::point_in_camera(lamp, &scene.cam_from_target));
        let gloss = lighting.gloss.map_or([0.0; 2], |g| [g.specular as f32, g.roughness as f32]);
        p.shade = [constant as f32, 1.0, gloss[0], gloss[1]];
        p.lamp = f32s(&l_t.coords, lamp.intensity);
    } else {
        return;
    }
    let eye = target_from_cam * nalgebra::Point3::origin();
    let n_z = (target_from_cam.rotation * n_cam).z.signum();
    p.eye = f32s(&eye.coords, n_z);
}

/// The lens model's uniforms (see `Params`); `split` from [`super::bend::split_radii`].
fn lens_params(p: &mut Params, cam: &CameraModel, split: [f64; 2]) {
    let r2_max = cam.lens.max_radius().map_or(1e30, |r| (r * r) as f32);
    p.intr2 = [cam.intrinsics.skew as f32, r2_max, if cam.lens.is_identity() { 0.0 } else { 1.0 }, 0.0];
    let a = cam.lens.params().map(|v| v as f32);
    p.dist0 = [a[0], a[1], a[2], a[3]];
    p.tilt0 = [1.0, 0.0, 0.0, 0.0];
    p.tilt1 = [0.0, 1.0, 0.0, 0.0];
    p.tilt2 = [0.0, 0.0, 1.0, 0.0];
    match cam.lens {
        Lens::OpenCv(d) => {
            p.dist1 = [a[4], a[5], a[6], a[7]];
            p.dist2 = [a[8], a[9], a[10], a[11]];
            if d.has_tilt() {
                let t = synthcam_core::camera::distortion::tilt::matrix(d.tau_x, d.tau_y);
                p.tilt0 = [t[(0, 0)] as f32, t[(0, 1)] as f32, t[(0, 2)] as f32, 0.0];
                p.tilt1 = [t[(1, 0)] as f32, t[(1, 1)] as f32, t[(1, 2)] as f32, 0.0];
                p.tilt2 = [t[(2, 0)] as f32, t[(2, 1)] as f32, t[(2, 2)] as f32, 0.0];
            }
        }
        Lens::Fisheye(f) => p.dist1 = [f.theta_max() as f32, split[0].min(1e30) as f32, split[1].min(1e30) as f32, 0.0],
        Lens::DoubleSphere(_) => {}
    }
}

/// The board's or grid's parameters (chessboard, dot grid, coded boards); for a coded board (its
/// `lattice`) its dark-cell bits. The plane homographies are the views' (`super::views`).
fn planar_params(p: &mut Params, scene: &Scene, lattice: Option<&CellLattice>) -> Result<Vec<u32>, RenderError> {
    match &scene.target {
        Target::Chessboard(b) => {
            p.board = [b.squares[0] as f32, b.squares[1] as f32, b.square_m as f32, b.margin_m as f32];
            p.grey = [b.dark as f32, b.light as f32, b.margin as f32, b.background as f32];
        }
        Target::DotGrid(g) => {
            p.board = [g.n as f32, g.edge_m as f32, g.dot_radius_m as f32, g.margin_m as f32];
            p.grey = [g.dark as f32, g.light as f32, g.light as f32, g.background as f32];
        }
        Target::Charuco(_) | Target::AprilGrid(_) => {
            let (Some(l), Some((look, _))) = (lattice, scene.target.coded_look()) else { return Ok(Vec::new()) };
            p.board = [l.cells[0] as f32, l.cells[1] as f32, l.per_period as f32, look.margin_m as f32];
            p.grey = [look.dark as f32, look.light as f32, look.margin as f32, look.background as f32];
            p.lat = [l.period_m as f32, l.origin_m as f32, l.first_m as f32, l.cell_m as f32];
            p.lat2 = [l.end_m(0) as f32, l.end_m(1) as f32, l.min_cell_m() as f32, 0.0];
            return Ok(l.dark_bits.clone());
        }
        Target::SPath(_) => {}
    }
    Ok(Vec::new())
}

/// A warped board's uniforms (`Params::warp`, `warp_c`, `tfc*`; all zero for a flat one): the
/// sharp view's pose and the `lambda` of its homography's row scaling
/// ([`super::views::homography_scaled`]; a warped board has that one view: scene validation).
fn warp_params(p: &mut Params, scene: &Scene, sharp: &synthcam_scene::views::ExposureView) -> Result<(), RenderError> {
    let Some(Warp { k, extent: Some(e) }) = scene.target.warp() else { return Ok(()) };
    let (_, scale) = super::views::homography_scaled(sharp)?;
    let r = scene.cam_from_target.rotation.to_rotation_matrix();
    let t = scene.cam_from_target.translation.vector;
    let rt = r.matrix().transpose();
    let centre = -(rt * t);
    p.warp = [k[0] as f32, k[1] as f32, (1.0 / scale) as f32, 1.0];
    p.warp_c = [(0.5 * (e.x.0 + e.x.1)) as f32, (0.5 * (e.y.0 + e.y.1)) as f32, (2.0 / (e.x.1 - e.x.0)) as f32, (2.0 / (e.y.1 - e.y.0)) as f32];
    for (row, out) in [&mut p.tfc0, &mut p.tfc1, &mut p.tfc2].into_iter().enumerate() {
        *out = [rt[(row, 0)] as f32, rt[(row, 1)] as f32, rt[(row, 2)] as f32, centre[row] as f32];
    }
    Ok(())
}

/// The S-path's parameters, its dots in the camera frame, and per tile the dots whose footprint
/// reaches it (`tile_start` offsets into `tile_items`).
fn s_path_params(p: &mut Params, scene: &Scene, s: &SPathDots, (tiles_x, tiles_y): (u32, u32)) -> (Vec<[f32; 4]>, Vec<u32>, Vec<u32>) {
    let (w, h) = (scene.camera.size.width, scene.camera.size.height);
    p.tiles[2] = match s.style {
        DotStyle::Bead => 0,
        DotStyle::Disc => 1,
    };
    let c = scene.cam_from_target * s.path.sphere_center_m;
    p.sphere = [c.x as f32, c.y as f32, c.z as f32, s.path.sphere_radius_m as f32];
    p.grey = [s.dark as f32, s.light as f32, s.light as f32, s.background as f32];
    let mut dots = Vec::new();
    let mut lists: Vec<Vec<u32>> = vec![Vec::new(); (tiles_x * tiles_y) as usize];
    for (i, pt) in s.path.points_m.iter().enumerate() {
        let pc = scene.cam_from_target * pt;
        dots.push([pc.x as f32, pc.y as f32, pc.z as f32, s.dot_radius(i) as f32]);
        let Some(bb) = dot_bbox_px(scene, pt, s.dot_radius(i), 2.0) else { continue };
        if bb[2] < -0.5 || bb[3] < -0.5 || bb[0] > f64::from(w) || bb[1] > f64::from(h) {
            continue;
        }
        let tx0 = (bb[0].max(0.0) / f64::from(TILE_PX)) as u32;
        let ty0 = (bb[1].max(0.0) / f64::from(TILE_PX)) as u32;
        let tx1 = ((bb[2].max(0.0) / f64::from(TILE_PX)) as u32).min(tiles_x - 1);
        let ty1 = ((bb[3].max(0.0) / f64::from(TILE_PX)) as u32).min(tiles_y - 1);
        for ty in ty0..=ty1 {
            for tx in tx0..=tx1 {
                lists[(ty * tiles_x + tx) as usize].push(i as u32);
            }
        }
    }
    let mut tile_start = vec![0u32; (tiles_x * tiles_y + 1) as usize];
    let mut tile_items = Vec::new();
    for (t, l) in lists.iter().enumerate() {
        tile_start[t + 1] = tile_start[t] + l.len() as u32;
        tile_items.extend_from_slice(l);
    }
    (dots, tile_start, tile_items)
}
