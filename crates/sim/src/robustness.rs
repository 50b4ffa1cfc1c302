//! Detector robustness against camera effects (`synthcam experiment robustness`): one effect at a
//! time at increasing strength, every image rendered, detected by synthcam's chessboard detector
//! and compared with the exact truth of that effect.
//!
//! **Scene.** [`CHESSBOARD_K1`] (`assets/scenes/chessboard_k1.toml`: 11 x 8 inner corners, 50 mm
//! squares, tilted 40 degrees, 0.65-0.95 m away, 1280 x 1024, f = 1500 px, barrel distortion
//! k1 = -0.25; the truth includes the distortion), no noise except under [`Effect::Noise`]. View 0
//! is the file's pose; views 1.. turn it by up to 3 degrees about a random axis through the
//! board's centre and shift it by up to 10 mm (seeded, redrawn until every corner is in the
//! image), so that a result is not one pose.
//!
//! **Effects** ([`Effect::levels`], [`Effect::configure`]); the strength reported is:
//! - [`Effect::Blur`]: Gaussian `render.blur_sigma_px`; strength = sigma, px.
//! - [`Effect::Defocus`]: thin lens f = 16 mm focused at 0.4 m, f-number levels, aperture samples
//!   about a pixel apart ([`defocus_lens`]); strength = the circle of confusion's radius at the
//!   board centre's depth, px.
//! - [`Effect::Noise`]: the EMVA 1288 sensor ([`synthcam_core::camera::sensor::SensorModel`] defaults: 1e6 photons/s at grey 255,
//!   QE 0.6, read noise 3 e, dark current 5 e/s, PRNU 1 %, DSNU 1 e, 8 bits) at exposure levels
//!   that give 9000 (near full well) down to 48 electrons at grey 255. The gain follows the
//!   exposure (an auto-gain camera: grey 255 is always 250 DN), so the image keeps its brightness
//!   and only its signal-to-noise ratio falls. Strength = the temporal SNR at grey 128,
//!   `mu_e / sqrt(mu_e + mu_d + sigma_d^2 + 1 / (12 K^2))` ([`snr_at`]).
//! - [`Effect::MotionBlur`]: the camera translates along its x axis during a 10 ms exposure at the
//!   speed that moves the board centre's image by the level, px (the strength).
//! - [`Effect::Jpeg`]: JPEG round trip in memory at quality levels; strength = the quality.
//! - [`Effect::RollingShutter`]: camera twist 0.5 rad/s about y plus 0.2 m/s along x, no
//!   exposure blur, line delay levels; strength = the mean image displacement of the corners
//!   between the global-shutter and the rolling-shutter image, px.
//!
//! - [`Effect::Gradient`], [`Effect::Highlight`], [`Effect::Clutter`]: the scene conditions of
//!   issue 41 ([`conditions`]): a lamp beside the board (levels: its intensity; strength: the
//!   brightest over the dimmest corner's irradiance), a laminated board with the lamp at the
//!   camera's mirror point over the board centre (intensity; the largest specular grey level at a
//!   corner), a clutter panorama behind the board (its contrast, the strength); [`Effect::Shadow`]:
//!   a bar's shadow band over a column of corners (lit over shadowed shading, the strength).
//!
//! **Truth**: `effects.rolling_shutter_px` under a rolling shutter, the mid-exposure projection
//! `effects.trajectory_px[2]` under motion blur, `pixel_px` otherwise ([`truth_points`]).
//! **Matching**: the detected corners in their order against the truth in the target's order,
//! under each symmetry of the grid (the detector and OpenCV may start at another corner); the
//! symmetry with the smallest RMS counts ([`match_errors`]).
//!
//! Pure: no files. [`run_robustness`] hands every image to a callback that may write it.

use nalgebra::{Isometry3, Point3, Translation3, Unit, UnitQuaternion, Vector3};
use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;

use synthcam_core::target::Target;
use synthcam_render::{finish, GreyImage, Renderer};
use synthcam_scene::effects::Encoding;
use synthcam_scene::{truth_labels, Scene, TruthLabels};

pub mod conditions;
mod levels;
pub mod score;
pub use levels::{defocus_lens, sensor_at, snr_at, MOTION_EXPOSURE_S};
use score::{detect_and_score, strength};
pub use score::{jpeg_round_trip, match_errors, rms, truth_points};

/// The default scene (`assets/scenes/chessboard_k1.toml`).
pub const CHESSBOARD_K1: &str = include_str!("../assets/scenes/chessboard_k1.toml");

