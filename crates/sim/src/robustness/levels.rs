//! The camera-effect levels' settings: the thin lens of [`super::Effect::Defocus`], the sensor
//! of [`super::Effect::Noise`] and its SNR, the exposure of [`super::Effect::MotionBlur`].

use synthcam_core::camera::optics::ThinLens;
use synthcam_core::camera::sensor::SensorModel;
use synthcam_scene::Scene;

/// Exposure of [`super::Effect::MotionBlur`], seconds.
pub const MOTION_EXPOSURE_S: f64 = 0.01;

/// The thin lens of [`super::Effect::Defocus`] at f-number `n` for `scene`: f = 16 mm focused at 0.4 m,
/// with enough aperture samples that they lie about a pixel apart on the largest circle of
/// confusion over the board (`pi r^2`, even, in 16..=256). With a fixed 16 samples the image of a
/// CoC of 7.5 px is 16 visibly separate copies, and the corner error measured is the sampling's
/// (2.6 px RMS at f/2, 0.04 px with 256 samples), not the detector's.
pub fn defocus_lens(n: f64, scene: &Scene) -> ThinLens {
    let lens = ThinLens { f_number: n, focal_length_m: 0.016, focus_distance_m: 0.4, aperture_samples: 0 };
    let mut s = scene.clone();
    s.render.effects.optics.thin_lens = Some(lens);
    synthcam_scene::views::resolved_lens(&s).unwrap_or(lens)
}

/// The sensor of [`super::Effect::Noise`] at exposure `exposure_s`: defaults, gain so that grey 255 is
/// 250 DN on average.
pub fn sensor_at(exposure_s: f64) -> SensorModel {
    let mut m = SensorModel { exposure_s, ..Default::default() };
    let electrons = m.mean_electrons(255.0) + m.dark_current_e_per_s * exposure_s;
    m.gain_dn_per_e = if electrons > 0.0 { 250.0 / electrons } else { 1.0 };
    m
}

/// The temporal SNR of `model` at `grey` (EMVA 1288: `mu_e / sqrt(mu_e + mu_d + sigma_d^2 +
/// sigma_q^2 / K^2)`, `sigma_q^2 = 1/12 DN^2`).
pub fn snr_at(model: &SensorModel, grey: f64) -> f64 {
    let mu_e = model.mean_electrons(grey);
    let var = mu_e + model.dark_current_e_per_s * model.exposure_s + model.read_noise_e.powi(2) + 1.0 / (12.0 * model.gain_dn_per_e.powi(2));
    mu_e / var.sqrt()
}
