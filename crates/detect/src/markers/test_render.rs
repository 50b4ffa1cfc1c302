//! Test-only CPU renderer of a marker target (ChArUco board, AprilGrid) through a pinhole camera
//! with radial k1 distortion: each pixel is the mean of n x n sub-samples of its square (OpenCV
//! convention: pixel (x, y) centred at (x, y)) of the target's colouring (`is_dark`), each
//! sub-sample mapped to the target by undistorting (fixed-point iteration) and intersecting its
//! ray with the target plane. The colouring is constant on the rectangles between the target's
//! edge lines (squares, marker cells, gaps, the white border), so it is tabulated per rectangle
//! (from `is_dark` at the rectangle's centre) and pixels whose footprint stays in rectangles of
//! one colour take a single sample.

use nalgebra::{Point2, Point3, Rotation3, Vector3};
use rayon::prelude::*;

use crate::ImageF32;
use synthcam_core::target::{AprilGrid, Charuco};

/// A planar target the renderer can draw.
pub trait Pattern: Sync {
    /// The edge lines of the colouring along x and along y, metres (any order, duplicates
    /// allowed), the outermost ones bounding the target.
    fn lines(&self) -> (Vec<f64>, Vec<f64>);
    /// Whether target point `(x, y)` is dark (`None` off the target).
    fn is_dark(&self, x: f64, y: f64) -> Option<bool>;
    /// Width of the white border drawn around the target, metres.
    fn border_m(&self) -> f64;
    /// Whether the target frame's z points towards the viewer (the camera is turned to face it).
    fn z_towards_viewer(&self) -> bool;
}

impl Pattern for Charuco {
    fn lines(&self) -> (Vec<f64>, Vec<f64>) {
        let s = self.square_m;
        let cells = self.dictionary.marker_bits() + 2;
        let cell = self.marker_m / cells as f64;
        let inset = 0.5 * (s - self.marker_m);
        let lines = |n: u32| {
            let mut v = Vec::new();
            for i in 0..=n {
                v.push(f64::from(i) * s);
                if i < n {
                    v.extend((0..=cells).map(|k| f64::from(i) * s + inset + k as f64 * cell));
                }
            }
            v
        };
        (lines(self.squares[0]), lines(self.squares[1]))
    }
    fn is_dark(&self, x: f64, y: f64) -> Option<bool> {
        Charuco::is_dark(self, x, y)
    }
    fn border_m(&self) -> f64 {
        0.6 * self.square_m
    }
    fn z_towards_viewer(&self) -> bool {
        false
    }
}

impl Pattern for AprilGrid {
    fn lines(&self) -> (Vec<f64>, Vec<f64>) {
        let (p, g, cell) = ((1.0 + self.spacing) * self.tag_m, self.spacing * self.tag_m, self.cell_m());
        let cells = self.family.marker_bits() + 2 * self.border_bits as usize;
        let lines = |n: u32| {
            let mut v = vec![f64::from(n) * p];
            for i in 0..n {
                v.push(f64::from(i) * p - g);
                v.extend((0..=cells).map(|k| f64::from(i) * p + k as f64 * cell));
            }
            v
        };
        (lines(self.tags[0]), lines(self.tags[1]))
    }
    fn is_dark(&self, x: f64, y: f64) -> Option<bool> {
        AprilGrid::is_dark(self, x, y)
    }
    fn border_m(&self) -> f64 {
        0.5 * self.tag_m
    }
    fn z_towards_viewer(&self) -> bool {
        true
    }
}

/// Light and dark grey, and the background beyond the board's white border.
pub const LIGHT: f64 = 235.0;
/// Dark grey.
pub const DARK: f64 = 20.0;
/// Off-board background.
pub const BACKGROUND: f64 = 128.0;

/// Pinhole camera with k1 radial distortion looking at a target: target point X maps to the
/// camera point R X + t.
#[derive(Debug, Clone, Copy)]
pub struct Camera {
    /// Focal length, pixels.
    pub f: f64,
    /// Principal point, pixels.
    pub c: [f64; 2],
    /// Radial distortion x_d = x (1 + k1 r^2).
    pub k1: f64,
    /// Board to camera rotation.
    pub r: Rotation3<f64>,
    /// Board to camera translation, metres.
    pub t: Vector3<f64>,
}

