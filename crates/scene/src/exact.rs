//! Exact box-filtered reference for planar targets (chessboard, dot grid, ChArUco, AprilGrid), f64.
//!
//! Each pixel square is cut into `subdivisions^2` sub-squares; the corners of every sub-square are
//! unprojected exactly ([`synthcam_core::camera::CameraModel::unproject_ray`]: Newton inversion of the
//! distortion) and intersected with the target plane, which gives a quadrilateral on the plane.
//! Its area inside every square, margin, plate and disc is computed exactly by polygon clipping
//! ([`synthcam_core::math::polygon`]); the sub-square's grey is the area-weighted mean of the region greys,
//! and the pixel's the mean over its sub-squares. The only approximation is that the map from
//! image to plane is treated as projective within one sub-square (edges straight); its error
//! falls as `subdivisions^-2` (measured by the property test at 4 vs 8 subdivisions).
//!
//! This is written apart from the GPU renderer (the shaders (`shaders/*.wgsl`)) and from the point-sampled
//! reference ([`super::reference`]): it shares only the camera model and the target description,
//! so it can check every pixel of the shader's closed-form coverage paths.

use nalgebra::{Isometry3, Point2, Point3, Vector2};
use rayon::prelude::*;

use super::{Scene, SceneError};
use synthcam_core::math::polygon::{self, Polygon};
use synthcam_core::target::{AprilGrid, Charuco, Chessboard, DotGrid, Target};

/// A rendered exact reference: grey levels row-major, `None` where a sub-square corner's ray
/// cannot be unprojected (beyond the fold of the lens model), where the grey is not defined.
pub type ExactImage = Vec<Option<f64>>;

/// Render `scene` exactly (see the module docs) with `subdivisions^2` sub-squares per pixel.
///
/// # Errors
/// [`SceneError::InvalidField`] for an S-path scene (not planar), a warped board, or `subdivisions` outside
/// 1..=64, and the scene's own validation errors.
pub fn render_exact_planar(scene: &Scene, subdivisions: u32) -> Result<ExactImage, SceneError> {
    scene.validate()?;
    let shaded = crate::lighting::shade(scene)?;
    let scene: &Scene = &shaded;
    if scene.render.lighting.varies() {
        return Err(SceneError::InvalidField { field: "light".into(), reason: "the exact reference shades uniform lighting only (no point light)".into() });
    }
    if !(1..=64).contains(&subdivisions) {
        return Err(SceneError::InvalidField { field: "subdivisions".into(), reason: format!("must be in 1..=64, got {subdivisions}") });
    }
    if !scene.target.is_planar() {
        return Err(SceneError::InvalidField { field: "target.kind".into(), reason: "the exact reference covers planar targets only".into() });
    }
    if scene.target.warp().is_some() {
        return Err(SceneError::InvalidField { field: "target.warp_m".into(), reason: "the exact reference covers flat boards only".into() });
    }
    let (w, h) = (scene.camera.size.width as usize, scene.camera.size.height as usize);
    let target_from_cam = scene.cam_from_target.inverse();
    let mut out = vec![None; w * h];
    out.par_chunks_mut(w).enumerate().for_each(|(y, row)| {
        for (x, px) in row.iter_mut().enumerate() {
            *px = pixel_value(scene, &target_from_cam, x as f64, y as f64, subdivisions);
        }
    });
    Ok(out)
}

/// Where the ray through pixel position `q_px` meets the target plane (target frame, metres):
/// `Some(Some(p))`, `Some(None)` when the ray misses the plane (beyond its horizon), `None` when
/// the pixel cannot be unprojected (beyond the fold of the lens model).
pub fn plane_point(scene: &Scene, q_px: Point2<f64>) -> Option<Option<Vector2<f64>>> {
    plane_point_from(scene, &scene.cam_from_target.inverse(), q_px)
}

/// [`plane_point`] with the scene's `target_from_cam` computed once by the caller.
fn plane_point_from(scene: &Scene, target_from_cam: &Isometry3<f64>, q_px: Point2<f64>) -> Option<Option<Vector2<f64>>> {
    let d = scene.camera.unproject_ray(&q_px).ok()?;
    let o = target_from_cam * Point3::origin();
    let dir = target_from_cam.rotation * d;
    let t = -o.z / dir.z;
    Some((t > 0.0 && t.is_finite()).then(|| Vector2::new(o.x + t * dir.x, o.y + t * dir.y)))
}

