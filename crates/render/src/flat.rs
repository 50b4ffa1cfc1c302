//! Flat tiles: the 8 x 8-pixel tiles whose pixels all see one grey level (no edge of the target
//! inside), found on the CPU from the rays through the tile corners, so that the GPU passes skip
//! them. Conservative: a tile is flat only when the region bounded by its outline's image holds
//! no discontinuity of the target.

use nalgebra::{Matrix3, Vector3};
use rayon::prelude::*;

use super::tiles::TileCornerRays;
use synthcam_core::target::{CellLattice, Target};
use synthcam_scene::views::{ExposureView, ViewSet};
use synthcam_scene::Scene;

/// A view ([`synthcam_scene::views::ExposureView`]) as the flat test casts rays: its centre and the map
/// from a pinhole direction to its ray's direction, in the target frame (matrices, not
/// quaternions: the test casts millions of rays per frame with defocus or motion).
struct RayFrame {
    origin: Vector3<f64>,
    dir_from_pinhole: Matrix3<f64>,
}

impl RayFrame {
    fn new(view: &ExposureView) -> Self {
        let target_from_cam = view.cam_from_target.inverse();
        let rot = target_from_cam.rotation.to_rotation_matrix().into_inner();
        let m = view.direction_map().unwrap_or_else(Matrix3::identity);
        Self { origin: rot * view.aperture() + target_from_cam.translation.vector, dir_from_pinhole: rot * m }
    }

    /// The view's ray through pinhole direction `r`: origin and direction in the target frame.
    fn ray(&self, r: &Vector3<f64>) -> (Vector3<f64>, Vector3<f64>) {
        (self.origin, self.dir_from_pinhole * r)
    }
}

/// Bounding box `[xmin, ymin, xmax, ymax]` of the plane points seen along `rays` in all `frames`,
/// grown by 10 % of its size to cover the bending of the tile's edges by the distortion (a
/// straight pixel edge stays straight under the homography; the lens bends it by far less than
/// 10 %); `None` if a ray misses the plane. A warped board lies between the planes `z = z_range`
/// (`[0, 0]` when flat): the rays are met with both, and the box holds every point seen.
fn plane_bbox(frames: &[RayFrame], rays: &[Vector3<f64>], z_range: [f64; 2]) -> Option<[f64; 4]> {
    let mut bb = [f64::INFINITY, f64::INFINITY, f64::NEG_INFINITY, f64::NEG_INFINITY];
    // A flat board: one plane (its rays are cast once).
    let planes = if z_range[0] == z_range[1] { &z_range[..1] } else { &z_range[..] };
    for f in frames {
        for r in rays {
            let (o, d) = f.ray(r);
            for &z in planes {
                let t = (z - o.z) / d.z;
                if !(t > 0.0) || !t.is_finite() {
                    return None;
                }
                let (x, y) = (o.x + t * d.x, o.y + t * d.y);
                bb = [bb[0].min(x), bb[1].min(y), bb[2].max(x), bb[3].max(y)];
            }
        }
    }
    let gx = 0.1 * (bb[2] - bb[0]) + 1e-9;
    let gy = 0.1 * (bb[3] - bb[1]) + 1e-9;
    Some([bb[0] - gx, bb[1] - gy, bb[2] + gx, bb[3] + gy])
}

/// Whether every ray of a tile provably misses the target plane (it sees the background) in
/// every frame: each corner ray points away from the plane by more than a tenth of the tile's
/// angular size (the rays meeting the plane form a hemisphere of directions; the lens bends a
/// tile's edges by far less than that margin). A wide lens looks past the plane's horizon over
/// much of its image.
fn plane_missed(frames: &[RayFrame], rays: &[Vector3<f64>; 4]) -> bool {
    frames.iter().all(|f| {
        let side = -f.ray(&Vector3::z()).0.z.signum();
        let units = rays.map(|r| f.ray(&r).1.normalize());
        let size = (units[0] - units[2]).norm().max((units[1] - units[3]).norm());
        units.iter().all(|d| d.z * side < -(0.1 * size + 1e-9))
    })
}

/// Whether a line of the ascending `lines` lies in `[lo, hi]`.
fn any_in(lines: &[f64], lo: f64, hi: f64) -> bool {
    lines.get(lines.partition_point(|l| *l < lo)).is_some_and(|l| *l <= hi)
}

