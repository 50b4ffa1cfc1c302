//! rerun recordings (`.rrd`, the `rerun` cargo feature): servo runs ([`write_servo_rrd`]), open
//! scenario runs ([`write_loop_rrd`]) and datasets ([`write_dataset_rrd`]), for `rerun FILE.rrd`.
//!
//! The entities and timelines are those of the Python recorder (`synthcam.rerun_log`), so one
//! reader (`synthcam.rerun_log.RecordedRun`, `benches/rerun_readback.py`) reads both:
//! - `world` (right-handed, Z up), `world/camera` (`Transform3D`: `world_from_cam`),
//!   `world/camera/image` (`Pinhole`, static; the frame as a PNG `EncodedImage`),
//!   `world/camera/image/detected`, `.../truth`, `.../desired` (`Points2D`, feature ids as
//!   keypoint ids; the desired ones static), `world/target` (`world_from_target`, static: the
//!   runs' targets do not move; the Python recorder logs both per step), `world/goal_camera`
//!   (+ `/image`, static),
//!   `joints/q<i>` (rad), `command/qdot<i>` (rad/s), `error/pixel_rms_px` (detected vs desired),
//!   `error/detection_rms_px` (detected vs truth), `error/pose_mm`, `error/pose_deg` (the true
//!   camera against the goal), `features/detected`, `features/matched`, `timing/render_ms`,
//!   `timing/detect_ms`, `camera_info` (markdown: the lens, which `Pinhole` cannot show);
//! - timelines `step` (sequence) and `sim_time` (duration, one step a frame period).
//!
//! Pixels: synthcam's follow OpenCV (the top-left pixel's centre at (0, 0)); rerun puts that
//! centre at (0.5, 0.5), so every 2-D position and the pinhole's principal point are logged
//! shifted by [`PIXEL_OFFSET`].
//!
//! The file is written under a temporary name beside `path` and renamed when complete: a failed
//! run leaves no file at `path`.

mod dataset;
mod runs;

use std::path::{Path, PathBuf};

use nalgebra::{Isometry3, Point2};
use rerun::RecordingStream;

use super::{tmp_path, FormatError};
use synthcam_scene::file::CameraSpec;

pub use dataset::write_dataset_rrd;
pub use runs::{write_loop_rrd, write_servo_rrd};

/// Added to every OpenCV pixel (and the principal point) logged.
pub const PIXEL_OFFSET: f64 = 0.5;

/// What a recording holds.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub struct RrdCounts {
    /// Frames (images) logged.
    pub frames: usize,
    /// Steps (or dataset images) logged.
    pub steps: usize,
    /// Bytes of the file.
    pub bytes: u64,
}

/// A recording being written: a temporary file, renamed to its path by [`Rrd::finish`] (dropped
/// before, the temporary file is removed).
pub(crate) struct Rrd {
    pub(crate) rec: RecordingStream,
    path: PathBuf,
    tmp: PathBuf,
    done: bool,
}

fn rerun_err(path: &Path, e: impl std::fmt::Display) -> FormatError {
    FormatError::Rerun { path: path.display().to_string(), reason: e.to_string() }
}

impl Rrd {
    /// Start a recording at `path` (application id "synthcam", recording name `name`).
    pub(crate) fn create(path: &Path, name: &str) -> Result<Self, FormatError> {
        if path.is_dir() {
            return Err(rerun_err(path, "it is a directory"));
        }
        if let Some(parent) = path.parent().filter(|p| !p.as_os_str().is_empty()) {
            std::fs::create_dir_all(parent).map_err(|e| super::write_err(parent, e))?;
        }
        let tmp = tmp_path(path);
        // The file sink opens the file on a thread of its own: create it here so that an
        // unwritable place is this call's error.
        std::fs::File::create(&tmp).map_err(|e| super::write_err(&tmp, e))?;
        let rec = rerun::RecordingStreamBuilder::new("synthcam").save(&tmp).map_err(|e| rerun_err(path, e))?;
        let rrd = Rrd { rec, path: path.to_path_buf(), tmp, done: false };
        rrd.log_static("world", &rerun::ViewCoordinates::RIGHT_HAND_Z_UP())?;
        rrd.rec.send_recording_name(name).map_err(|e| rerun_err(path, e))?;
        Ok(rrd)
    }

    pub(crate) fn err(&self, e: impl std::fmt::Display) -> FormatError {
        rerun_err(&self.path, e)
    }

    pub(crate) fn log(&self, entity: &str, what: &impl rerun::AsComponents) -> Result<(), FormatError> {
        self.rec.log(entity, what).map_err(|e| self.err(e))
    }

    pub(crate) fn log_static(&self, entity: &str, what: &impl rerun::AsComponents) -> Result<(), FormatError> {
        self.rec.log_static(entity, what).map_err(|e| self.err(e))
    }

    /// A curve's point at the current time.
    pub(crate) fn scalar(&self, entity: &str, value: f64) -> Result<(), FormatError> {
        self.log(entity, &rerun::Scalars::single(value))
    }

    /// Step `step` on the `step` timeline, `step x period_s` on `sim_time`.
    pub(crate) fn at_step(&self, step: u64, period_s: f64) {
        self.rec.set_time_sequence("step", i64::try_from(step).unwrap_or(i64::MAX));
        self.rec.set_duration_secs("sim_time", step as f64 * period_s);
    }

