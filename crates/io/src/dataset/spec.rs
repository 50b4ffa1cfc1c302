//! Dataset specs: a versioned TOML file describing `count` images of one camera and target under
//! randomly sampled poses.
//!
//! ```toml
//! version = 1
//! count = 200
//! seed = 7
//! [camera]            # as in a scene file (scene/file.rs `CameraSpec`)
//! [target]            # as in a scene file (`TargetTable`)
//! [render]            # as in a scene file, without `seed` (per-image seeds derive from `seed`)
//! [poses]
//! mode = "board"      # or "course", "robot"; see [`PosesSpec`]
//! ```
//!
//! Unknown fields are errors; every invalid value is reported as a [`SpecError`] naming its field.

use super::error::SpecError;
use serde::Deserialize;

use synthcam_core::camera::CameraModel;
use synthcam_core::robot::Cell;
use synthcam_core::target::Target;
use synthcam_scene::file::{CameraSpec, RenderSpec, TargetTable};
use synthcam_scene::RenderSettings;

/// The spec format this build reads.
pub const SPEC_VERSION: u32 = 1;

/// Largest `count` (image names have six digits).
pub const MAX_COUNT: u64 = 1_000_000;

/// A whole dataset spec file.
#[derive(Debug, Clone, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct DatasetSpec {
    /// Format version, must be [`SPEC_VERSION`].
    pub version: u32,
    /// Number of images, k = 0..count.
    pub count: u64,
    /// Master seed: image k's pose and noise seed depend only on (seed, k).
    pub seed: u64,
    /// `[camera]` (or `[[cameras]]`, a rig).
    #[serde(default)]
    pub camera: Option<CameraSpec>,
    /// `[[cameras]]`: a rig (as in scene files: each a camera table plus `name` and
    /// `rig_from_cam`); every camera of image k sees the same target pose, its images in
    /// `images/<name>/`. The poses are sampled in the first camera's frame.
    #[serde(default)]
    pub cameras: Vec<synthcam_scene::file::rig::RigCameraSpec>,
    /// `[target]`.
    pub target: TargetTable,
    /// `[render]` (optional; `seed` is not allowed here).
    #[serde(default)]
    pub render: RenderSpec,
    /// `[poses]`.
    pub poses: PosesSpec,
    /// `[sensor]` (optional; as in scene files).
    #[serde(default)]
    pub sensor: Option<synthcam_core::camera::sensor::SensorModel>,
    /// `[optics]` (optional).
    #[serde(default)]
    pub optics: Option<synthcam_scene::file::effects::OpticsSpec>,
    /// `[motion]` (optional).
    #[serde(default)]
    pub motion: Option<synthcam_scene::motion::Motion>,
    /// `[output]` (optional).
    #[serde(default)]
    pub output: Option<synthcam_scene::file::effects::OutputSpec>,
    /// `[ranges]` (optional): numeric render and effect fields sampled uniformly per image from
    /// `[lo, hi]`, e.g. `"sensor.exposure_s" = [0.002, 0.02]`
    /// ([`synthcam_scene::effect_fields::FIELDS`]).
    #[serde(default)]
    pub ranges: std::collections::BTreeMap<String, Vec<f64>>,
    /// `[[object]]` tables: meshes fixed in the camera or the target frame (as in scene files).
    #[serde(default, rename = "object")]
    pub objects: Vec<synthcam_scene::file::ObjectSpec>,
    /// `[[occluder]]` tables: random occluders ([`super::objects`]).
    #[serde(default, rename = "occluder")]
    pub occluders: Vec<super::objects::OccluderSpec>,
    /// `[[light]]` tables (as in scene files; `[render] ambient` the ambient term).
    #[serde(default, rename = "light")]
    pub lights: Vec<synthcam_scene::file::LightSpec>,
    /// `[background]` (as in scene files, plus `folder` and `yaw_deg` drawn per image:
    /// [`super::background`]).
    #[serde(default)]
    pub background: Option<synthcam_scene::file::background::BackgroundSpec>,
    /// Also write each image's depth (`.depth.npy`, [`super::extras`]).
    #[serde(default)]
    pub depth: bool,
    /// Also write each image's instance mask (`.mask.png`).
    #[serde(default)]
    pub masks: bool,
}