fn pixel_value(scene: &Scene, target_from_cam: &Isometry3<f64>, x: f64, y: f64, n: u32) -> Option<f64> {
    let m = n as usize + 1;
    let step = 1.0 / f64::from(n);
    let mut corners = Vec::with_capacity(m * m);
    for j in 0..m {
        for i in 0..m {
            corners.push(plane_point_from(scene, target_from_cam, Point2::new(x - 0.5 + i as f64 * step, y - 0.5 + j as f64 * step))?);
        }
    }
    let background = scene.target.background();
    let mut sum = 0.0;
    for j in 0..n as usize {
        for i in 0..n as usize {
            let quad: Option<Polygon> =
                [corners[j * m + i], corners[j * m + i + 1], corners[(j + 1) * m + i + 1], corners[(j + 1) * m + i]].into_iter().collect();
            // A corner beyond the plane's horizon: the rays there see infinitely far parts of the
            // plane, never the (finite) target.
            sum += quad.map_or(background, |q| region_mean(&scene.target, &q));
        }
    }
    Some(sum / f64::from(n * n))
}

/// Area-weighted mean grey of the target over the quadrilateral `quad` (target-plane metres).
fn region_mean(target: &Target, quad: &[Vector2<f64>]) -> f64 {
    let a = polygon::area(quad);
    if !(a > 0.0) {
        return target.background();
    }
    match target {
        Target::Chessboard(b) => chessboard_sum(b, quad, a) / a,
        Target::DotGrid(g) => dot_grid_sum(g, quad, a) / a,
        Target::Charuco(_) | Target::AprilGrid(_) => coded_sum(target, quad, a) / a,
        Target::SPath(_) => target.background(),
    }
}

/// Integral of the chessboard's grey over `quad` (area `a`).
fn chessboard_sum(b: &Chessboard, quad: &[Vector2<f64>], a: f64) -> f64 {
    let s = b.square_m;
    let (w, h) = (s * f64::from(b.squares[0]), s * f64::from(b.squares[1]));
    let mm = b.margin_m;
    let a_margin = polygon::area(&polygon::clip_rect(quad, Vector2::new(-mm, -mm), Vector2::new(w + mm, h + mm)));
    let on_board = polygon::clip_rect(quad, Vector2::zeros(), Vector2::new(w, h));
    let a_board = polygon::area(&on_board);
    let mut dark = 0.0;
    if let Some((lo, hi)) = polygon::bbox(&on_board) {
        let (i0, i1) = cell_range(lo.x, hi.x, s, b.squares[0]);
        let (j0, j1) = cell_range(lo.y, hi.y, s, b.squares[1]);
        for j in j0..=j1 {
            for i in (i0..=i1).filter(|i| (i + j) % 2 == 0) {
                let cell_lo = Vector2::new(f64::from(i) * s, f64::from(j) * s);
                dark += polygon::area(&polygon::clip_rect(&on_board, cell_lo, cell_lo + Vector2::new(s, s)));
            }
        }
    }
    b.background * (a - a_margin) + b.margin * (a_margin - a_board) + b.dark * dark + b.light * (a_board - dark)
}

/// Integral of a coded board's grey over `quad` (area `a`): border, board, and the dark area of
/// its squares, marker and tag cells and corner squares ([`charuco_dark`], [`aprilgrid_dark`]).
fn coded_sum(target: &Target, quad: &[Vector2<f64>], a: f64) -> f64 {
    let Some((l, [x0, y0, x1, y1])) = target.coded_look() else { return a * target.background() };
    let mm = l.margin_m;
    let a_margin = polygon::area(&polygon::clip_rect(quad, Vector2::new(x0 - mm, y0 - mm), Vector2::new(x1 + mm, y1 + mm)));
    let on_board = polygon::clip_rect(quad, Vector2::new(x0, y0), Vector2::new(x1, y1));
    let a_board = polygon::area(&on_board);
    let dark = match (target, polygon::bbox(&on_board)) {
        (Target::Charuco(c), Some(bb)) => charuco_dark(&c.board, &on_board, bb),
        (Target::AprilGrid(g), Some(bb)) => aprilgrid_dark(&g.grid, &on_board, bb),
        _ => 0.0,
    };
    l.background * (a - a_margin) + l.margin * (a_margin - a_board) + l.dark * dark + l.light * (a_board - dark)
}

