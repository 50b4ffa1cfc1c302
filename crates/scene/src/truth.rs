//! Truth labels written next to every image.
//!
//! For every feature: its point in the target frame, its projected pixel (CPU camera model, the
//! same one the shader mirrors), whether it is in front of the camera and inside the image, and for
//! dots the expected centroid and area of the rendered blob.
//!
//! **Blob centroid**: [`crate::blobs`].

use rayon::prelude::*;
use serde::Serialize;

use super::file::CameraSpec;
use super::trace::Tracer;
use super::{RenderSettings, Scene};
pub use crate::blobs::{blob_centroid, dot_blobs, Blob, CentroidSampling, CENTROID_BISECTIONS, CENTROID_LINES, CENTROID_LINE_SAMPLES};
use synthcam_core::math::so3::rvec_from_rotation;
use synthcam_core::target::{FeatureKind, Target};

/// Pose as written to JSON.
#[derive(Debug, Clone, PartialEq, Serialize, serde::Deserialize)]
pub struct PoseLabel {
    /// Rotation matrix rows of `cam_from_target`.
    #[serde(rename = "R")]
    pub r: [[f64; 3]; 3],
    /// Rodrigues vector of the same rotation, radians.
    pub rvec: [f64; 3],
    /// Translation, metres.
    pub t_m: [f64; 3],
}

/// Truth of one feature.
#[derive(Debug, Clone, PartialEq, Serialize, serde::Deserialize)]
pub struct FeatureLabel {
    /// Index in the target's documented order.
    pub id: usize,
    /// Point in the target frame, metres.
    pub point_target_m: [f64; 3],
    /// Projection through the full camera model, pixels (OpenCV convention).
    pub pixel_px: [f64; 2],
    /// Depth in the camera frame (its z), metres: negative behind the camera plane, where a
    /// fisheye that reaches beyond 90 degrees still sees.
    pub depth_m: f64,
    /// On the side of the camera its lens sees: z > 0, or within a fisheye's reach
    /// ([`synthcam_core::camera::Projection::in_front`]).
    pub in_front: bool,
    /// Projected pixel inside the image.
    pub in_image: bool,
    /// In front, inside the image, not hidden by an object (`occluded`) and (for dots) at
    /// least partly unoccluded by the target itself.
    pub visible: bool,
    /// An object ([`super::objects`]) lies between the camera and the feature point (exact ray
    /// cast to the point); written only when true.
    #[serde(default, skip_serializing_if = "std::ops::Not::not")]
    pub occluded: bool,
    /// Dots: intensity-weighted centroid of the rendered (box-filtered) blob, pixels: what an
    /// intensity-centroid detector measures on the noise-free image. `None` when nothing is rendered.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub centroid_px: Option<[f64; 2]>,
    /// Dots: centroid of the continuous blob region (differs from `centroid_px` by the pixel
    /// discretisation of the boundary).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub area_centroid_px: Option<[f64; 2]>,
    /// Dots: area of the rendered blob, pixels^2.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub area_px: Option<f64>,
    /// Truth under the camera effects (rolling shutter, motion, defocus;
    /// [`super::effect_truth`]); empty without them.
    #[serde(default, skip_serializing_if = "super::effect_truth::EffectLabel::is_empty")]
    pub effects: super::effect_truth::EffectLabel,
    /// Under lights ([`super::lighting`]): the irradiance at the feature per unit albedo,
    /// `A + sum E cos` (its grey levels are the albedos times it); absent without lights.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub irradiance: Option<f64>,
    /// A glossy target under a point light: the specular grey level added at the feature (the
    /// highlight's share there); absent without gloss.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub specular: Option<f64>,
    /// With objects under a directional light ([`super::shadow`]): whether the feature lies in an
    /// object's shadow (its `irradiance` then the ambient term alone); under an area light,
    /// whether any of the light is hidden from it (its `irradiance` then `A + E V`, the visible
    /// share `V` sampled on 32 x 32 cells of the emitter); absent otherwise.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub in_shadow: Option<bool>,
}