/// `[poses]`: how `cam_from_target` is sampled.
#[derive(Debug, Clone, Deserialize)]
#[serde(tag = "mode", rename_all = "kebab-case", deny_unknown_fields)]
pub enum PosesSpec {
    /// A planar target in front of the camera: its centre (the centre of its feature points'
    /// bounding box) at `(offset_x_m, offset_y_m, distance_m)` in the camera frame, its normal
    /// (target +z) at `tilt_deg` from the optical axis about a uniformly random axis in the image
    /// plane, then turned by `roll_deg` about the optical axis. Every range is `[lo, hi]`, sampled
    /// uniformly (lo = hi gives a constant).
    Board {
        /// Distance of the target centre along the optical axis, metres: > 0, or any value for a
        /// fisheye that reaches beyond 90 degrees (<= 0: beside or behind the camera plane).
        distance_m: Vec<f64>,
        /// Angle between the optical axis and the target normal, degrees, within [0, 90).
        tilt_deg: Vec<f64>,
        /// Rotation about the optical axis, degrees (default [0, 0]).
        roll_deg: Option<Vec<f64>>,
        /// Offset of the target centre along camera x, metres (default [0, 0]).
        offset_x_m: Option<Vec<f64>>,
        /// Offset of the target centre along camera y, metres (default [0, 0]).
        offset_y_m: Option<Vec<f64>>,
        /// What `tilt_deg` is measured from: `"axis"` (the optical axis, default) or `"sight"`
        /// (the line of sight to the target centre: the board faces the camera wherever it is in
        /// the field of view, as one holds a board at the edge of a fisheye's view).
        tilt_from: Option<TiltFrom>,
        /// Re-draw until every feature point projects inside the image (default true).
        full_target_visible: Option<bool>,
        /// Partial views: re-draw until the fraction of feature points inside the image (by
        /// `margin_px`) lies in `[lo, hi]`, within [0, 1] (replaces `full_target_visible`; for
        /// coded boards, which are detected in part).
        inside_fraction: Option<Vec<f64>>,
        /// Margin of the visibility constraint, pixels (default 0).
        margin_px: Option<f64>,
        /// A rig: the visibility constraint must hold in at least this many cameras (default 1;
        /// views that one camera alone sees are normal in rig data).
        min_cameras: Option<usize>,
    },
    /// The course's calibration views (sweep.rs): a rotation of uniform angle in [0, pi/10] about a
    /// uniform random axis, camera position x, y in [-0.4, 0.4] m and z in [-6, -3] m relative to
    /// the target centre, re-drawn until every feature point is in the image.
    Course {
        /// Margin of the visibility constraint, pixels (default 0).
        margin_px: Option<f64>,
    },
    /// The hand-eye scenario's robot (the S-path target's frame is the world): joints
    /// q = q0 + U(-spread, spread) per joint, `cam_from_target` = (world_from_base *
    /// base_from_tool(q) * tool_from_cam)^-1; fields default to the course's variant A
    /// (`assets/scenarios/course.toml`).
    Robot {
        /// Centre of the joint sampling, radians.
        q0_rad: Option<[f64; 6]>,
        /// Uniform perturbation per joint, radians.
        spread_rad: Option<f64>,
        /// Translation of `world_from_base` (rotation identity), metres.
        base_t_m: Option<[f64; 3]>,
        /// Translation of `tool_from_cam`, metres.
        tool_from_cam_t_m: Option<[f64; 3]>,
        /// Rotation of `tool_from_cam`, rows.
        #[serde(rename = "tool_from_cam_R")]
        tool_from_cam_r: Option<[[f64; 3]; 3]>,
        /// Re-draw until every feature point projects inside the image (default true).
        full_target_visible: Option<bool>,
        /// Margin of the visibility constraint, pixels (default 0).
        margin_px: Option<f64>,
    },
}

/// What a board's tilt is measured from ([`PosesSpec::Board`]'s `tilt_from`).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, Deserialize)]
#[serde(rename_all = "kebab-case")]
pub enum TiltFrom {
    /// The optical axis.
    #[default]
    Axis,
    /// The line of sight from the camera to the target centre.
    Sight,
}

/// Validated board-mode ranges (see [`PosesSpec::Board`]).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct BoardRanges {
    /// Distance, metres.
    pub distance_m: [f64; 2],
    /// Tilt, degrees.
    pub tilt_deg: [f64; 2],
    /// Roll, degrees.
    pub roll_deg: [f64; 2],
    /// Offset along camera x, metres.
    pub offset_x_m: [f64; 2],
    /// Offset along camera y, metres.
    pub offset_y_m: [f64; 2],
    /// What the tilt is measured from.
    pub tilt_from: TiltFrom,
}