/// A camera effect studied alone.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub enum Effect {
    /// Gaussian blur.
    Blur,
    /// Thin-lens defocus.
    Defocus,
    /// EMVA 1288 sensor noise.
    Noise,
    /// Motion blur (camera translation during the exposure).
    MotionBlur,
    /// JPEG compression.
    Jpeg,
    /// Rolling shutter.
    RollingShutter,
    /// A lamp's gradient across the board ([`conditions::gradient`]).
    Gradient,
    /// A glossy board's highlight over its centre ([`conditions::highlight`]).
    Highlight,
    /// A cluttered room behind the board ([`conditions::cluttered`]).
    Clutter,
    /// An object's shadow edge across corners ([`conditions::shadowed`]).
    Shadow,
}

impl Effect {
    /// Every effect, in report order.
    pub const ALL: [Effect; 10] = [
        Effect::Blur,
        Effect::Defocus,
        Effect::Noise,
        Effect::MotionBlur,
        Effect::Jpeg,
        Effect::RollingShutter,
        Effect::Gradient,
        Effect::Highlight,
        Effect::Clutter,
        Effect::Shadow,
    ];

    /// The effect's name (CLI, file names, tables).
    pub fn name(&self) -> &'static str {
        match self {
            Effect::Blur => "blur",
            Effect::Defocus => "defocus",
            Effect::Noise => "noise",
            Effect::MotionBlur => "motion-blur",
            Effect::Jpeg => "jpeg",
            Effect::RollingShutter => "rolling-shutter",
            Effect::Gradient => "gradient",
            Effect::Highlight => "highlight",
            Effect::Clutter => "clutter",
            Effect::Shadow => "shadow",
        }
    }

    /// The effect of a name ([`Effect::name`]; `_` for `-` accepted).
    pub fn from_name(name: &str) -> Option<Effect> {
        let n = name.trim().to_ascii_lowercase().replace('_', "-");
        Self::ALL.into_iter().find(|e| e.name() == n)
    }

    /// The levels (the parameter set), weakest first.
    pub fn levels(&self) -> &'static [f64] {
        match self {
            Effect::Blur => &[0.0, 0.5, 1.0, 1.5, 2.0, 3.0],
            Effect::Defocus => &[16.0, 8.0, 5.6, 4.0, 2.8, 2.0],
            Effect::Noise => &[0.015, 0.005, 0.0015, 5e-4, 1.5e-4, 8e-5],
            Effect::MotionBlur => &[0.0, 1.0, 2.0, 4.0, 8.0, 16.0],
            Effect::Jpeg => &[100.0, 90.0, 75.0, 50.0, 30.0, 10.0],
            Effect::RollingShutter => &[0.0, 10e-6, 20e-6, 40e-6, 80e-6],
            Effect::Gradient => &[0.0, 0.01, 0.02, 0.05, 0.1, 0.2],
            Effect::Highlight => &[0.0, 0.5, 1.0, 2.0, 4.0, 8.0],
            Effect::Clutter => &[0.0, 0.25, 0.5, 0.75, 1.0],
            Effect::Shadow => &[1.0, 1.5, 2.0, 4.0, 8.0, 16.0],
        }
    }

    /// What a level is, with its unit.
    pub fn level_name(&self) -> &'static str {
        match self {
            Effect::Blur => "sigma px",
            Effect::Defocus => "f-number",
            Effect::Noise => "exposure s",
            Effect::MotionBlur => "motion px",
            Effect::Jpeg => "quality",
            Effect::RollingShutter => "line delay s",
            Effect::Gradient | Effect::Highlight => "lamp intensity",
            Effect::Clutter | Effect::Shadow => "contrast",
        }
    }

    /// What the strength is, with its unit.
    pub fn strength_name(&self) -> &'static str {
        match self {
            Effect::Blur => "blur sigma, px",
            Effect::Defocus => "CoC radius at the board centre, px",
            Effect::Noise => "SNR at grey 128",
            Effect::MotionBlur => "image motion at the board centre, px",
            Effect::Jpeg => "JPEG quality",
            Effect::RollingShutter => "mean rolling-shutter displacement, px",
            Effect::Gradient => "brightest / dimmest corner irradiance",
            Effect::Highlight => "largest specular grey level at a corner",
            Effect::Clutter => "background contrast",
            Effect::Shadow => "lit / shadowed shading",
        }
    }

    /// `base` with this effect at `level` (the module docs give the settings).
    pub fn configure(&self, base: &Scene, level: f64) -> Scene {
        let mut s = base.clone();
        let fx = &mut s.render.effects;
        match self {
            Effect::Blur => s.render.blur_sigma_px = level,
            Effect::Defocus => fx.optics.thin_lens = Some(defocus_lens(level, base)),
            Effect::Noise => fx.sensor = Some(sensor_at(level)),
            Effect::MotionBlur => {
                let speed = level * centre_depth_m(base) / (base.camera.intrinsics.fx * MOTION_EXPOSURE_S);
                fx.motion.twist = [0.0, 0.0, 0.0, speed, 0.0, 0.0];
                fx.motion.exposure_s = MOTION_EXPOSURE_S;
            }
            Effect::Jpeg => {
                fx.output.encoding = Encoding::Jpeg;
                fx.output.jpeg_quality = level.clamp(1.0, 100.0) as u8;
            }
            Effect::RollingShutter => {
                fx.motion.twist = [0.0, 0.5, 0.0, 0.2, 0.0, 0.0];
                fx.motion.line_delay_s = level;
            }
            Effect::Gradient => return conditions::gradient(base, level),
            Effect::Highlight => return conditions::highlight(base, level),
            Effect::Clutter => return conditions::cluttered(base, level, base.cam_from_target.translation.x.to_bits()),
            Effect::Shadow => return conditions::shadowed(base, level),
        }
        s
    }

    /// Whether the effect only changes the image formation after the shader (the geometry
    /// render of a view can be shared by all levels).
    fn post_only(&self) -> bool {
        matches!(self, Effect::Blur | Effect::Noise | Effect::Jpeg)
    }
}

