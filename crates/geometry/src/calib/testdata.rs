//! Synthetic views shared by the calibration tests.

use nalgebra::{Isometry3, Point3, Translation3, UnitQuaternion, Vector2, Vector3};
use rand::Rng;
use rand_distr::{Distribution, Normal};

use super::refine::View;
use synthcam_core::camera::CameraModel;

/// The `cols x rows` board points (`square` apart, z = 0), row by row.
pub(crate) fn board(cols: usize, rows: usize, square: f64) -> Vec<Point3<f64>> {
    (0..rows).flat_map(|r| (0..cols).map(move |c| Point3::new(c as f64 * square, r as f64 * square, 0.0))).collect()
}

/// `n` views of an 8 x 6 board (3 cm squares) 0.3-0.45 m away, its centre up to `max_deg` off
/// the axis, tilted by up to 0.5 rad; only views wholly in the image; with their
/// `cam_from_board` poses.
pub(crate) fn wide_scene(cam: &CameraModel, n: usize, max_deg: f64, rng: &mut impl Rng) -> (Vec<View>, Vec<Isometry3<f64>>) {
    let pts = board(8, 6, 0.03);
    let (mut views, mut poses) = (Vec::new(), Vec::new());
    while views.len() < n {
        let (off, around) = (rng.random_range(0.0..max_deg).to_radians(), rng.random_range(0.0..std::f64::consts::TAU));
        let dir = Vector3::new(off.sin() * around.cos(), off.sin() * around.sin(), off.cos());
        let face = UnitQuaternion::rotation_between(&Vector3::z(), &dir).unwrap_or_else(UnitQuaternion::identity);
        let tilt_axis = nalgebra::Unit::new_normalize(Vector3::new(rng.random_range(-1.0..1.0), rng.random_range(-1.0..1.0), 0.0));
        let rot = face * UnitQuaternion::from_axis_angle(&tilt_axis, rng.random_range(0.0..0.5));
        let t = dir * rng.random_range(0.3..0.45) - rot * Vector3::new(0.105, 0.075, 0.0);
        let pose = Isometry3::from_parts(Translation3::from(t), rot);
        let v: View = pts.iter().map(|p| (*p, cam.project(&(pose * p)))).filter(|(_, pr)| pr.visible()).map(|(p, pr)| (p, pr.pixel_px)).collect();
        if v.len() == pts.len() {
            views.push(v);
            poses.push(pose);
        }
    }
    (views, poses)
}

/// [`wide_scene`]'s views.
pub(crate) fn wide_views(cam: &CameraModel, n: usize, max_deg: f64, rng: &mut impl Rng) -> Vec<View> {
    wide_scene(cam, n, max_deg, rng).0
}

/// `views` with independent Gaussian noise of `sigma` px on every pixel coordinate.
pub(crate) fn with_noise(views: &[View], sigma: f64, rng: &mut impl Rng) -> Vec<View> {
    let noise = Normal::new(0.0, sigma).expect("sigma");
    views.iter().map(|v| v.iter().map(|(x, q)| (*x, q + Vector2::new(noise.sample(rng), noise.sample(rng)))).collect()).collect()
}