/// Under lights, the irradiance factor at a feature (camera frame), on a glossy target the
/// specular grey level there, and with objects whether it lies in their shadow; `None` without
/// lights (gloss, objects). One normal for a flat board; a point light's terms depend on the
/// feature's point.
fn feature_light(scene: &Scene, p_cam: &nalgebra::Point3<f64>) -> (Option<f64>, Option<f64>, Option<bool>) {
    let lighting = scene.render.lighting;
    let n = super::lighting::camera_side_normal(scene);
    let mut irradiance = (!lighting.is_neutral()).then(|| lighting.irradiance_at(&p_cam.coords, &n, &scene.cam_from_target));
    let mut in_shadow = None;
    if let (Some(e), Some(light)) = (irradiance.as_mut(), super::shadow::shadow_light(scene)) {
        let (shadowed, dark) = light.irradiance_at(scene, *e, p_cam);
        (*e, in_shadow) = (shadowed, Some(dark));
    }
    (irradiance, lighting.gloss.map(|_| lighting.specular_at(&p_cam.coords, &n, &scene.cam_from_target)), in_shadow)
}

/// Truth file contents.
#[derive(Debug, Clone, PartialEq, Serialize, serde::Deserialize)]
pub struct TruthLabels {
    /// Format version.
    pub version: u32,
    /// Pixel convention in words.
    pub pixel_convention: String,
    /// Camera.
    pub camera: CameraSpec,
    /// `cam_from_target`.
    pub cam_from_target: PoseLabel,
    /// Target kind ("chessboard", "dot-grid", "s-path", "charuco").
    pub target_kind: String,
    /// "corner" or "dot".
    pub feature_kind: FeatureKind,
    /// Chessboard (and ChArUco) inner corners `[cols, rows]` or dot-grid `[n, n]`; S-path `[101, 1]`;
    /// AprilGrid `[4, tags]` (four corners per tag).
    pub grid: [u32; 2],
    /// Render settings.
    pub render: RenderLabel,
    /// Features in the target's order.
    pub features: Vec<FeatureLabel>,
    /// Coded boards: every marker, by id.
    #[serde(default, skip_serializing_if = "Vec::is_empty")]
    pub markers: Vec<MarkerLabel>,
}

/// Truth of one marker of a coded board.
#[derive(Debug, Clone, PartialEq, Serialize, serde::Deserialize)]
pub struct MarkerLabel {
    /// Marker id in its dictionary.
    pub id: u32,
    /// Its corners' projections, pixels: ChArUco top-left, top-right, bottom-right, bottom-left
    /// in the board frame (OpenCV's `getObjPoints()`); AprilGrid Kalibr's order (bottom-left,
    /// bottom-right, top-right, top-left on the page: feature ids `4 k .. 4 k + 3`).
    pub corners_px: [[f64; 2]; 4],
    /// Every corner in front of the camera and inside the image.
    pub visible: bool,
}

/// Render settings as written to JSON.
#[derive(Debug, Clone, PartialEq, Serialize, serde::Deserialize)]
pub struct RenderLabel {
    /// Sub-samples per axis for brute-force pixels.
    pub samples: u32,
    /// Noise sigma, grey levels.
    pub noise_sigma: f64,
    /// Blur sigma, pixels.
    pub blur_sigma_px: f64,
    /// Seed.
    pub seed: u64,
    /// Bit depth.
    pub bit_depth: u8,
    /// The EMVA 1288 sensor, when one is simulated.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub sensor: Option<synthcam_core::camera::sensor::SensorModel>,
    /// Motion during the exposure, when anything moves.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub motion: Option<super::motion::Motion>,
    /// Optics, when not the ideal pinhole.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub optics: Option<synthcam_core::camera::optics::Optics>,
}

impl From<RenderSettings> for RenderLabel {
    fn from(r: RenderSettings) -> Self {
        let motion = (!r.effects.motion.is_still()).then_some(r.effects.motion);
        let optics = (r.effects.optics != synthcam_core::camera::optics::Optics::default()).then_some(r.effects.optics);
        Self {
            samples: r.samples,
            noise_sigma: r.noise_sigma,
            blur_sigma_px: r.blur_sigma_px,
            seed: r.seed,
            bit_depth: r.bit_depth,
            sensor: r.effects.sensor,
            motion,
            optics,
        }
    }
}

