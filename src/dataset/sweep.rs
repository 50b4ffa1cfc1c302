//! The course's calibration study (course-scenario 1.3 / 3.3): how the number of views M and of
//! target points N x N change the error of the intrinsics, with ideal projections plus Gaussian
//! noise (the course's method) and with rendered images detected by synthcam's detector.
//!
//! Views: a rotation of uniform angle in [0, pi/10] about a uniform random axis and a camera
//! position (x, y) uniform in [-0.4, 0.4] m, z uniform in [-6, -3] m in the target frame, looking
//! along its own +z at the 0.4 m target; re-drawn until every point is in the image. Camera: the
//! course's (1280 x 1024, f = 1500 px, no distortion); calibration with distortion fixed at 0.

use nalgebra::{Isometry3, Point2, Point3, Translation3, UnitQuaternion, Vector3};
use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;
use rand_distr::{Distribution, Normal};

use crate::calib::{calibrate, CalibParams, View};
use crate::camera::CameraModel;
use crate::detect::target::{detect, TargetSpec};
use crate::detect::ImageF32;
use crate::render::Renderer;
use crate::scene::{RenderSettings, Scene};
use crate::target::{Chessboard, Target};

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

/// `cam_from_target` of one course calibration view (the target centred at its origin).
pub fn course_pose(rng: &mut ChaCha8Rng) -> Isometry3<f64> {
    let n = Normal::new(0.0, 1.0).unwrap_or_else(|_| unreachable!());
    let axis = nalgebra::Unit::new_normalize(Vector3::new(n.sample(rng), n.sample(rng), n.sample(rng)));
    let rot = UnitQuaternion::from_axis_angle(&axis, rng.random_range(0.0..std::f64::consts::PI / 10.0));
    let p = Vector3::new(rng.random_range(-0.4..0.4), rng.random_range(-0.4..0.4), rng.random_range(-6.0..-3.0));
    Isometry3::from_parts(Translation3::from(p), rot).inverse()
}

/// The N x N target points (x slow, y fast) over 0.4 m, centred.
fn grid_points(n: usize) -> Vec<Point3<f64>> {
    let s = 0.4 / (n - 1) as f64;
    (0..n).flat_map(|i| (0..n).map(move |j| Point3::new(-0.2 + s * i as f64, -0.2 + s * j as f64, 0.0))).collect()
}

/// Run the sweep for one mode: for each N and seed a pool of max(M) views, calibrated on its
/// first M views for every M.
pub fn run_sweep(mode: SweepMode, ms: &[usize], ns: &[usize], seeds: u64, renderer: Option<&Renderer>) -> Vec<SweepRun> {
    let cam = CameraModel::course_default();
    let m_max = ms.iter().copied().max().unwrap_or(0);
    let mut out = Vec::new();
    for &n in ns {
        for seed in 0..seeds {
            let mut rng = ChaCha8Rng::seed_from_u64(1000 * n as u64 + seed);
            let pts = grid_points(n);
            let mut pool: Vec<View> = Vec::new();
            let mut attempts = 0;
            while pool.len() < m_max && attempts < 50 * m_max {
                attempts += 1;
                let pose = course_pose(&mut rng);
                let proj: Vec<_> = pts.iter().map(|p| cam.project(&(pose * p))).collect();
                if !proj.iter().all(|p| p.visible()) {
                    continue;
                }
                match mode {
                    SweepMode::Ideal => {
                        let noise = Normal::new(0.0, 0.5).unwrap_or_else(|_| unreachable!());
                        pool.push(
                            pts.iter()
                                .zip(&proj)
                                .map(|(p, q)| (*p, q.pixel_px + nalgebra::Vector2::new(noise.sample(&mut rng), noise.sample(&mut rng))))
                                .collect(),
                        );
                    }
                    SweepMode::Rendered => {
                        let Some(r) = renderer else { return out };
                        // A chessboard whose N x N inner corners are the grid points.
                        let s = 0.4 / (n - 1) as f64;
                        let board = Chessboard { squares: [n as u32 + 1, n as u32 + 1], square_m: s, margin_m: 0.5 * s, ..Default::default() };
                        let shift = Translation3::new(-0.2 - s, -0.2 - s, 0.0);
                        let scene = Scene {
                            camera: cam,
                            target: Target::Chessboard(board),
                            cam_from_target: pose * Isometry3::from_parts(shift, UnitQuaternion::identity()),
                            render: RenderSettings { noise_sigma: 1.0, seed: rng.random(), ..Default::default() },
                        };
                        let Ok(img) = r.render(&scene) else { continue };
                        let Ok(grey) = ImageF32::from_u8(1280, 1024, &img.to_u8()) else { continue };
                        let Ok(det) = detect(&grey, &TargetSpec::Chessboard { cols: n, rows: n }) else { continue };
                        if !det.found {
                            continue;
                        }
                        // The detector's own order (row-major, no mirror): board point (k % n, k / n).
                        let view: View = det
                            .points_px
                            .iter()
                            .enumerate()
                            .map(|(k, q)| (Point3::new(s * (k % n) as f64, s * (k / n) as f64, 0.0), Point2::new(q.x, q.y)))
                            .collect();
                        pool.push(view);
                    }
                }
            }
            for &m in ms {
                if pool.len() < m {
                    continue;
                }
                let params = CalibParams { fix_distortion: [true; 5], ..Default::default() };
                let Ok(r) = calibrate(&pool[..m], cam.size, &params) else { continue };
                let (k, kt) = (r.camera.intrinsics, cam.intrinsics);
                let pct = |a: f64, b: f64| 100.0 * (a - b).abs() / b;
                out.push(SweepRun { mode, m, n, seed, err_pct: [pct(k.fx, kt.fx), pct(k.fy, kt.fy), pct(k.cx, kt.cx), pct(k.cy, kt.cy)], rms_px: r.rms_px });
            }
        }
    }
    out
}