/// Dark area of `poly` (on the board, bounding box `bb`) on a ChArUco board: squares without a
/// marker whole, marker squares cell by cell.
fn charuco_dark(b: &Charuco, poly: &[Vector2<f64>], (lo, hi): (Vector2<f64>, Vector2<f64>)) -> f64 {
    let s = b.square_m;
    let (i0, i1) = cell_range(lo.x, hi.x, s, b.squares[0]);
    let (j0, j1) = cell_range(lo.y, hi.y, s, b.squares[1]);
    let n = b.dictionary.marker_bits() as u32 + 2;
    let mut dark = 0.0;
    for j in j0..=j1 {
        for i in i0..=i1 {
            let sq = Vector2::new(f64::from(i) * s, f64::from(j) * s);
            dark += if b.has_marker(i, j) {
                let origin = sq + Vector2::repeat(0.5 * (s - b.marker_m));
                cells_dark_area(poly, (lo, hi), origin, b.marker_m / f64::from(n), n, |x, y| b.is_dark(x, y) == Some(true))
            } else {
                polygon::area(&polygon::clip_rect(poly, sq, sq + Vector2::new(s, s)))
            };
        }
    }
    dark
}

/// Dark area of `poly` (on the grid, bounding box `bb`) on an AprilGrid: the corner squares and
/// each tag cell by cell.
fn aprilgrid_dark(g: &AprilGrid, poly: &[Vector2<f64>], bb: (Vector2<f64>, Vector2<f64>)) -> f64 {
    let (lo, hi) = bb;
    let squares: f64 =
        g.corner_squares_m().iter().map(|(c, e)| polygon::area(&polygon::clip_rect(poly, Vector2::new(c[0], c[1]), Vector2::new(c[0] + e, c[1] + e)))).sum();
    let n = g.family.marker_bits() as u32 + 2 * g.border_bits;
    let tags: f64 = (0..g.tags[0] * g.tags[1])
        .map(|k| g.tag_corners_m(k))
        .filter(|c| c[2].x >= lo.x && c[0].x <= hi.x && c[2].y >= lo.y && c[0].y <= hi.y)
        .map(|c| cells_dark_area(poly, bb, Vector2::new(c[0].x, c[0].y), g.cell_m(), n, |x, y| g.is_dark(x, y) == Some(true)))
        .sum();
    squares + tags
}

/// Area of `poly` (bounding box `lo..hi`) on the dark cells of the `n x n` grid of `cell`-wide
/// cells from `origin`, a cell's colour `dark` at its centre.
fn cells_dark_area(
    poly: &[Vector2<f64>],
    (lo, hi): (Vector2<f64>, Vector2<f64>),
    origin: Vector2<f64>,
    cell: f64,
    n: u32,
    dark: impl Fn(f64, f64) -> bool,
) -> f64 {
    let range = |lo: f64, hi: f64| (((lo / cell).floor().max(0.0) as u32).min(n), ((hi / cell).floor().max(0.0) as u32).min(n - 1));
    let (cx0, cx1) = range(lo.x - origin.x, hi.x - origin.x);
    let (cy0, cy1) = range(lo.y - origin.y, hi.y - origin.y);
    if hi.x < origin.x || hi.y < origin.y {
        return 0.0;
    }
    let mut area = 0.0;
    for cy in cy0..=cy1 {
        for cx in cx0..=cx1 {
            let c_lo = origin + Vector2::new(f64::from(cx), f64::from(cy)) * cell;
            let mid = c_lo + Vector2::repeat(0.5 * cell);
            if dark(mid.x, mid.y) {
                area += polygon::area(&polygon::clip_rect(poly, c_lo, c_lo + Vector2::repeat(cell)));
            }
        }
    }
    area
}

/// Cells `i` with `[i s, (i + 1) s]` meeting `[lo, hi]`, clamped to `0..n`.
fn cell_range(lo: f64, hi: f64, s: f64, n: u32) -> (u32, u32) {
    let last = f64::from(n - 1);
    ((lo / s).floor().clamp(0.0, last) as u32, (hi / s).floor().clamp(0.0, last) as u32)
}

