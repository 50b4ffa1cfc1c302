//! The views a pixel integrates: one per sample of the exposure time and of the aperture, and
//! under a rolling shutter one set per row ([`super::motion`], [`synthcam_core::camera::optics`]).
//!
//! A view is a pinhole at an aperture point `a` (camera frame at the view's time, z = 0) whose
//! rays pass through the focus plane where the central pinhole's do: the ray of direction `d`
//! becomes `F d - a d_z` from `a` (`F` the focus distance). Exposure time and aperture are
//! sampled together (distributed ray tracing, Cook et al. 1984): `n = max(time, aperture)`
//! samples, time strata and ring aperture points (`ThinLens::aperture_points_m`) paired by a
//! rank-1 lattice permutation so that both are stratified and uncorrelated.

use nalgebra::{Isometry3, Matrix3, Vector3};

use super::effect_truth::pixel_at;
use super::Scene;
use synthcam_core::camera::optics::{samples_for_coc, ThinLens};

/// One view: the target's pose in the camera at the view's time and the aperture point.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct ExposureView {
    /// `cam(t)_from_target(t)` at the view's time.
    pub cam_from_target: Isometry3<f64>,
    /// Aperture point in the camera frame (x, y; z = 0), metres.
    pub aperture_m: [f64; 2],
    /// Focus distance, metres; `None`: a pinhole (the aperture point is 0).
    pub focus_m: Option<f64>,
}

impl ExposureView {
    /// The aperture point: the origin of this view's rays (camera frame at the view's time).
    pub fn aperture(&self) -> Vector3<f64> {
        Vector3::new(self.aperture_m[0], self.aperture_m[1], 0.0)
    }

    /// The linear map from a pinhole ray direction `d` to this view's ray direction from
    /// [`ExposureView::aperture`]: `F I - a e_z^T` (the ray `F d - a d_z` passes the focus plane where
    /// the pinhole's does); `None` for a pinhole view (the identity).
    pub fn direction_map(&self) -> Option<Matrix3<f64>> {
        self.focus_m.map(|f| Matrix3::identity() * f - self.aperture() * Vector3::z().transpose())
    }
}

/// The views of every pixel.
#[derive(Debug, Clone, PartialEq)]
pub struct ViewSet {
    /// Views per pixel.
    pub samples: u32,
    /// Whether each row has its own views (rolling shutter); else all rows share one set.
    pub per_row: bool,
    /// `samples` views per row (or one set), row-major.
    pub views: Vec<ExposureView>,
}

impl ViewSet {
    /// The views of row `y`.
    pub fn row(&self, y: u32) -> &[ExposureView] {
        let n = self.samples as usize;
        let start = if self.per_row { y as usize * n } else { 0 };
        self.views.get(start..start + n).unwrap_or(&[])
    }
}

/// Most image motion (pixels) of the target's features over the exposure, at row time 0.
fn motion_px(scene: &Scene) -> f64 {
    let half = 0.5 * scene.render.effects.motion.exposure_s;
    scene.target.feature_points_m().iter().filter_map(|p| Some((pixel_at(scene, p, -half)? - pixel_at(scene, p, half)?).norm())).fold(0.0, f64::max)
}

/// Time samples per pixel: the motion's own setting, else four per pixel of image motion.
fn time_samples(scene: &Scene) -> u32 {
    let m = &scene.render.effects.motion;
    if m.is_still() || m.exposure_s <= 0.0 {
        return 1;
    }
    if m.time_samples > 0 {
        return m.time_samples;
    }
    ((4.0 * motion_px(scene)).ceil() as u32).clamp(2, super::motion::MAX_TIME_SAMPLES)
}

/// The thin lens with its aperture samples resolved (0: [`samples_for_coc`] of the largest
/// circle of confusion over the target's features).
pub fn resolved_lens(scene: &Scene) -> Option<ThinLens> {
    let mut lens = scene.render.effects.optics.thin_lens?;
    if lens.aperture_samples == 0 {
        let f = scene.camera.intrinsics.fx.max(scene.camera.intrinsics.fy);
        let r_max = scene
            .target
            .feature_points_m()
            .iter()
            .map(|p| (scene.cam_from_target * p).z)
            .filter(|z| *z > 0.0)
            .map(|z| lens.coc_radius_px(f, z))
            .fold(0.0, f64::max);
        lens.aperture_samples = samples_for_coc(r_max);
    }
    Some(lens)
}

/// The views of `scene` (a valid scene).
pub fn view_set(scene: &Scene) -> ViewSet {
    let fx = &scene.render.effects;
    let lens = resolved_lens(scene);
    let n = time_samples(scene).max(lens.map_or(1, |l| l.aperture_samples));
    let offsets = fx.motion.time_offsets_s(n);
    let aperture = lens.map(|l| ThinLens { aperture_samples: n, ..l }.aperture_points_m());
    // Rank-1 lattice pairing: aperture point k with time stratum (k c) mod n, c coprime to n.
    let c = (1..=n).rev().find(|c| gcd(*c, n) == 1 && f64::from(*c) <= 0.62 * f64::from(n) + 1.0).unwrap_or(1);
    let per_row = fx.motion.rolling();
    let rows = if per_row { scene.camera.size.height } else { 1 };
    let mut views = Vec::with_capacity((rows * n) as usize);
    for y in 0..rows {
        let t_row = if per_row { fx.motion.row_time_s(f64::from(y), scene.camera.size.height) } else { 0.0 };
        for k in 0..n {
            let t = t_row + offsets.get(((u64::from(k) * u64::from(c)) % u64::from(n)) as usize).copied().unwrap_or(0.0);
            let cam_from_target = if fx.motion.is_still() { scene.cam_from_target } else { fx.motion.cam_from_target_at(&scene.cam_from_target, t) };
            let aperture_m = aperture.as_ref().and_then(|a| a.get(k as usize).copied()).unwrap_or([0.0; 2]);
            views.push(ExposureView { cam_from_target, aperture_m, focus_m: lens.map(|l| l.focus_distance_m) });
        }
    }
    ViewSet { samples: n, per_row, views }
}

fn gcd(a: u32, b: u32) -> u32 {
    if b == 0 {
        a
    } else {
        gcd(b, a % b)
    }
}