impl Camera {
    /// A camera of focal `f` for a `w x h` image, with the target's centre at `(ox, oy, dist)` in
    /// the camera frame, rotated by roll (about the optical axis) and tilts about x and y
    /// (radians); a target whose z points towards the viewer is first turned by 180 degrees about
    /// x, so that the camera sees its printed side.
    pub fn looking_at(target: &impl Pattern, size: (usize, usize), f: f64, at: (f64, f64, f64), angles: (f64, f64, f64)) -> Self {
        Self::facing(target, size, f, at, angles, target.z_towards_viewer())
    }

    /// As [`Self::looking_at`], turning the target about x by 180 degrees when `flip` (without it
    /// a target whose z points towards the viewer is seen from behind: mirrored).
    pub fn facing(target: &impl Pattern, (w, h): (usize, usize), f: f64, (ox, oy, dist): (f64, f64, f64), (roll, tx, ty): (f64, f64, f64), flip: bool) -> Self {
        let r = Rotation3::from_axis_angle(&Vector3::z_axis(), roll)
            * Rotation3::from_axis_angle(&Vector3::x_axis(), tx)
            * Rotation3::from_axis_angle(&Vector3::y_axis(), ty)
            * Rotation3::from_axis_angle(&Vector3::x_axis(), if flip { std::f64::consts::PI } else { 0.0 });
        let (xs, ys) = target.lines();
        let mid = |v: &[f64]| 0.5 * (v.iter().copied().fold(f64::INFINITY, f64::min) + v.iter().copied().fold(f64::NEG_INFINITY, f64::max));
        let centre = Vector3::new(mid(&xs), mid(&ys), 0.0);
        let t = Vector3::new(ox, oy, dist) - r * centre;
        Self { f, c: [0.5 * w as f64 - 0.5, 0.5 * h as f64 - 0.5], k1: 0.0, r, t }
    }

    /// Image of a board point.
    pub fn project(&self, p: Point3<f64>) -> Point2<f64> {
        let q = self.r * p.coords + self.t;
        let (x, y) = (q.x / q.z, q.y / q.z);
        let d = 1.0 + self.k1 * (x * x + y * y);
        Point2::new(self.f * x * d + self.c[0], self.f * y * d + self.c[1])
    }

    /// Board point `(x, y)` seen at pixel position `(u, v)`; `None` when the ray misses the plane.
    pub fn board_point_at(&self, u: f64, v: f64) -> Option<(f64, f64)> {
        let (xd, yd) = ((u - self.c[0]) / self.f, (v - self.c[1]) / self.f);
        let (mut x, mut y) = (xd, yd);
        if self.k1 != 0.0 {
            for _ in 0..30 {
                let d = 1.0 + self.k1 * (x * x + y * y);
                (x, y) = (xd / d, yd / d);
            }
        }
        let ray = Vector3::new(x, y, 1.0);
        let n = self.r * Vector3::z();
        let den = n.dot(&ray);
        if den.abs() < 1e-12 {
            return None;
        }
        let s = n.dot(&self.t) / den;
        if !(s > 0.0) {
            return None;
        }
        let b = self.r.inverse() * (ray * s - self.t);
        Some((b.x, b.y))
    }
}

/// The board's colouring, tabulated between its edge lines.
pub struct Colouring {
    xs: Vec<f64>,
    ys: Vec<f64>,
    grey: Vec<f64>,
}