/// How poses are drawn, validated.
#[derive(Debug, Clone, PartialEq)]
pub enum PoseMode {
    /// [`PosesSpec::Board`].
    Board(BoardRanges),
    /// [`PosesSpec::Course`].
    Course,
    /// [`PosesSpec::Robot`].
    Robot(Cell),
}

pub use rig::RigMember;

/// A validated spec: everything the generator needs.
#[derive(Debug, Clone, PartialEq)]
pub struct DatasetPlan {
    /// Number of images.
    pub count: u64,
    /// Master seed.
    pub seed: u64,
    /// Camera (a rig's first camera: the poses are sampled in its frame).
    pub camera: CameraModel,
    /// A rig's cameras, the first included (empty: one camera).
    pub rig: Vec<RigMember>,
    /// A rig: the visibility constraint must hold in at least this many cameras.
    pub min_cameras: usize,
    /// Target.
    pub target: Target,
    /// Render settings (the seed is replaced per image).
    pub render: RenderSettings,
    /// Pose sampling.
    pub mode: PoseMode,
    /// Whether every feature point must project inside the image.
    pub full_target_visible: bool,
    /// Partial views: the range of the fraction of feature points inside the image (overrides
    /// `full_target_visible`).
    pub inside_fraction: Option<[f64; 2]>,
    /// Margin of that constraint, pixels.
    pub margin_px: f64,
    /// Render and effect fields sampled per image from `[lo, hi]` (`[ranges]`), in name order.
    pub ranges: Vec<(String, [f64; 2])>,
    /// Fixed objects and random occluders, meshes loaded.
    pub objects: super::objects::DatasetObjects,
    /// Write depth and instance masks beside each image.
    pub extras: [bool; 2],
    /// The background, drawn per image.
    pub background: Option<super::background::DatasetBackground>,
}

fn invalid(field: &str, reason: impl Into<String>) -> SpecError {
    SpecError::InvalidField { field: field.into(), reason: reason.into() }
}

/// Check a `[lo, hi]` range (absent: `[0, 0]`): two finite values, lo <= hi, within `[min, max]`.
/// (Ranges are read as lists so that a wrong length is reported with the field's name.)
fn check_range(field: &str, r: Option<&Vec<f64>>, min: f64, max: f64) -> Result<[f64; 2], SpecError> {
    let r: [f64; 2] = match r.map(Vec::as_slice) {
        None => [0.0; 2],
        Some(&[lo, hi]) => [lo, hi],
        Some(v) => return Err(invalid(field, format!("must be a range [lo, hi], got {} values", v.len()))),
    };
    if r.iter().any(|v| !v.is_finite()) {
        return Err(invalid(field, format!("must be finite, got {r:?}")));
    }
    if r[0] > r[1] {
        return Err(invalid(field, format!("is inverted: lo {} > hi {}", r[0], r[1])));
    }
    if r[0] < min || r[1] > max {
        return Err(invalid(field, format!("must lie within [{min}, {max}], got {r:?}")));
    }
    Ok(r)
}

fn check_margin(field: &str, m: Option<f64>) -> Result<f64, SpecError> {
    let m = m.unwrap_or(0.0);
    if !(m >= 0.0) || !m.is_finite() {
        return Err(invalid(field, format!("must be finite and >= 0, got {m}")));
    }
    Ok(m)
}

fn check_finite<const N: usize>(field: &str, v: &[f64; N]) -> Result<(), SpecError> {
    if v.iter().any(|x| !x.is_finite()) {
        return Err(invalid(field, format!("must be finite, got {v:?}")));
    }
    Ok(())
}

impl DatasetSpec {
    /// Validate every field and build the plan (the feasibility of the pose constraint is checked
    /// separately by [`super::poses::check_feasible`]).
    ///
    /// # Errors
    /// The first invalid field.
    pub fn to_plan(&self) -> Result<DatasetPlan, SpecError> {
        self.to_plan_with(&super::MeshLibrary::new(std::path::Path::new(".")))
    }

