//! The S-path's entry in [`super::detect_with_camera`]: dots, their places on the path, residuals.

use super::{Detection, TargetSpec};
use crate::dots::{find_dots, DotParams};
use crate::s_path_fit::{index_s_path, path_residuals, unmeasured, SPathFitParams, SPathTrack};
use crate::{DetectError, ImageF32};
use synthcam_core::camera::CameraModel;
use synthcam_core::target::s_path::{build_s_path, planar_s};
use synthcam_core::target::{spherical_s, SPath};

/// [`super::detect_with_camera`] on one frame of a sequence (a servo loop's): the S-path's labels are
/// carried from the previous frame (`track`) where every dot moved less than
/// [`TRACK_FRACTION`](crate::s_path_fit::TRACK_FRACTION) of its spacing and the carried
/// labelling fits the path as well ([`SPathTrack::carry`]), and placed afresh otherwise; `track`
/// then remembers this frame. Other targets are detected as by [`super::detect_with_camera`].
///
/// # Errors
/// As [`super::detect_with_camera`].
pub fn detect_tracked(img: &ImageF32, spec: &TargetSpec, camera: Option<&CameraModel>, track: &mut SPathTrack) -> Result<Detection, DetectError> {
    match *spec {
        TargetSpec::SPath { points } => {
            super::check_camera(img, camera)?;
            detect_s_path(img, points, camera, Some(track))
        }
        _ => super::detect_with_camera(img, spec, camera),
    }
}

/// Detect the S-path of `points` points, placed by `camera`'s pose where it is known; with a
/// sequence's `track`, the previous frame's labels are carried where they can be
/// ([`SPathTrack::carry`]) and the frame is remembered for the next.
pub(super) fn detect_s_path(img: &ImageF32, points: usize, camera: Option<&CameraModel>, track: Option<&mut SPathTrack>) -> Result<Detection, DetectError> {
    let t0 = std::time::Instant::now();
    let dots = find_dots(img, &DotParams::default())?;
    let Some(path) = spherical_path(points) else {
        return Err(DetectError::BadParams { reason: "the S-path needs at least 2 points" });
    };
    let t1 = std::time::Instant::now();
    let carried = track.as_deref().and_then(|t| t.carry(&dots, &path));
    let tracked = carried.is_some();
    let indexed = carried.map_or_else(
        || index_s_path(&dots, &path, &SPathFitParams { camera: camera.copied(), image_centre_px: Some(img.centre_px()), ..SPathFitParams::default() }),
        Ok,
    );
    if let Some(t) = track {
        t.remember(&dots, indexed.as_deref().unwrap_or_default(), &path, tracked);
    }
    log::debug!("s-path: labels {}", if tracked { "carried from the previous frame" } else { "placed afresh" });
    log::debug!("s-path: {} dots found in {:.1} ms, indexed in {:.1} ms", dots.len(), (t1 - t0).as_secs_f64() * 1e3, t1.elapsed().as_secs_f64() * 1e3);
    match indexed {
        Ok(ordered) => {
            let (ordered, unmeasured) = unmeasured(ordered, &dots);
            Ok(Detection {
                found: true,
                points_px: ordered.iter().map(|d| d.centre_px).collect(),
                indices: Some(ordered.iter().map(|d| d.index).collect()),
                path_residuals: path_residuals(&ordered, &path),
                unmeasured: Some(unmeasured),
                ..Default::default()
            })
        }
        Err(DetectError::NotFound { reason }) => Ok(Detection { note: Some(reason), ..Default::default() }),
        Err(e) => Err(e),
    }
}

/// The S on its sphere ([`spherical_s`]), resampled to `points` points (cached for its own 101).
fn spherical_path(points: usize) -> Option<std::borrow::Cow<'static, SPath>> {
    static PATH: std::sync::OnceLock<SPath> = std::sync::OnceLock::new();
    let path = PATH.get_or_init(spherical_s);
    if points == path.len() {
        return Some(std::borrow::Cow::Borrowed(path));
    }
    let planar = planar_s().ok()?;
    let points_m = build_s_path(&planar, points).ok()?;
    Some(std::borrow::Cow::Owned(SPath { points_m, ..path.clone() }))
}