/// Compute the truth labels of `scene`.
pub fn truth_labels(scene: &Scene) -> TruthLabels {
    let tracer = Tracer::new(scene);
    let pts = scene.target.feature_points_m();
    let kind = scene.target.feature_kind();
    let blobs = dot_blobs(scene, &tracer, &CentroidSampling::TRUTH);
    let features = pts
        .par_iter()
        .enumerate()
        .map(|(id, p)| {
            let p_cam = scene.cam_from_target * p;
            let proj = scene.camera.project(&p_cam);
            let occluded = super::objects::occluded(&scene.objects, &p_cam);
            let (irradiance, specular, in_shadow) = feature_light(scene, &p_cam);
            let mut label = FeatureLabel {
                id,
                point_target_m: [p.x, p.y, p.z],
                pixel_px: [proj.pixel_px.x, proj.pixel_px.y],
                depth_m: p_cam.z,
                in_front: proj.in_front,
                in_image: proj.in_image,
                visible: proj.visible() && !occluded,
                occluded,
                centroid_px: None,
                area_px: None,
                area_centroid_px: None,
                effects: super::effect_truth::effect_label(scene, p),
                irradiance,
                specular,
                in_shadow,
            };
            if kind == FeatureKind::Dot {
                if let Some(b) = blobs[id] {
                    label.area_px = Some(b.area_px);
                    label.centroid_px = Some(b.centroid_px);
                    label.area_centroid_px = Some(b.area_centroid_px);
                } else {
                    label.visible = false;
                }
            }
            label
        })
        .collect();
    let rot = scene.cam_from_target.rotation.to_rotation_matrix();
    let m = rot.matrix();
    let rvec = rvec_from_rotation(&rot);
    let t = scene.cam_from_target.translation.vector;
    TruthLabels {
        version: 1,
        pixel_convention: "OpenCV: the centre of the top-left pixel is (0, 0), u right, v down".into(),
        camera: CameraSpec::from_model(&scene.camera),
        cam_from_target: PoseLabel {
            r: [[m[(0, 0)], m[(0, 1)], m[(0, 2)]], [m[(1, 0)], m[(1, 1)], m[(1, 2)]], [m[(2, 0)], m[(2, 1)], m[(2, 2)]]],
            rvec: [rvec.x, rvec.y, rvec.z],
            t_m: [t.x, t.y, t.z],
        },
        target_kind: scene.target.kind_name().into(),
        feature_kind: kind,
        grid: grid_of(&scene.target),
        render: scene.render.into(),
        features,
        markers: marker_labels(scene),
    }
}

/// The truth's `grid` of a target.
fn grid_of(target: &Target) -> [u32; 2] {
    match target {
        Target::Chessboard(b) => b.inner_corner_count(),
        Target::DotGrid(g) => [g.n, g.n],
        Target::SPath(s) => [s.path.points_m.len() as u32, 1],
        Target::Charuco(c) => [c.board.squares[0] - 1, c.board.squares[1] - 1],
        Target::AprilGrid(g) => [4, g.grid.tags[0] * g.grid.tags[1]],
    }
}

/// The markers of a coded board, projected.
fn marker_labels(scene: &Scene) -> Vec<MarkerLabel> {
    let markers: Vec<(u32, [nalgebra::Point3<f64>; 4])> = match &scene.target {
        Target::Charuco(c) => c.board.markers().iter().map(|m| (m.id, m.corners_m)).collect(),
        Target::AprilGrid(g) => (0..g.grid.tags[0] * g.grid.tags[1]).map(|k| (g.grid.first_id + k, g.grid.tag_corners_m(k))).collect(),
        _ => return Vec::new(),
    };
    markers
        .iter()
        .map(|(id, corners_m)| {
            let cam = corners_m.map(|q| scene.cam_from_target * q);
            let p = cam.map(|q| scene.camera.project(&q));
            let hidden = cam.iter().any(|q| super::objects::occluded(&scene.objects, q));
            MarkerLabel { id: *id, corners_px: p.map(|p| [p.pixel_px.x, p.pixel_px.y]), visible: !hidden && p.iter().all(|p| p.visible()) }
        })
        .collect()
}
