//! Initial intrinsics and poses for lenses without a useful pinhole homography (fisheye, Double
//! Sphere): the principal point at the image centre, then a 1-D search over the focal length.
//! For each candidate `f`, the pixels are unprojected with the model's base lens (equidistant
//! `theta = r / f`; Double Sphere `xi = 0, alpha = 0.5`), each view's pose comes from the
//! homography of the board to those rays, and the candidate's cost is the total reprojection
//! error. The best candidate seeds Levenberg-Marquardt.
//!
//! Reference: the same idea as OpenCV's `cv::fisheye::calibrate` initialisation (equidistant
//! start, principal point at the centre) and basalt's Double Sphere start (`xi = 0`,
//! `alpha = 0.5`), with the focal length searched instead of guessed.

use nalgebra::{Isometry3, Point2, Vector6};

use super::refine::{pose_vector, vector_of, IntrinsicVector, View};
use super::zhang::pose_from_homography;
use synthcam_core::camera::{CameraModel, ImageSize, Intrinsics, Lens, LensKind};

/// Candidate focal lengths, as fractions of the larger image side (log-spaced).
const F_LO: f64 = 0.05;
const F_HI: f64 = 3.0;
const F_STEPS: usize = 64;
/// Rays farther than this from the axis (radians) do not enter the homographies.
const MAX_HOMOGRAPHY_ANGLE: f64 = 1.3;
/// Points per view in the focal-length search (spread evenly over the view).
pub const SEARCH_POINTS: usize = 24;

/// The model's base lens: equidistant (fisheye, all `k` zero), Double Sphere `xi = 0`,
/// `alpha = 0.5`; the OpenCV models without distortion.
pub fn base_lens(kind: LensKind) -> Lens {
    match kind {
        LensKind::DoubleSphere => kind.lens(&[0.0, 0.5]),
        _ => kind.lens(&[]),
    }
}

/// The camera with the principal point at the image centre, focal length `f` and lens `lens`.
pub fn centred(size: ImageSize, lens: Lens, f: f64) -> CameraModel {
    let k = Intrinsics { fx: f, fy: f, cx: (f64::from(size.width) - 1.0) / 2.0, cy: (f64::from(size.height) - 1.0) / 2.0, skew: 0.0 };
    CameraModel { size, intrinsics: k, lens }
}

/// One view's pose under `cam`, and its sum of squared reprojection errors.
pub(super) fn view_pose(cam: &CameraModel, view: &View) -> Option<(Isometry3<f64>, f64)> {
    let (mut src, mut dst) = (Vec::new(), Vec::new());
    for (x, q) in view {
        let Ok(ray) = cam.unproject(q) else { continue };
        if ray.xy().norm().atan() < MAX_HOMOGRAPHY_ANGLE {
            src.push(x.xy());
            dst.push(Point2::from(ray.xy()));
        }
    }
    if src.len() < 4 {
        return None;
    }
    let h = synthcam_core::math::homography::homography(&src, &dst)?;
    let pose = pose_from_homography(&h, &Intrinsics { fx: 1.0, fy: 1.0, cx: 0.0, cy: 0.0, skew: 0.0 });
    let mut cost = 0.0;
    for (x, q) in view {
        let p = pose * x;
        // A fisheye maps points behind its camera plane too (theta from atan2), and so does a
        // Double Sphere lens within its field of view (beyond it, the error is large anyway).
        if !(p.z > 0.0 || cam.lens.kind() != LensKind::OpenCv) {
            return None;
        }
        cost += (cam.project_unchecked(&p) - q).norm_squared();
    }
    cost.is_finite().then_some((pose, cost))
}

/// About [`SEARCH_POINTS`] points of each view, spread evenly over it: what the searches score.
pub fn sparse(views: &[View]) -> Vec<View> {
    views.iter().map(|v| v.iter().step_by(v.len().div_ceil(SEARCH_POINTS).max(1)).copied().collect()).collect()
}

/// The sum of squared reprojection errors of `views` under `cam`, every view's pose solved from
/// its homography (`view_pose`); `None` where a view has no pose.
pub fn cost_under(cam: &CameraModel, views: &[View]) -> Option<f64> {
    views.iter().map(|v| view_pose(cam, v).map(|(_, c)| c)).sum()
}

/// The intrinsics vector and poses of the best focal length under the lens `lens` (its
/// parameters held), or `None` when no candidate gives a pose for every view.
pub fn initial(size: ImageSize, lens: Lens, views: &[View]) -> Option<(IntrinsicVector, Vec<Vector6<f64>>)> {
    let side = f64::from(size.width.max(size.height));
    let sparse = sparse(views);
    let mut best: Option<(f64, CameraModel)> = None;
    for i in 0..F_STEPS {
        let f = side * F_LO * (F_HI / F_LO).powf(i as f64 / (F_STEPS - 1) as f64);
        let cam = centred(size, lens, f);
        let Some(cost) = cost_under(&cam, &sparse) else { continue };
        if best.as_ref().is_none_or(|(c, _)| cost < *c) {
            best = Some((cost, cam));
        }
    }
    let (_, cam) = best?;
    let poses = views.iter().map(|v| view_pose(&cam, v).map(|(p, _)| pose_vector(&p))).collect::<Option<Vec<_>>>()?;
    Some((vector_of(&cam), poses))
}