impl Colouring {
    /// Tabulate `target` with its white border around it.
    pub fn new(target: &impl Pattern) -> Self {
        let border_m = target.border_m();
        let with_border = |mut v: Vec<f64>| {
            let (lo, hi) = v.iter().fold((f64::INFINITY, f64::NEG_INFINITY), |(l, h), x| (l.min(*x), h.max(*x)));
            v.extend([lo - border_m, hi + border_m]);
            v.sort_by(f64::total_cmp);
            v.dedup_by(|a, b| (*a - *b).abs() < 1e-12);
            v
        };
        let (xs, ys) = target.lines();
        let (xs, ys) = (with_border(xs), with_border(ys));
        let mut grey = Vec::with_capacity((xs.len() + 1) * (ys.len() + 1));
        let mid = |v: &[f64], k: usize| {
            if k == 0 {
                v[0] - 1.0
            } else if k == v.len() {
                v[k - 1] + 1.0
            } else {
                0.5 * (v[k - 1] + v[k])
            }
        };
        for j in 0..=ys.len() {
            for i in 0..=xs.len() {
                let (x, y) = (mid(&xs, i), mid(&ys, j));
                let inside_border = i > 0 && j > 0 && i < xs.len() && j < ys.len();
                grey.push(match target.is_dark(x, y) {
                    Some(true) => DARK,
                    Some(false) => LIGHT,
                    None if inside_border => LIGHT,
                    None => BACKGROUND,
                });
            }
        }
        Self { xs, ys, grey }
    }

    /// Rectangle indices of a board point.
    fn cell(&self, x: f64, y: f64) -> (usize, usize) {
        (self.xs.partition_point(|&l| l <= x), self.ys.partition_point(|&l| l <= y))
    }

    fn grey_at(&self, (i, j): (usize, usize)) -> f64 {
        self.grey[j * (self.xs.len() + 1) + i]
    }
}

/// Render `target` seen by `cam` into a `w x h` image, `n x n` sub-samples per pixel where the
/// colour changes inside it.
pub fn render(target: &impl Pattern, cam: &Camera, (w, h): (usize, usize), n: usize) -> ImageF32 {
    let col = Colouring::new(target);
    let grey = |u: f64, v: f64| cam.board_point_at(u, v).map_or(BACKGROUND, |(x, y)| col.grey_at(col.cell(x, y)));
    let pixel = |x: usize, y: usize| -> f32 {
        let (x, y) = (x as f64, y as f64);
        // the rectangles under the pixel's corners (and centre); one colour -> one sample
        let probe = [(-0.5, -0.5), (0.5, -0.5), (-0.5, 0.5), (0.5, 0.5)];
        let cells: Option<Vec<(usize, usize)>> = probe.iter().map(|(dx, dy)| cam.board_point_at(x + dx, y + dy).map(|(bx, by)| col.cell(bx, by))).collect();
        if let Some(c) = cells {
            let (i0, i1) = (c.iter().map(|c| c.0).min().unwrap_or(0), c.iter().map(|c| c.0).max().unwrap_or(0));
            let (j0, j1) = (c.iter().map(|c| c.1).min().unwrap_or(0), c.iter().map(|c| c.1).max().unwrap_or(0));
            // one rectangle wider: lens distortion bends the footprint's sides slightly
            let (i0, j0) = (i0.saturating_sub(1), j0.saturating_sub(1));
            let (i1, j1) = ((i1 + 1).min(col.xs.len()), (j1 + 1).min(col.ys.len()));
            let g0 = col.grey_at((i0, j0));
            if (j0..=j1).all(|j| (i0..=i1).all(|i| col.grey_at((i, j)) == g0)) {
                return g0 as f32;
            }
        }
        let mut sum = 0.0;
        for j in 0..n {
            for i in 0..n {
                sum += grey(x - 0.5 + (i as f64 + 0.5) / n as f64, y - 0.5 + (j as f64 + 0.5) / n as f64);
            }
        }
        (sum / (n * n) as f64) as f32
    };
    let mut data = vec![0.0f32; w * h];
    data.par_chunks_mut(w).enumerate().for_each(|(y, row)| row.iter_mut().enumerate().for_each(|(x, o)| *o = pixel(x, y)));
    ImageF32 { width: w, height: h, data }
}

/// Render two boards (each with its camera) into one image: a pixel shows the first board
/// whose white border it hits, else the background.
pub fn render_two<P: Pattern>(boards: [(&P, &Camera); 2], (w, h): (usize, usize), n: usize) -> ImageF32 {
    let a = render(boards[0].0, boards[0].1, (w, h), n);
    let b = render(boards[1].0, boards[1].1, (w, h), n);
    let data = a.data.iter().zip(&b.data).map(|(x, y)| if *x as f64 == BACKGROUND { *y } else { *x }).collect();
    ImageF32 { width: w, height: h, data }
}