/// Grey level of each tile that is provably one flat region (no edge of the target inside), else
/// -1. Flat tiles skip all per-pixel work on the GPU. Conservative: a tile is flat only when the
/// region bounded by its outline's image holds no discontinuity of the target.
pub(super) fn classify_tiles(
    scene: &Scene,
    grid: &TileCornerRays,
    (tiles_x, tiles_y): (u32, u32),
    tile_start: &[u32],
    lattice: Option<&CellLattice>,
    views: &ViewSet,
) -> Vec<f32> {
    let flat = FlatTest::new(scene, lattice);
    let frames = tile_row_frames(views, tiles_y, scene.camera.size.height);
    (0..tiles_x * tiles_y)
        .into_par_iter()
        .map(|t| {
            let (tx, ty) = (t % tiles_x, t / tiles_x);
            let has_dots = tile_start[t as usize + 1] > tile_start[t as usize];
            if grid.beyond_lens(tx, ty) {
                return scene.target.background() as f32;
            }
            let f = row_frames(&frames, ty);
            grid.tile(tx, ty).and_then(|rays| flat.value(scene, f, &rays, has_dots)).map_or(-1.0, |v| v as f32)
        })
        .collect()
}

/// The frames each row of tiles is seen in: all views of the set, or under a rolling shutter
/// the views of the tile row's first and last pixel rows (the motion over 8 rows is smooth; the
/// bounding boxes' 10 % growth covers its curvature). One entry when rows share their views.
fn tile_row_frames(views: &ViewSet, tiles_y: u32, height: u32) -> Vec<Vec<RayFrame>> {
    if !views.per_row {
        return vec![views.views.iter().map(RayFrame::new).collect()];
    }
    (0..tiles_y)
        .into_par_iter()
        .map(|ty| {
            let (y0, y1) = (ty * super::tiles::TILE_PX, ((ty + 1) * super::tiles::TILE_PX).min(height) - 1);
            views.row(y0).iter().chain(views.row(y1)).map(RayFrame::new).collect()
        })
        .collect()
}

/// What [`classify_tiles`] tests each tile against, computed once per frame.
struct FlatTest<'a> {
    /// Chessboard: the board's lines (squares and margin) along x and y; coded boards: the
    /// board's and its border's outline, metres.
    lines_m: [Vec<f64>; 2],
    /// Coded boards: the cell lattice (a tile inside the board is flat when its cells are all
    /// of one colour, also across lattice lines).
    lattice: Option<&'a CellLattice>,
    /// S-path: the sphere's centre in the camera frame and its radius in pixels.
    sphere: Option<(Vector3<f64>, f64)>,
    /// The range of a warped board's sag over its sheet (`[0, 0]`: flat).
    z_range: [f64; 2],
}

impl<'a> FlatTest<'a> {
    fn new(scene: &Scene, lattice: Option<&'a CellLattice>) -> Self {
        let mut lines_m: [Vec<f64>; 2] = match &scene.target {
            Target::Chessboard(b) => {
                let along = |n: u32| (0..=n).map(|j| f64::from(j) * b.square_m).chain([-b.margin_m, f64::from(n) * b.square_m + b.margin_m]).collect();
                [along(b.squares[0]), along(b.squares[1])]
            }
            Target::Charuco(_) | Target::AprilGrid(_) => match scene.target.coded_look() {
                Some((look, [x0, y0, x1, y1])) => {
                    let m = look.margin_m;
                    [vec![x0 - m, x0, x1, x1 + m], vec![y0 - m, y0, y1, y1 + m]]
                }
                None => Default::default(),
            },
            _ => Default::default(),
        };
        lines_m.iter_mut().for_each(|l| l.sort_by(f64::total_cmp));
        let sphere = match &scene.target {
            Target::SPath(s) => {
                let c = (scene.cam_from_target * s.path.sphere_center_m).coords;
                let f = scene.camera.intrinsics.fx.min(scene.camera.intrinsics.fy);
                Some((c, f * s.path.sphere_radius_m / c.norm()))
            }
            _ => None,
        };
        let z_range = scene.target.warp().zip(scene.target.extent_m()).map_or([0.0; 2], |(w, sheet)| w.z_range(sheet));
        Self { lines_m, lattice, sphere, z_range }
    }

