//! Observing the S-path in the loop: render it from a camera pose, detect and order its dots, and
//! estimate the pose from them with the bead-centroid correction.
//!
//! Bead centroids are not the projections of the path points (about half of each bead is inside
//! the sphere: 1.4 px on average at the course's desired pose). [`pose_from_dots`] therefore
//! corrects them with the model: the expected blob centroid minus the projected centre at the
//! current pose estimate (the truth labels' blob centroids, [`dot_blobs`]) is subtracted from the
//! detections and PnP is solved again.

use std::time::Instant;

use nalgebra::{Isometry3, Point2, Vector2};

use synthcam_core::target::Target;
use synthcam_detect::s_path_fit::SPathTrack;
use synthcam_detect::target::{detect, detect_tracked, Detection, TargetSpec};
use synthcam_detect::DetectError;
use synthcam_geometry::pnp::{pnp_general, PnpError, PnpResult};
use synthcam_render::{GreyImage, RenderError, Renderer};
use synthcam_scene::blobs::{dot_blobs, CentroidSampling};
use synthcam_scene::trace::Tracer;
use synthcam_scene::Scene;

pub use crate::loop_bias::{pose_from_dots_cached, BiasCache, BiasRefresh};

/// Errors of one observation (a failed detection is not an error: see [`Observed::dots`]).
#[derive(Debug, thiserror::Error)]
#[non_exhaustive]
pub enum ObserveError {
    /// The scene's target is not the S-path.
    #[error("the scene's target is {0}, not the S-path")]
    NotSPath(&'static str),
    /// The renderer failed.
    #[error("rendering: {0}")]
    Render(#[from] RenderError),
    /// The image could not be handed to the detector.
    #[error("detection: {0}")]
    Detect(#[from] DetectError),
}

/// Detected S-path dots: path index and pixel of each.
#[derive(Debug, Clone, PartialEq, Default)]
pub struct Dots {
    /// Path index of every dot.
    pub ids: Vec<usize>,
    /// Pixel of every dot (the detector's blob centroid).
    pub pixels_px: Vec<Point2<f64>>,
}

/// One rendered and detected frame.
#[derive(Debug, Clone)]
pub struct Observed {
    /// The rendered image.
    pub image: GreyImage,
    /// The ordered dots, `None` when the S-path was not found (the detector's reason in `note`).
    pub dots: Option<Dots>,
    /// Why the S-path was not found.
    pub note: Option<String>,
    /// Render + readback time, milliseconds.
    pub render_ms: f64,
    /// Detection time (conversion, dots, ordering), milliseconds.
    pub detect_ms: f64,
}

/// Render `scene` (an S-path scene) and detect its ordered dots.
///
/// # Errors
/// Not an S-path scene, the renderer failed, or the image buffer was inconsistent.
pub fn render_and_detect(renderer: &Renderer, scene: &Scene) -> Result<Observed, ObserveError> {
    if !matches!(scene.target, Target::SPath(_)) {
        return Err(ObserveError::NotSPath(scene.target.kind_name()));
    }
    let Timed { image, det, render_ms, detect_ms } = render_and_detect_target(renderer, scene)?;
    let dots = match det.indices {
        Some(ids) if det.found => Some(Dots { ids, pixels_px: det.points_px }),
        _ => None,
    };
    Ok(Observed { image, dots, note: det.note, render_ms, detect_ms })
}

/// A rendered image, its detection and the time each took.
#[derive(Debug, Clone)]
pub struct Timed {
    /// The rendered image.
    pub image: GreyImage,
    /// What the detector found.
    pub det: Detection,
    /// Render + readback, milliseconds.
    pub render_ms: f64,
    /// Conversion and detection, milliseconds.
    pub detect_ms: f64,
}

/// Render `scene` and run the detector for its target ([`TargetSpec::for_target`]).
///
/// # Errors
/// The renderer failed, or the image buffer was inconsistent.
pub fn render_and_detect_target(renderer: &Renderer, scene: &Scene) -> Result<Timed, ObserveError> {
    render_and_detect_in_sequence(renderer, scene, None)
}

/// [`render_and_detect_target`] on a frame of a sequence: with `track`, the S-path's labels are
/// carried from the previous frame where they can be ([`detect_tracked`]).
///
/// # Errors
/// As [`render_and_detect_target`].
pub fn render_and_detect_in_sequence(renderer: &Renderer, scene: &Scene, track: Option<&mut SPathTrack>) -> Result<Timed, ObserveError> {
    let t0 = Instant::now();
    let image = renderer.render(scene)?;
    let render_ms = t0.elapsed().as_secs_f64() * 1e3;
    let t1 = Instant::now();
    let (img, spec) = (image.to_detector_image()?, TargetSpec::for_target(&scene.target));
    let det = match track {
        Some(t) => detect_tracked(&img, &spec, None, t)?,
        None => detect(&img, &spec)?,
    };
    Ok(Timed { image, det, render_ms, detect_ms: t1.elapsed().as_secs_f64() * 1e3 })
}

/// The model's blob-centroid bias per path index at `scene`'s pose: blob centroid minus the
/// projected dot centre (`None` where the dot is not seen).
#[derive(Debug, Clone, PartialEq)]
pub struct CentroidBias {
    /// The `cam_from_target` it was computed at.
    pub at: Isometry3<f64>,
    /// Bias per path index, pixels.
    pub bias_px: Vec<Option<Vector2<f64>>>,
}

/// The blob sampling of the loops' cached bias ([`pose_from_dots_cached`]): the truth's 16 scan
/// lines per boundary pixel, 9 samples each (the truth's 33) and 12 bisections (16). Within
/// 3.1e-4 px of the truth's bias on the course's view (the test below), well inside the 5e-3 px
/// the 5 mm refresh of [`BiasRefresh`] lets the bias go stale; 8 lines were 6.8e-3 px off.
pub const LOOP_SAMPLING: CentroidSampling = CentroidSampling { lines: 16, samples: 9, bisections: 12 };

impl CentroidBias {
    /// Compute the bias at `scene`'s pose from the truth labels' blob centroids (traces every
    /// dot's blob: tens to hundreds of ms).
    pub fn at(scene: &Scene) -> Self {
        Self::sampled(scene, &CentroidSampling::TRUTH)
    }

    /// [`CentroidBias::at`] with the blobs' boundary pixels integrated as `sampling` says.
    pub fn sampled(scene: &Scene, sampling: &CentroidSampling) -> Self {
        let blobs = dot_blobs(scene, &Tracer::new(scene), sampling);
        let pts = scene.target.feature_points_m();
        let bias_px = pts
            .iter()
            .zip(&blobs)
            .map(|(p, b)| {
                let q = scene.camera.project(&(scene.cam_from_target * p)).pixel_px;
                b.map(|b| Vector2::new(b.centroid_px[0] - q.x, b.centroid_px[1] - q.y))
            })
            .collect();
        Self { at: scene.cam_from_target, bias_px }
    }

    /// Whether `cam_from_target` is within `mm` and `deg` of the pose this was computed at.
    pub fn is_near(&self, cam_from_target: &Isometry3<f64>, mm: f64, deg: f64) -> bool {
        let d = self.at.inverse() * cam_from_target;
        d.translation.vector.norm() * 1e3 <= mm && d.rotation.angle().to_degrees() <= deg
    }

    /// The detected pixels minus the bias: estimates of the projections of the dot centres.
    pub fn correct(&self, dots: &Dots) -> Vec<Point2<f64>> {
        dots.ids.iter().zip(&dots.pixels_px).map(|(id, q)| self.bias_px.get(*id).copied().flatten().map_or(*q, |b| q - b)).collect()
    }
}

/// PnP on detected dots with `rounds` rounds of the bead-centroid correction (0: plain PnP on the
/// blob centroids). `scene` gives the camera, the target and the render settings; its pose is
/// ignored. Returns the estimate and the corrected pixels.
///
/// # Errors
/// PnP failed (too few dots, degenerate geometry).
pub fn pose_from_dots(scene: &Scene, dots: &Dots, rounds: usize) -> Result<(PnpResult, Vec<Point2<f64>>), PnpError> {
    let points = dot_points(scene, dots);
    let mut est = pnp_general(&scene.camera, &points, &dots.pixels_px)?;
    let mut used = dots.pixels_px.clone();
    for _ in 0..rounds {
        used = CentroidBias::at(&Scene { cam_from_target: est.cam_from_target, ..scene.clone() }).correct(dots);
        est = pnp_general(&scene.camera, &points, &used)?;
    }
    Ok((est, used))
}

pub(crate) fn dot_points(scene: &Scene, dots: &Dots) -> Vec<nalgebra::Point3<f64>> {
    let all = scene.target.feature_points_m();
    dots.ids.iter().map(|i| all[*i]).collect()
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The loops' light blob sampling against the truth labels' on the course's view (101 beads,
    /// some behind the sphere's outline): the bias within 1e-3 px per dot, a fifth of the
    /// staleness the 5 mm refresh allows (the bias changes by about 1e-3 px per mm).
    #[test]
    fn the_loop_bias_matches_the_truths() {
        let scene = synthcam_scene::file::parse_scene(include_str!("../assets/scenes/course_s_path.toml")).expect("scene");
        let (light, truth) = (CentroidBias::sampled(&scene, &LOOP_SAMPLING), CentroidBias::at(&scene));
        assert_eq!(light.bias_px.iter().filter(|b| b.is_some()).count(), truth.bias_px.iter().filter(|b| b.is_some()).count());
        let worst = light.bias_px.iter().zip(&truth.bias_px).filter_map(|(a, b)| Some((a.as_ref()? - b.as_ref()?).norm())).fold(0.0, f64::max);
        let largest = truth.bias_px.iter().flatten().map(|b| b.norm()).fold(0.0, f64::max);
        eprintln!("loop bias vs truth: worst {worst:.2e} px (the bias itself up to {largest:.3} px)");
        assert!(worst <= 1e-3, "{worst}");
    }
}
