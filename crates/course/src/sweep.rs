//! The course's calibration study (course-scenario 1.3 / 3.3): how the number of views M and of
//! target points N x N change the error of the intrinsics, with ideal projections plus Gaussian
//! noise (the course's method) and with rendered images detected by synthcam's detector.
//!
//! Views: a rotation of uniform angle in [0, pi/10] about a uniform random axis and a camera
//! position (x, y) uniform in [-0.4, 0.4] m, z uniform in [-6, -3] m in the target frame, looking
//! along its own +z at the 0.4 m target; re-drawn until every point is in the image. Camera: the
//! course's (1280 x 1024, f = 1500 px, no distortion), calibration with distortion fixed at 0; or
//! any camera and lens model ([`SweepSetup`], `experiment calib-sweep --camera --model`).

use nalgebra::{Isometry3, Point2, Point3, Translation3, UnitQuaternion};
use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;
use rand_distr::{Distribution, Normal};

use synthcam_core::camera::CameraModel;
use synthcam_core::target::{Chessboard, Target};
use synthcam_detect::target::{detect, TargetSpec};
use synthcam_detect::ImageF32;
use synthcam_geometry::calib::{calibrate, CalibModel, CalibParams, View};
use synthcam_render::Renderer;
use synthcam_scene::{RenderSettings, Scene};

/// How the observations are made.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum SweepMode {
    /// Ideal projections plus N(0, 0.5^2) px noise (the course's method).
    Ideal,
    /// Rendered chessboard (N x N inner corners over 0.4 m), noise 1 grey level, detected.
    Rendered,
}

/// One calibration of the sweep.
#[derive(Debug, Clone, PartialEq)]
pub struct SweepRun {
    /// Mode.
    pub mode: SweepMode,
    /// Views.
    pub m: usize,
    /// Points per side.
    pub n: usize,
    /// Seed.
    pub seed: u64,
    /// Percent errors of fx, fy, cx, cy.
    pub err_pct: [f64; 4],
    /// Reprojection RMS, px.
    pub rms_px: f64,
}

/// The camera of a sweep and the model its calibrations estimate.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct SweepSetup {
    /// The camera the views are made with.
    pub camera: CameraModel,
    /// The lens model estimated; `None`: the course's study (pinhole, distortion fixed at 0).
    pub model: Option<CalibModel>,
}

impl Default for SweepSetup {
    fn default() -> Self {
        Self { camera: CameraModel::sxga_1500px(), model: None }
    }
}

impl SweepSetup {
    fn params(&self) -> CalibParams {
        match self.model {
            Some(model) => CalibParams { model, ..Default::default() },
            None => CalibParams { fix_distortion: [true; synthcam_core::camera::MAX_LENS_PARAMS], ..Default::default() },
        }
    }
}

/// The N x N target points (x slow, y fast) over 0.4 m, centred.
fn grid_points(n: usize) -> Vec<Point3<f64>> {
    let s = 0.4 / (n - 1) as f64;
    (0..n).flat_map(|i| (0..n).map(move |j| Point3::new(-0.2 + s * i as f64, -0.2 + s * j as f64, 0.0))).collect()
}

/// Run the sweep for one mode: for each N and seed a pool of max(M) views, calibrated on its
/// first M views for every M.
///
/// # Errors
/// No M or N values, an N below 2 (a grid needs two points per side) or an M below 3 (Zhang's
/// method needs three views).
pub fn run_sweep(mode: SweepMode, ms: &[usize], ns: &[usize], seeds: u64, renderer: Option<&Renderer>) -> Result<Vec<SweepRun>, super::SimError> {
    run_sweep_with(&SweepSetup::default(), mode, ms, ns, seeds, renderer, &mut |_, _| {})
}