    /// [`DatasetSpec::to_plan`], the `mesh` paths resolved by `meshes`.
    ///
    /// # Errors
    /// As [`DatasetSpec::to_plan`], and a mesh that does not load.
    pub fn to_plan_with(&self, meshes: &super::MeshLibrary) -> Result<DatasetPlan, SpecError> {
        if self.version != SPEC_VERSION {
            return Err(SpecError::Version { found: self.version, expected: SPEC_VERSION });
        }
        if self.count == 0 || self.count > MAX_COUNT {
            return Err(invalid("count", format!("must be in 1..={MAX_COUNT}, got {}", self.count)));
        }
        if self.render.seed.is_some() {
            return Err(invalid("render.seed", "per-image noise seeds derive from the top-level `seed`; remove it"));
        }
        let (camera, rig) = self.cameras_of()?;
        let target = self.target.to_target();
        let render = synthcam_scene::file::with_lights(
            synthcam_scene::file::effects::render_settings(&self.render, self.sensor, self.optics.as_ref(), self.motion, self.output.as_ref())?,
            &self.lights,
        )?;
        let ranges = self.effect_ranges(&render)?;
        // Validate camera, target and render settings with the scene's own rules (a pose straight
        // ahead keeps the depth check quiet; the sampled poses are checked per image).
        let probe = synthcam_scene::Scene {
            camera,
            target: target.clone(),
            cam_from_target: nalgebra::Isometry3::translation(0.0, 0.0, 1e3),
            render,
            objects: Vec::new(),
            background: None,
        };
        probe.validate()?;
        let (mode, full_target_visible, margin_px) = self.poses.to_mode(&target, &camera)?;
        let inside_fraction = self.poses.inside_fraction()?;
        let objects = super::objects::DatasetObjects::load(&self.objects, &self.occluders, meshes)?;
        if !objects.is_empty() {
            synthcam_scene::lighting::check_with_objects(&render.lighting)?;
        }
        if !rig.is_empty() && !objects.is_empty() {
            return Err(invalid("cameras", "objects and occluders are not placed for rigs yet: use one [camera]"));
        }
        let min_cameras = self.poses.min_cameras(rig.len())?;
        if !objects.is_empty() && (matches!(target, Target::SPath(_)) || render.effects.needs_views()) {
            return Err(invalid("object", "objects are rendered with planar targets and without defocus, motion or a rolling shutter"));
        }
        let extras = [self.depth, self.masks];
        let background = self.background.as_ref().map(|b| super::background::DatasetBackground::load(b, meshes)).transpose()?;
        if background.is_some() {
            synthcam_scene::background::check_target(&target)?;
        }
        Ok(DatasetPlan {
            count: self.count,
            seed: self.seed,
            camera,
            rig,
            min_cameras,
            target,
            render,
            mode,
            full_target_visible,
            inside_fraction,
            margin_px,
            ranges,
            objects,
            extras,
            background,
        })
    }

    /// The `[ranges]`, each checked: a known field, `lo <= hi`, and both ends valid settings.
    fn effect_ranges(&self, render: &RenderSettings) -> Result<Vec<(String, [f64; 2])>, SpecError> {
        let mut out = Vec::new();
        for (field, r) in &self.ranges {
            let [lo, hi] = check_range(&format!("ranges.{field}"), Some(r), f64::NEG_INFINITY, f64::INFINITY)?;
            for v in [lo, hi] {
                let mut probe = *render;
                synthcam_scene::effect_fields::set_field(&mut probe, field, v)?;
                probe.effects.validate()?;
                probe.lighting.validate()?;
            }
            out.push((field.clone(), [lo, hi]));
        }
        Ok(out)
    }
}

/// Parse and validate spec text (TOML).
///
/// # Errors
/// [`SpecError::Parse`] (the parser's message names the field) or a validation error.
pub fn parse_dataset_spec(text: &str) -> Result<DatasetPlan, SpecError> {
    parse_dataset_spec_with(text, &super::MeshLibrary::new(std::path::Path::new(".")))
}

/// [`parse_dataset_spec`], the `mesh` paths resolved by `meshes`
/// ([`super::MeshLibrary::beside`] the spec file).
///
/// # Errors
/// As [`parse_dataset_spec`].
pub fn parse_dataset_spec_with(text: &str, meshes: &super::MeshLibrary) -> Result<DatasetPlan, SpecError> {
    let spec: DatasetSpec = toml::from_str(text).map_err(|e| SpecError::Parse(e.to_string()))?;
    spec.to_plan_with(meshes)
}

mod poses_spec;
mod rig;
#[cfg(test)]
mod tests;