    /// The grey level of the tile seen along the corner `rays` when it is one flat region;
    /// `has_dots`: S-path dots reach the tile.
    fn value(&self, scene: &Scene, frames: &[RayFrame], rays: &[Vector3<f64>; 4], has_dots: bool) -> Option<f64> {
        match &scene.target {
            Target::Chessboard(_) | Target::DotGrid(_) | Target::Charuco(_) | Target::AprilGrid(_) if plane_missed(frames, rays) => {
                Some(scene.target.background())
            }
            // A point light shades every board pixel differently: the GPU passes draw them.
            _ if scene.render.lighting.varies() => None,
            Target::Chessboard(_) | Target::Charuco(_) | Target::AprilGrid(_) => plane_bbox(frames, rays, self.z_range).and_then(|bb| {
                let [xl, yl] = &self.lines_m;
                let crossed = any_in(xl, bb[0], bb[2]) || any_in(yl, bb[1], bb[3]);
                let uniform = self.lattice.is_none_or(|l| l.uniform_over(bb));
                (!crossed && uniform).then(|| scene.target.plane_intensity(0.5 * (bb[0] + bb[2]), 0.5 * (bb[1] + bb[3]))).flatten()
            }),
            Target::DotGrid(g) => plane_bbox(frames, rays, self.z_range).and_then(|bb| {
                let outer = 0.5 * g.edge_m + g.margin_m;
                if any_in(&[-outer, outer], bb[0], bb[2]) || any_in(&[-outer, outer], bb[1], bb[3]) {
                    return None;
                }
                let r = g.dot_radius_m;
                let near = g.dot_centres_m().iter().any(|c| {
                    let dx = (bb[0] - c.x).max(c.x - bb[2]).max(0.0);
                    let dy = (bb[1] - c.y).max(c.y - bb[3]).max(0.0);
                    dx * dx + dy * dy <= r * r
                });
                (!near).then(|| g.intensity_at(0.5 * (bb[0] + bb[2]), 0.5 * (bb[1] + bb[3])))
            }),
            Target::SPath(s) => {
                let (c, sphere_px) = self.sphere?;
                let r = s.path.sphere_radius_m;
                // Two pixels of angle at the sphere's distance.
                let margin = 2.0 * c.norm() / scene.camera.intrinsics.fx.min(scene.camera.intrinsics.fy);
                let dist = |d: &Vector3<f64>| {
                    let n = d.normalize();
                    (c - n * n.dot(&c)).norm()
                };
                // The sphere's outline is convex and, when it is over 100 px in radius, cannot
                // reach more than 16^2 / 800 px between two tile corners: corners all inside
                // (or all outside) by 2 px make the tile flat.
                if has_dots || c.z <= r || sphere_px < 100.0 {
                    None
                } else if rays.iter().all(|d| dist(d) < r - margin) {
                    Some(s.light)
                } else if rays.iter().all(|d| dist(d) > r + margin && d.dot(&c) > 0.0) {
                    Some(s.background)
                } else {
                    None
                }
            }
        }
    }
}

/// The frames tile row `ty` is seen in ([`tile_row_frames`]: one entry when rows share theirs).
fn row_frames(frames: &[Vec<RayFrame>], ty: u32) -> &[RayFrame] {
    frames.get(ty as usize).or(frames.first()).map_or(&[][..], Vec::as_slice)
}

/// Where a tile lies against the target's printed sheet (a background is mixed in beside it).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub(super) enum Cover {
    /// Beyond the lens's reach: no pixel has a ray.
    Beyond,
    /// Every pixel sees past the sheet.
    Outside,
    /// The sheet covers every pixel.
    Inside,
    /// The sheet's outline may cross the tile.
    Mixed,
}

/// Per tile, its [`Cover`]: by the same conservative tests as [`classify_tiles`] (the plane
/// points seen through the tile's corners, grown by 10 %, against the sheet's rectangle).
pub(super) fn sheet_cover(scene: &Scene, grid: &TileCornerRays, (tiles_x, tiles_y): (u32, u32), views: &ViewSet) -> Vec<Cover> {
    let Some([x0, y0, x1, y1]) = scene.target.extent_m() else { return vec![Cover::Mixed; (tiles_x * tiles_y) as usize] };
    let z_range = scene.target.warp().map_or([0.0; 2], |w| w.z_range([x0, y0, x1, y1]));
    let frames = tile_row_frames(views, tiles_y, scene.camera.size.height);
    (0..tiles_x * tiles_y)
        .into_par_iter()
        .map(|t| {
            let (tx, ty) = (t % tiles_x, t / tiles_x);
            if grid.beyond_lens(tx, ty) {
                return Cover::Beyond;
            }
            let f = row_frames(&frames, ty);
            let Some(rays) = grid.tile(tx, ty) else { return Cover::Mixed };
            if plane_missed(f, &rays) {
                return Cover::Outside;
            }
            match plane_bbox(f, &rays, z_range) {
                Some(bb) if bb[0] > x0 && bb[2] < x1 && bb[1] > y0 && bb[3] < y1 => Cover::Inside,
                Some(bb) if bb[2] < x0 || bb[0] > x1 || bb[3] < y0 || bb[1] > y1 => Cover::Outside,
                _ => Cover::Mixed,
            }
        })
        .collect()
}