/// Mean camera-frame point of the target's features.
fn centre_cam(scene: &Scene) -> Point3<f64> {
    scene.cam_from_target * scene.target.feature_centre_m()
}

/// Depth of the board centre, metres.
fn centre_depth_m(scene: &Scene) -> f64 {
    centre_cam(scene).z
}

/// The experiment's scene and views.
#[derive(Debug, Clone, PartialEq)]
pub struct RobustnessSetup {
    /// The scene every view perturbs (a chessboard).
    pub base: Scene,
    /// Poses per level.
    pub views: usize,
    /// Seed of the pose perturbations and of the noise.
    pub seed: u64,
}

impl RobustnessSetup {
    /// [`CHESSBOARD_K1`] with `views` poses per level.
    ///
    /// # Errors
    /// Never for the embedded file; [`RobustnessError::Scene`] otherwise.
    pub fn chessboard_k1(views: usize, seed: u64) -> Result<Self, RobustnessError> {
        Ok(Self { base: synthcam_scene::file::parse_scene(CHESSBOARD_K1)?, views, seed })
    }

    /// The scenes of the views: view 0 is `base`, the others perturbed (module docs).
    pub fn view_scenes(&self) -> Vec<Scene> {
        (0..self.views).map(|k| if k == 0 { self.base.clone() } else { self.perturbed(k) }).collect()
    }

    fn perturbed(&self, k: usize) -> Scene {
        let mut rng = ChaCha8Rng::seed_from_u64(self.seed.wrapping_mul(7919).wrapping_add(k as u64));
        let c = centre_cam(&self.base).coords;
        for _ in 0..50 {
            let axis = Vector3::new(rng.random_range(-1.0..1.0), rng.random_range(-1.0..1.0), rng.random_range(-1.0..1.0));
            let Some(axis) = Unit::try_new(axis, 1e-6) else { continue };
            let rot = UnitQuaternion::from_axis_angle(&axis, rng.random_range(-3.0f64..3.0).to_radians());
            let shift = Vector3::new(rng.random_range(-0.01..0.01), rng.random_range(-0.01..0.01), rng.random_range(-0.01..0.01));
            let delta = Isometry3::from_parts(Translation3::from(c + shift - rot * c), rot);
            let scene = Scene { cam_from_target: delta * self.base.cam_from_target, ..self.base.clone() };
            if truth_labels(&scene).features.iter().all(|f| f.visible) {
                return scene;
            }
        }
        self.base.clone()
    }
}

/// One detection of the experiment.
#[derive(Debug, Clone, PartialEq)]
pub struct RobustnessRun {
    /// The effect.
    pub effect: Effect,
    /// Its level ([`Effect::levels`]).
    pub level: f64,
    /// The strength (module docs; per view).
    pub strength: f64,
    /// View index.
    pub view: usize,
    /// Whether the whole board was found.
    pub detected: bool,
    /// RMS error against the truth of the corners the detector trusts (the ones a calibration
    /// keeps), px (NaN when not detected).
    pub rms_px: f64,
    /// Largest error of a trusted corner, px (NaN when not detected).
    pub max_px: f64,
    /// Corners detected.
    pub n_corners: usize,
    /// Corners the detector flags as untrusted (left out of the errors).
    pub untrusted: usize,
}