/// [`run_sweep`] with another camera and lens model, calling `progress(done, total)` after each
/// (N, seed) pool is calibrated (`total` = N values x seeds).
///
/// # Errors
/// As [`run_sweep`], and an invalid camera.
pub fn run_sweep_with(
    setup: &SweepSetup,
    mode: SweepMode,
    ms: &[usize],
    ns: &[usize],
    seeds: u64,
    renderer: Option<&Renderer>,
    progress: &mut dyn FnMut(usize, usize),
) -> Result<Vec<SweepRun>, super::SimError> {
    if ms.is_empty() || ns.is_empty() || ns.iter().any(|n| *n < 2) || ms.iter().any(|m| *m < 3) {
        return Err(super::SimError::Scenario(format!("the sweep needs M >= 3 and N >= 2 values, got M {ms:?}, N {ns:?}")));
    }
    let cam = setup.camera;
    cam.validate().map_err(|e| super::SimError::Scenario(format!("sweep camera: {e}")))?;
    let m_max = ms.iter().copied().max().unwrap_or(0);
    let (mut out, total) = (Vec::new(), ns.len() * seeds as usize);
    for (ni, &n) in ns.iter().enumerate() {
        for seed in 0..seeds {
            let pool = view_pool(&cam, mode, n, seed, m_max, renderer)?;
            for &m in ms {
                if pool.len() < m {
                    continue;
                }
                let Ok(r) = calibrate(&pool[..m], cam.size, &setup.params()) else { continue };
                let (k, kt) = (r.camera.intrinsics, cam.intrinsics);
                let pct = |a: f64, b: f64| 100.0 * (a - b).abs() / b;
                out.push(SweepRun { mode, m, n, seed, err_pct: [pct(k.fx, kt.fx), pct(k.fy, kt.fy), pct(k.cx, kt.cx), pct(k.cy, kt.cy)], rms_px: r.rms_px });
            }
            progress(ni * seeds as usize + seed as usize + 1, total);
        }
    }
    Ok(out)
}

/// Up to `m_max` views of the N x N grid for one seed (fewer when views keep failing).
fn view_pool(cam: &CameraModel, mode: SweepMode, n: usize, seed: u64, m_max: usize, renderer: Option<&Renderer>) -> Result<Vec<View>, super::SimError> {
    let cam = *cam;
    let mut rng = ChaCha8Rng::seed_from_u64(1000 * n as u64 + seed);
    let pts = grid_points(n);
    let mut pool: Vec<View> = Vec::new();
    let mut attempts = 0;
    while pool.len() < m_max && attempts < 50 * m_max {
        attempts += 1;
        let pose = crate::calibration_pose(&mut rng);
        let proj: Vec<_> = pts.iter().map(|p| cam.project(&(pose * p))).collect();
        if !proj.iter().all(|p| p.visible()) {
            continue;
        }
        match mode {
            SweepMode::Ideal => {
                let noise = Normal::new(0.0, 0.5).unwrap_or_else(|_| unreachable!());
                pool.push(
                    pts.iter().zip(&proj).map(|(p, q)| (*p, q.pixel_px + nalgebra::Vector2::new(noise.sample(&mut rng), noise.sample(&mut rng)))).collect(),
                );
            }
            SweepMode::Rendered => {
                let Some(r) = renderer else { return Err(super::SimError::Scenario("the rendered sweep needs a renderer".into())) };
                // A chessboard whose N x N inner corners are the grid points.
                let s = 0.4 / (n - 1) as f64;
                let board = Chessboard { squares: [n as u32 + 1, n as u32 + 1], square_m: s, margin_m: 0.5 * s, ..Default::default() };
                let scene = Scene {
                    camera: cam,
                    target: Target::Chessboard(board),
                    cam_from_target: pose * Isometry3::from_parts(Translation3::new(-0.2 - s, -0.2 - s, 0.0), UnitQuaternion::identity()),
                    render: RenderSettings { noise_sigma: 1.0, seed: rng.random(), ..Default::default() },
                    objects: Vec::new(),
                    background: None,
                };
                let Ok(img) = r.render(&scene) else { continue };
                let Ok(grey) = ImageF32::from_u8(cam.size.width as usize, cam.size.height as usize, &img.to_u8()) else { continue };
                let Ok(det) = detect(&grey, &TargetSpec::Chessboard { cols: n, rows: n }) else { continue };
                if !det.found {
                    continue;
                }
                // The detector's own order (row-major, no mirror): board point (k % n, k / n).
                let view: View =
                    det.points_px.iter().enumerate().map(|(k, q)| (Point3::new(s * (k % n) as f64, s * (k / n) as f64, 0.0), Point2::new(q.x, q.y))).collect();
                pool.push(view);
            }
        }
    }
    Ok(pool)
}
