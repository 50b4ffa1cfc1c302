//! Where a fisheye bends rays across one pixel more than the renderer's affine footprint holds.
//!
//! The shader maps every sub-sample and every board line of a pixel through the ray of its centre
//! and the Jacobian `d(ray)/d(pixel)` there (one inversion per pixel). Far off the axis of a
//! wide fisheye (beyond about 105 degrees) the map bends noticeably within one pixel: at 139
//! degrees of a 280-degree lens the linearised corner rays were 0.009 px off the exact ones and
//! edge pixels 1.1 grey levels off the exact reference (measured, `tests/e2e/lens_models.rs`).
//! There the fine pass splits the pixel into 2 x 2 or 4 x 4 sub-pixels, each with its own exact
//! ray and Jacobian; the bend of a sub-pixel falls with the square of its size. This module finds,
//! per camera, the distorted radii (normalised, `|K^-1 q|`) beyond which each split is needed.

use nalgebra::{Matrix3x2, Point2, Vector2, Vector3};
use rayon::prelude::*;

use synthcam_core::camera::{CameraModel, Lens};

/// Largest bend (pixels: the distance between a pixel corner's exact ray and the linearised one,
/// mapped back through the Jacobian) a pixel is rendered with unsplit.
pub const BEND_TOLERANCE_PX: f64 = 0.002;

/// Directions (degrees from the image x axis) scanned from the principal point.
const DIRECTIONS: usize = 16;
/// Scan step along each direction, pixels.
const STEP_PX: f64 = 2.0;

/// Distorted normalised radii beyond which a pixel is split into 2 x 2 and into 4 x 4 sub-pixels
/// (`f64::INFINITY`: never). Only a fisheye bends enough to split; other lenses return infinity.
pub fn split_radii(cam: &CameraModel) -> [f64; 2] {
    if !matches!(cam.lens, Lens::Fisheye(_)) {
        return [f64::INFINITY; 2];
    }
    // Each direction costs thousands of inversions (tens of ms): scanned in parallel.
    (0..DIRECTIONS).into_par_iter().map(|i| direction_radii(cam, i)).reduce(|| [f64::INFINITY; 2], |a, b| [a[0].min(b[0]), a[1].min(b[1])])
}

/// [`split_radii`] along direction `i` of [`DIRECTIONS`] from the principal point.
fn direction_radii(cam: &CameraModel, i: usize) -> [f64; 2] {
    let mut radii = [f64::INFINITY; 2];
    let k = &cam.intrinsics;
    let centre = Point2::new(k.cx, k.cy);
    let reach = f64::from(cam.size.width.max(cam.size.height)) * 2.0;
    let a = std::f64::consts::TAU * i as f64 / DIRECTIONS as f64;
    let u = Vector2::new(a.cos(), a.sin());
    let mut r = STEP_PX;
    while r < reach {
        let q = centre + u * r;
        if !cam.size.contains_px(&q) {
            break;
        }
        let Some(b) = bend_px(cam, q) else { break };
        let rd = k.pixel_to_normalized(&q).norm();
        if b > BEND_TOLERANCE_PX {
            radii[0] = radii[0].min(rd);
        }
        // A 4 x 4 split shrinks the bend 16-fold, a 2 x 2 one 4-fold.
        if b > 4.0 * BEND_TOLERANCE_PX {
            radii[1] = radii[1].min(rd);
            break;
        }
        r += STEP_PX;
    }
    radii
}

/// The bend of pixel `q` (see [`BEND_TOLERANCE_PX`]); `None` where a corner has no ray.
pub fn bend_px(cam: &CameraModel, q: Point2<f64>) -> Option<f64> {
    let ray = |p: Point2<f64>| cam.unproject_ray(&p).ok().map(|r| r.normalize());
    let h = 1e-3;
    let (ex, ey) = (Vector2::new(h, 0.0), Vector2::new(0.0, h));
    let d0 = ray(q)?;
    let j = Matrix3x2::from_columns(&[(ray(q + ex)? - ray(q - ex)?) / (2.0 * h), (ray(q + ey)? - ray(q - ey)?) / (2.0 * h)]);
    let pinv = (j.transpose() * j).try_inverse()? * j.transpose();
    let mut worst: f64 = 0.0;
    for o in [Vector2::new(-0.5, -0.5), Vector2::new(0.5, -0.5), Vector2::new(-0.5, 0.5), Vector2::new(0.5, 0.5)] {
        let exact: Vector3<f64> = ray(q + o)?;
        let linear = (d0 + j * o).normalize();
        worst = worst.max((pinv * (linear - exact)).norm());
    }
    Some(worst)
}

#[cfg(test)]
mod tests {
    use super::*;
    use synthcam_core::camera::{Fisheye, ImageSize, Intrinsics};

    fn wide() -> CameraModel {
        CameraModel {
            size: ImageSize { width: 640, height: 512 },
            intrinsics: Intrinsics { fx: 125.0, fy: 126.25, cx: 319.5, cy: 255.5, skew: 0.0 },
            lens: Lens::Fisheye(Fisheye { k: [0.02, -0.005, 0.0, 0.0] }),
        }
    }

    #[test]
    fn a_wide_fisheye_splits_far_off_its_axis_only() {
        let cam = wide();
        let [r2, r4] = split_radii(&cam);
        // Equidistant-like: rd is about the angle from the axis in radians.
        assert!(r2 > 1.2 && r2 < r4 && r4 < 2.6, "{r2} {r4}");
        // The bend grows towards the edge: small at 20 degrees, past the tolerance at 139.
        assert!(bend_px(&cam, Point2::new(319.5 + 45.0, 255.5)).expect("ray") < 0.5 * BEND_TOLERANCE_PX);
        assert!(bend_px(&cam, Point2::new(607.0, 244.0)).expect("ray") > 2.0 * BEND_TOLERANCE_PX);
        assert_eq!(split_radii(&CameraModel::sxga_1500px()), [f64::INFINITY; 2]);
    }
}