/// One rendered and detected image, as [`run_robustness`] hands it to its callback.
#[derive(Debug, Clone, Copy)]
pub struct ViewImage<'a> {
    /// Index of the level in [`Effect::levels`].
    pub level_index: usize,
    /// The detection's result.
    pub run: &'a RobustnessRun,
    /// The image the detector saw (after the JPEG round trip for [`Effect::Jpeg`]).
    pub image: &'a GreyImage,
    /// The scene's truth labels.
    pub truth: &'a TruthLabels,
    /// The truth the corners are compared with, in the target's order ([`truth_points`]).
    pub truth_px: &'a [[f64; 2]],
    /// Inner corners `[cols, rows]`.
    pub grid: [u32; 2],
}

/// Errors of [`run_robustness`].
#[derive(Debug, thiserror::Error)]
#[non_exhaustive]
pub enum RobustnessError {
    /// The scene is invalid or not a chessboard.
    #[error(transparent)]
    Scene(#[from] synthcam_scene::SceneError),
    /// Rendering failed.
    #[error(transparent)]
    Render(#[from] synthcam_render::RenderError),
    /// The detector rejected the image.
    #[error(transparent)]
    Detect(#[from] synthcam_detect::DetectError),
    /// JPEG encoding or decoding failed.
    #[error("JPEG round trip: {0}")]
    Jpeg(String),
    /// The callback asked to stop.
    #[error("stopped: {0}")]
    Stopped(String),
}

/// Render `scene` (post-only effects share the view's geometry render in `cache`), then the JPEG
/// round trip for [`Effect::Jpeg`].
fn render_image(renderer: &Renderer, effect: Effect, scene: &Scene, cache: &mut Option<Vec<f32>>) -> Result<GreyImage, RobustnessError> {
    let img = if effect.post_only() {
        let linear = match cache.take() {
            Some(l) => l,
            None => renderer.render_radiance(scene)?,
        };
        let img = finish(scene, &linear);
        *cache = Some(linear);
        img?
    } else {
        renderer.render(scene)?
    };
    match effect {
        Effect::Jpeg => jpeg_round_trip(&img, scene.render.effects.output.jpeg_quality),
        _ => Ok(img),
    }
}

/// Render every (effect, level, view) of `setup` at each effect's [`Effect::levels`], detect
/// the chessboard, compare with the truth (module docs) and hand each image to `on_view` (which
/// may write it; an `Err` stops the run). Writes nothing itself.
///
/// # Errors
/// As [`run_levels`].
pub fn run_robustness(
    renderer: &Renderer,
    setup: &RobustnessSetup,
    effects: &[Effect],
    on_view: &mut dyn FnMut(&ViewImage<'_>) -> Result<(), String>,
) -> Result<Vec<RobustnessRun>, RobustnessError> {
    let plan: Vec<(Effect, &[f64])> = effects.iter().map(|e| (*e, e.levels())).collect();
    run_levels(renderer, setup, &plan, on_view)
}

/// [`run_robustness`] at chosen levels per effect.
///
/// # Errors
/// A base scene that is not a valid chessboard scene, a level the scene rejects, a render or
/// JPEG failure, or [`RobustnessError::Stopped`] from the callback.
pub fn run_levels(
    renderer: &Renderer,
    setup: &RobustnessSetup,
    plan: &[(Effect, &[f64])],
    on_view: &mut dyn FnMut(&ViewImage<'_>) -> Result<(), String>,
) -> Result<Vec<RobustnessRun>, RobustnessError> {
    let Target::Chessboard(board) = &setup.base.target else {
        return Err(synthcam_scene::SceneError::InvalidField { field: "target".into(), reason: "the robustness experiment needs a chessboard".into() }.into());
    };
    let grid = board.inner_corner_count();
    setup.base.validate()?;
    let views = setup.view_scenes();
    let mut cache: Vec<Option<Vec<f32>>> = vec![None; views.len()];
    let mut runs = Vec::new();
    for &(effect, levels) in plan {
        for (level_index, &level) in levels.iter().enumerate() {
            for ((view, base), cached) in views.iter().enumerate().zip(cache.iter_mut()) {
                let mut scene = effect.configure(base, level);
                scene.render.seed = setup.seed.wrapping_mul(1_000_003).wrapping_add((level_index * 1000 + view) as u64);
                let image = render_image(renderer, effect, &scene, cached)?;
                let truth = truth_labels(&scene);
                let truth_px = truth_points(effect, &scene, &truth);
                let run = detect_and_score(&image, &truth_px, grid)?.run(effect, level, strength(effect, &scene, level, &truth), view);
                on_view(&ViewImage { level_index, run: &run, image: &image, truth: &truth, truth_px: &truth_px, grid }).map_err(RobustnessError::Stopped)?;
                runs.push(run);
            }
        }
    }
    Ok(runs)
}