/// Mean and standard deviation.
fn mean_std(v: &[f64]) -> (f64, f64) {
    let n = v.len().max(1) as f64;
    let m = v.iter().sum::<f64>() / n;
    (m, (v.iter().map(|x| (x - m).powi(2)).sum::<f64>() / n).sqrt())
}

/// Markdown table: one row per (mode, M, N), mean +- std over seeds.
pub fn markdown(runs: &[SweepRun], ms: &[usize], ns: &[usize]) -> String {
    let mut s = String::from("| mode | M | N | %e fx | %e fy | %e cx | %e cy | RMS px | runs |\n|---|---|---|---|---|---|---|---|---|\n");
    for mode in [SweepMode::Ideal, SweepMode::Rendered] {
        for &m in ms {
            for &n in ns {
                let sel: Vec<&SweepRun> = runs.iter().filter(|r| r.mode == mode && r.m == m && r.n == n).collect();
                if sel.is_empty() {
                    continue;
                }
                let cell = |f: &dyn Fn(&SweepRun) -> f64| {
                    let (a, b) = mean_std(&sel.iter().map(|r| f(r)).collect::<Vec<_>>());
                    format!("{a:.3} +- {b:.3}")
                };
                s += &format!(
                    "| {} | {m} | {n} | {} | {} | {} | {} | {} | {} |\n",
                    if mode == SweepMode::Ideal { "ideal + 0.5 px" } else { "rendered + detected" },
                    cell(&|r| r.err_pct[0]),
                    cell(&|r| r.err_pct[1]),
                    cell(&|r| r.err_pct[2]),
                    cell(&|r| r.err_pct[3]),
                    cell(&|r| r.rms_px),
                    sel.len()
                );
            }
        }
    }
    s
}

/// CSV: one line per calibration.
pub fn csv(runs: &[SweepRun]) -> String {
    let mut s = String::from("mode,M,N,seed,err_fx_pct,err_fy_pct,err_cx_pct,err_cy_pct,rms_px\n");
    for r in runs {
        s += &format!(
            "{},{},{},{},{:.6},{:.6},{:.6},{:.6},{:.6}\n",
            if r.mode == SweepMode::Ideal { "ideal" } else { "rendered" },
            r.m,
            r.n,
            r.seed,
            r.err_pct[0],
            r.err_pct[1],
            r.err_pct[2],
            r.err_pct[3],
            r.rms_px
        );
    }
    s
}

/// The sweep as a PNG: mean % error of fx against M (log-log), one line per N, one panel per mode.
///
/// # Errors
/// PNG encoding.
pub fn plot_png(runs: &[SweepRun], ms: &[usize], ns: &[usize]) -> Result<Vec<u8>, super::DatasetError> {
    use super::plot::{canvas, png, text, Panel, PALETTE};
    let mut img = canvas(1100, 520);
    let (ylo, yhi) = (-3.0f64, 2.0f64);
    let xt: Vec<(f64, String)> = ms.iter().map(|m| ((*m as f64).log10(), m.to_string())).collect();
    let yt: Vec<(f64, String)> = (-3..=2).map(|e| (f64::from(e), format!("{}", 10f64.powi(e)))).collect();
    let xr = ((ms[0] as f64).log10() - 0.1, (ms[ms.len() - 1] as f64).log10() + 0.1);
    for (k, (mode, name)) in [(SweepMode::Ideal, "ideal + 0.5 px noise"), (SweepMode::Rendered, "rendered + detected")].into_iter().enumerate() {
        let panel = Panel { rect: (90 + 520 * k as i32, 50, 420, 380), x: xr, y: (ylo, yhi) };
        panel.axes(&mut img, name, "views M", "% err fx", &xt, &yt);
        for (j, &n) in ns.iter().enumerate() {
            let pts: Vec<(f64, f64)> = ms
                .iter()
                .filter_map(|&m| {
                    let v: Vec<f64> = runs.iter().filter(|r| r.mode == mode && r.m == m && r.n == n).map(|r| r.err_pct[0]).collect();
                    (!v.is_empty()).then(|| ((m as f64).log10(), (v.iter().sum::<f64>() / v.len() as f64).max(1e-3).log10().clamp(ylo, yhi)))
                })
                .collect();
            panel.line(&mut img, &pts, PALETTE[j % PALETTE.len()]);
            text(&mut img, 90 + 520 * k as i32 + 330, 60 + 14 * j as i32, &format!("N = {n}"), PALETTE[j % PALETTE.len()], 1);
        }
    }
    png(&img)
}
