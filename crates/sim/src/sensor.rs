//! Sensors: what turns a scene into features. [`RenderedSensor`] renders the scene on the GPU and
//! runs the detector for the target's kind; [`IdealSensor`] projects the target's features and
//! adds Gaussian noise (the course's method). A loop runs the same over either.

use nalgebra::{Point2, Vector2};
use rand::SeedableRng;
use rand_chacha::ChaCha8Rng;
use rand_distr::{Distribution, Normal};
use synthcam_detect::chessboard::corners_to_leave_out;

use super::observe::{render_and_detect_in_sequence, Timed};
use super::SimError;
use synthcam_detect::s_path_fit::SPathTrack;
use synthcam_render::{GreyImage, Renderer};
use synthcam_scene::Scene;

/// One feature seen in an image: its id (index into [`synthcam_core::target::Target::feature_points_m`]) and pixel.
#[derive(Debug, Clone, Copy, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct Feature {
    /// Index into the target's feature points.
    pub id: usize,
    /// Pixel (OpenCV convention).
    pub pixel_px: Point2<f64>,
}

/// What a sensor returns for one frame.
#[derive(Debug, Clone)]
pub struct Capture {
    /// The image (`None` for an ideal sensor).
    pub image: Option<GreyImage>,
    /// The features found. For planar grids the ids are the detector's order, which is the
    /// target's order up to the grid's symmetry: [`super::Sim`] resolves it.
    pub features: Vec<Feature>,
    /// Why nothing was found, when nothing was.
    pub note: Option<String>,
    /// Render + readback time, milliseconds.
    pub render_ms: f64,
    /// Detection time, milliseconds.
    pub detect_ms: f64,
}

/// A camera in the loop.
pub trait Sensor {
    /// Capture `scene` (its `render.seed` varies per frame).
    ///
    /// # Errors
    /// A renderer or detector failure; a target that is not found is a capture without features.
    fn capture(&mut self, scene: &Scene) -> Result<Capture, SimError>;

    /// Restart the sensor's own random stream from `seed` (a rendered sensor has none: its
    /// noise follows the scene's seed).
    fn reseed(&mut self, _seed: u64) {}
}

/// The GPU renderer and synthcam's detector. The frames are a sequence: the S-path's labels are
/// carried from one frame to the next where every dot moved less than a third of its spacing
/// ([`SPathTrack::carry`]; the same labels as placing them afresh, at a fraction of the time),
/// and placed afresh otherwise.
#[derive(Debug)]
pub struct RenderedSensor<'a> {
    /// The renderer.
    pub renderer: &'a Renderer,
    track: SPathTrack,
}

impl<'a> RenderedSensor<'a> {
    /// A sensor rendering with `renderer`, its sequence empty.
    pub fn new(renderer: &'a Renderer) -> Self {
        Self { renderer, track: SPathTrack::default() }
    }

    /// The S-path's sequence so far (how many frames had their labels carried).
    pub fn track(&self) -> &SPathTrack {
        &self.track
    }
}

impl Sensor for RenderedSensor<'_> {
    fn capture(&mut self, scene: &Scene) -> Result<Capture, SimError> {
        let Timed { image, det, render_ms, detect_ms } = render_and_detect_in_sequence(self.renderer, scene, Some(&mut self.track))?;
        let features = if det.found {
            let coded = det.ids.map(|ids| ids.into_iter().map(|i| i as usize).collect());
            let ids = det.indices.or(coded).unwrap_or_else(|| (0..det.points_px.len()).collect());
            // corners whose fit failed, or far less certain than the rest, are not measurements
            let leave_out = det.position_sigma_px.as_deref().map(|s| corners_to_leave_out(s, &det.untrusted)).unwrap_or_default();
            ids.into_iter().zip(det.points_px).enumerate().filter(|(k, _)| !leave_out.contains(k)).map(|(_, (id, pixel_px))| Feature { id, pixel_px }).collect()
        } else {
            Vec::new()
        };
        Ok(Capture { image: Some(image), features, note: det.note, render_ms, detect_ms })
    }

    /// A restart begins a new sequence: the next frame's labels are placed afresh.
    fn reseed(&mut self, _seed: u64) {
        self.track = SPathTrack::default();
    }
}

/// Ideal projections of the visible features plus N(0, noise_px^2) per coordinate.
#[derive(Debug, Clone)]
pub struct IdealSensor {
    noise: Normal<f64>,
    rng: ChaCha8Rng,
}

impl IdealSensor {
    /// A sensor with `noise_px` pixel noise, seeded.
    ///
    /// # Errors
    /// A negative or non-finite noise.
    pub fn new(noise_px: f64, seed: u64) -> Result<Self, SimError> {
        if !(noise_px >= 0.0) || !noise_px.is_finite() {
            return Err(SimError::Scenario(format!("ideal noise must be finite and >= 0 px, got {noise_px}")));
        }
        let noise = Normal::new(0.0, noise_px).map_err(|e| SimError::Scenario(format!("ideal noise {noise_px}: {e}")))?;
        Ok(Self { noise, rng: ChaCha8Rng::seed_from_u64(seed) })
    }
}

impl Sensor for IdealSensor {
    fn capture(&mut self, scene: &Scene) -> Result<Capture, SimError> {
        let mut features = Vec::new();
        for (id, p) in scene.target.feature_points_m().iter().enumerate() {
            let pr = scene.camera.project(&(scene.cam_from_target * p));
            if pr.visible() {
                let n = Vector2::new(self.noise.sample(&mut self.rng), self.noise.sample(&mut self.rng));
                features.push(Feature { id, pixel_px: pr.pixel_px + n });
            }
        }
        Ok(Capture { image: None, features, note: None, render_ms: 0.0, detect_ms: 0.0 })
    }

    fn reseed(&mut self, seed: u64) {
        self.rng = ChaCha8Rng::seed_from_u64(seed);
    }
}

/// The sensor for `observation`: the renderer and detector, or ideal projections plus
/// `noise_px` (seeded).
///
/// # Errors
/// A rendered observation without a renderer, or a bad noise level.
pub fn sensor_for(
    observation: ObservationKind,
    renderer: Option<&synthcam_render::Renderer>,
    noise_px: f64,
    seed: u64,
) -> Result<Box<dyn Sensor + '_>, SimError> {
    match (observation, renderer) {
        (ObservationKind::Rendered, Some(r)) => Ok(Box::new(RenderedSensor::new(r))),
        (ObservationKind::Rendered, None) => Err(SimError::Scenario("a rendered observation needs a renderer".into())),
        (ObservationKind::Ideal, _) => Ok(Box::new(IdealSensor::new(noise_px, seed)?)),
    }
}

/// How the dots are observed.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum ObservationKind {
    /// Ideal projections plus N(0, 0.1^2) px noise (the course's method).
    Ideal,
    /// Rendered (noise 1 grey level) and detected.
    Rendered,
}