/// Integral of the dot grid's grey over `quad` (area `a`).
fn dot_grid_sum(g: &DotGrid, quad: &[Vector2<f64>], a: f64) -> f64 {
    let half = 0.5 * g.edge_m;
    let outer = half + g.margin_m;
    let plate = polygon::clip_rect(quad, Vector2::new(-outer, -outer), Vector2::new(outer, outer));
    let a_plate = polygon::area(&plate);
    let mut dark = 0.0;
    if let Some((lo, hi)) = polygon::bbox(&plate) {
        let p = g.pitch_m();
        let r = g.dot_radius_m;
        let last = f64::from(g.n - 1);
        let range = |lo: f64, hi: f64| (((lo + half - r) / p).ceil().clamp(0.0, last) as u32, ((hi + half + r) / p).floor().clamp(0.0, last) as u32);
        let (i0, i1) = range(lo.x, hi.x);
        let (j0, j1) = range(lo.y, hi.y);
        for j in j0..=j1 {
            for i in i0..=i1 {
                let c = Vector2::new(-half + p * f64::from(i), -half + p * f64::from(j));
                dark += polygon::disc_area(&plate, c, r);
            }
        }
    }
    g.background * (a - a_plate) + g.light * (a_plate - dark) + g.dark * dark
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::RenderSettings;
    use nalgebra::{Isometry3, Translation3, UnitQuaternion};
    use synthcam_core::camera::{CameraModel, ImageSize, Intrinsics, Lens};

    fn fronto_scene(target: Target, centre_m: [f64; 2], f: f64) -> Scene {
        let camera = CameraModel {
            size: ImageSize { width: 16, height: 16 },
            intrinsics: Intrinsics { fx: f, fy: f, cx: 7.0, cy: 7.0, skew: 0.0 },
            lens: Lens::default(),
        };
        let t = Translation3::new(-centre_m[0], -centre_m[1], 1.0);
        Scene {
            camera,
            target,
            cam_from_target: Isometry3::from_parts(t, UnitQuaternion::identity()),
            render: RenderSettings::default(),
            objects: Vec::new(),
            background: None,
        }
    }

    #[test]
    fn fronto_parallel_chessboard_corner_is_the_box_filter() {
        // 1 px = 1 mm on the plane at 1 m with f = 1000. The board's corner (s, s) of its first
        // squares sits 0.3 mm right and 0.2 mm below pixel (7, 7)'s centre.
        let b = Chessboard { squares: [4, 4], square_m: 0.01, margin_m: 0.005, ..Default::default() };
        let scene = fronto_scene(Target::Chessboard(b), [0.01 - 0.0003, 0.01 - 0.0002], 1000.0);
        let img = render_exact_planar(&scene, 2).expect("planar");
        let v = img[7 * 16 + 7].expect("defined");
        // Quadrants of pixel (7,7): x split at 0.8 (left part 0.8), y at 0.7 (top part 0.7).
        // Cells: top-left (0,0) dark, top-right (1,0) light, bottom-left (0,1) light, bottom-right (1,1) dark.
        let expect = b.dark * (0.8 * 0.7 + 0.2 * 0.3) + b.light * (0.2 * 0.7 + 0.8 * 0.3);
        assert!((v - expect).abs() < 1e-9, "{v} vs {expect}");
    }

    #[test]
    fn fronto_parallel_dot_grid_pixel_is_the_disc_share() {
        // A dot of radius 5 mm = 5 px; pixel (7, 7) at 4.6 px from its centre (x only) holds a
        // segment of the disc: the area with x > 4.1 of the circle of radius 5 between y = -0.5 and 0.5.
        let g = DotGrid { n: 2, edge_m: 0.05, dot_radius_m: 0.005, margin_m: 0.01, ..Default::default() };
        let scene = fronto_scene(Target::DotGrid(g), [-0.025 + 0.0046, -0.025], 1000.0);
        let img = render_exact_planar(&scene, 1).expect("planar");
        let v = img[7 * 16 + 7].expect("defined");
        // Midpoint integral of the disc's chord extent, 20 000 strips.
        let n = 20_000;
        let share: f64 = (0..n)
            .map(|k| {
                let y = -0.5 + (f64::from(k) + 0.5) / f64::from(n);
                ((25.0 - y * y).sqrt() - 4.1).clamp(0.0, 1.0) / f64::from(n)
            })
            .sum();
        let expect = g.dark * share + g.light * (1.0 - share);
        assert!((v - expect).abs() < 1e-6, "{v} vs {expect}");
    }

    #[test]
    fn refuses_the_s_path_and_silly_subdivisions() {
        let b = Chessboard::default();
        let scene = fronto_scene(Target::Chessboard(b), [0.0, 0.0], 1000.0);
        assert!(render_exact_planar(&scene, 0).is_err());
        assert!(render_exact_planar(&scene, 65).is_err());
    }
}