    /// The camera's pinhole (static) at `entity` and, once, its lens as markdown (`camera_info`).
    pub(crate) fn camera(&self, entity: &str, cam: &CameraSpec) -> Result<(), FormatError> {
        let o = PIXEL_OFFSET as f32;
        // rerun's matrix is column-major: columns (fx, 0, 0), (skew, fy, 0), (cx, cy, 1).
        let k = [[cam.fx as f32, 0.0, 0.0], [cam.skew as f32, cam.fy as f32, 0.0], [cam.cx as f32 + o, cam.cy as f32 + o, 1.0]];
        let pinhole = rerun::Pinhole::new(rerun::components::PinholeProjection::from(k))
            .with_resolution([cam.width as f32, cam.height as f32])
            .with_camera_xyz(rerun::components::ViewCoordinates::RDF)
            .with_image_plane_distance(0.1);
        self.log_static(entity, &pinhole)
    }

    /// `camera_info`: the camera model as markdown (static).
    pub(crate) fn camera_info(&self, title: &str, cam: &CameraSpec) -> Result<(), FormatError> {
        let dist = cam.dist.clone().unwrap_or_default();
        let text = format!(
            "# {title}: camera\n\n- image: {} x {} px\n- model: `{:?}`, distortion coefficients `{dist:?}`{}{}\n- K (OpenCV): fx = {}, fy = {}, cx = {}, cy = {}, skew = {}\n\n\
             **rerun's Pinhole shows no lens distortion**: the frustum and any 3-D point rerun projects use the undistorted pinhole; \
             the image and the 2-D features are the real (distorted) ones.\n\n2-D positions are OpenCV pixels + {PIXEL_OFFSET}; the \
             Pinhole's principal point is (cx + {PIXEL_OFFSET}, cy + {PIXEL_OFFSET}).",
            cam.width,
            cam.height,
            cam.model,
            cam.xi.map(|x| format!(", xi {x}")).unwrap_or_default(),
            cam.alpha.map(|a| format!(", alpha {a}")).unwrap_or_default(),
            cam.fx,
            cam.fy,
            cam.cx,
            cam.cy,
            cam.skew
        );
        self.log_static("camera_info", &rerun::TextDocument::from_markdown(text))
    }

    /// A pose as rerun's `Transform3D` (`parent_from_child`).
    pub(crate) fn pose(&self, entity: &str, parent_from_child: &Isometry3<f64>, is_static: bool) -> Result<(), FormatError> {
        let t = parent_from_child.translation.vector.cast::<f32>();
        let q = parent_from_child.rotation.coords.cast::<f32>();
        let tf = rerun::Transform3D::from_translation_rotation([t.x, t.y, t.z], rerun::Quaternion::from_xyzw([q.x, q.y, q.z, q.w]));
        if is_static {
            self.log_static(entity, &tf)
        } else {
            self.log(entity, &tf)
        }
    }

    /// Points (OpenCV pixels) with their ids, as `Points2D` in rerun's pixel convention.
    pub(crate) fn points(&self, entity: &str, pts: &[(usize, Point2<f64>)], style: PointStyle) -> Result<(), FormatError> {
        self.log(entity, &Self::points_2d(pts, style))
    }

    /// [`Rrd::points`]' archetype, for a caller that logs it static.
    pub(crate) fn points_2d(pts: &[(usize, Point2<f64>)], style: PointStyle) -> rerun::Points2D {
        let o = PIXEL_OFFSET;
        let pos: Vec<[f32; 2]> = pts.iter().map(|(_, p)| [(p.x + o) as f32, (p.y + o) as f32]).collect();
        let ids: Vec<u16> = pts.iter().map(|(i, _)| u16::try_from(*i).unwrap_or(u16::MAX)).collect();
        rerun::Points2D::new(pos)
            .with_keypoint_ids(ids)
            .with_colors([rerun::Color::from_rgb(style.rgb[0], style.rgb[1], style.rgb[2])])
            .with_radii([rerun::Radius::new_ui_points(style.radius)])
            .with_draw_order(style.order)
    }

    /// A frame as a PNG `EncodedImage` (lossless, a fraction of the raw size).
    pub(crate) fn frame(&self, entity: &str, png: Vec<u8>) -> Result<(), FormatError> {
        self.log(entity, &rerun::EncodedImage::from_file_contents(png).with_media_type(rerun::MediaType::PNG))
    }

    /// Flush, close and move the file to its path; returns its size.
    pub(crate) fn finish(mut self) -> Result<u64, FormatError> {
        self.rec.flush_blocking().map_err(|e| self.err(e))?;
        self.rec.disconnect();
        std::fs::rename(&self.tmp, &self.path).map_err(|e| super::write_err(&self.path, e))?;
        self.done = true;
        std::fs::metadata(&self.path).map(|m| m.len()).map_err(|e| super::write_err(&self.path, e))
    }
}

impl Drop for Rrd {
    fn drop(&mut self) {
        if !self.done {
            self.rec.disconnect();
            let _ = std::fs::remove_file(&self.tmp);
        }
    }
}

/// How a set of points is drawn.
#[derive(Debug, Clone, Copy)]
pub(crate) struct PointStyle {
    rgb: [u8; 3],
    radius: f32,
    order: f32,
}

/// Detected features: green, over the truth and the goal.
pub(crate) const DETECTED: PointStyle = PointStyle { rgb: [40, 220, 40], radius: 3.0, order: 30.0 };
/// True projections: small, blue, on top.
pub(crate) const TRUTH: PointStyle = PointStyle { rgb: [60, 150, 255], radius: 1.5, order: 40.0 };
/// Desired features: red, under the others.
pub(crate) const DESIRED: PointStyle = PointStyle { rgb: [255, 60, 60], radius: 4.0, order: 20.0 };
