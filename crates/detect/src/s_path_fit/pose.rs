//! A calibrated camera's pose fitted to path points and their (undistorted) images: what the
//! S-path's labelling fits where the camera is known ([`super::SPathFitParams::camera`]).
//!
//! Reference: Terzakis and Lourakis, "A Consistently Fast and Globally Optimal Solution to the
//! Perspective-n-Point Problem", ECCV 2020 (SQPnP, the start; crate `sqpnp_simple`); the
//! refinement is Gauss-Newton with Levenberg-Marquardt damping (Hartley and Zisserman, *Multiple
//! View Geometry*, 2nd ed., A6.2) on the left-multiplied rotation increment.

use super::dlt::Dlt;
use nalgebra::{Matrix2, Matrix2x3, Matrix2x6, Matrix3, Matrix3x4, Matrix6, Point2, Point3, Vector3, Vector6};
use synthcam_core::camera::Intrinsics;
use synthcam_core::math::so3::{project_to_so3, rotation_from_rvec, skew};

/// Gauss-Newton iterations (Levenberg-Marquardt damped).
const ITERATIONS: usize = 30;

/// A pose: rotation, translation, and its sum of squared reprojection errors (pixels^2).
type Pose = (Matrix3<f64>, Vector3<f64>, f64);

/// A refinement from the projective camera's start is kept where its RMS stays within this
/// factor of the projective camera's own ...
const NEAR_PROJECTIVE: f64 = 1.25;
/// ... plus this many pixels.
const NEAR_PROJECTIVE_PX: f64 = 0.25;

/// `K [R | t]` fitted to the correspondences (image points undistorted): Levenberg-Marquardt on
/// the six pose parameters over the reprojection error in pixels, started from the projective
/// camera `dlt` (its left 3 x 3 block, `K^-1`-mapped, projected onto the rotations). A projective
/// camera fits at least as well as any pose; where the refined pose stays near it
/// ([`NEAR_PROJECTIVE`]) it is kept, otherwise (a start from a nearly flat stretch, where the
/// DLT is poorly conditioned) SQPnP's global optimum of the object-space error is refined too and
/// the better of the two kept.
pub(super) fn fit_pose(k: &Intrinsics, world: &[Point3<f64>], image: &[Point2<f64>], dlt: Option<&Dlt>) -> Option<Matrix3x4<f64>> {
    let n = world.len().max(1) as f64;
    let from_dlt = dlt.and_then(|d| projective_start(k, &d.p)).map(|(r, t)| refine(k, world, image, r, t));
    let bound = dlt.map(|d| d.rms(world, image));
    let near = |pose: &Pose, bound: f64| (pose.2 / n).sqrt() <= NEAR_PROJECTIVE * bound + NEAR_PROJECTIVE_PX;
    let pose = match (from_dlt, bound) {
        (Some(pose), Some(b)) if near(&pose, b) => pose,
        (other, _) => {
            let global = sqpnp(k, world, image).map(|(r, t)| refine(k, world, image, r, t));
            [other, global].into_iter().flatten().min_by(|a, b| a.2.total_cmp(&b.2))?
        }
    };
    let mut rt = Matrix3x4::zeros();
    rt.fixed_view_mut::<3, 3>(0, 0).copy_from(&pose.0);
    rt.set_column(3, &pose.1);
    let out = k.matrix() * rt;
    out.iter().all(|v| v.is_finite()).then_some(out)
}

/// The pose nearest the projective camera `p`: `K^-1 P`'s left block projected onto the
/// rotations, its scale the mean singular value.
fn projective_start(k: &Intrinsics, p: &Matrix3x4<f64>) -> Option<(Matrix3<f64>, Vector3<f64>)> {
    let m = k.matrix().try_inverse()? * p;
    let a: Matrix3<f64> = m.fixed_view::<3, 3>(0, 0).into_owned();
    let (a, col) = if a.determinant() < 0.0 { (-a, -m.column(3).into_owned()) } else { (a, m.column(3).into_owned()) };
    let scale = a.singular_values().mean();
    (scale > 0.0 && scale.is_finite()).then(|| (project_to_so3(&a).into_inner(), col / scale))
}

/// Levenberg-Marquardt from `(r, t)` on the reprojection error.
fn refine(k: &Intrinsics, world: &[Point3<f64>], image: &[Point2<f64>], mut r: Matrix3<f64>, mut t: Vector3<f64>) -> Pose {
    let cost = |r: &Matrix3<f64>, t: &Vector3<f64>| -> f64 {
        world.iter().zip(image).map(|(x, u)| project(k, r, t, x).map_or(1e12, |q| (q - u).norm_squared())).sum()
    };
    let mut c = cost(&r, &t);
    let mut lambda = 1e-3;
    for _ in 0..ITERATIONS {
        let (mut h, mut g) = (Matrix6::<f64>::zeros(), Vector6::<f64>::zeros());
        for (x, u) in world.iter().zip(image) {
            let Some((q, j)) = pixel_jacobian(k, &r, &t, x) else { continue };
            h += j.transpose() * j;
            g += j.transpose() * (q - u);
        }
        let mut improved = false;
        for _ in 0..8 {
            let damped = h + Matrix6::from_diagonal(&(h.diagonal() * lambda));
            let Some(step) = damped.cholesky().map(|ch| ch.solve(&-g)) else {
                lambda *= 10.0;
                continue;
            };
            let r2 = rotation_from_rvec(&step.fixed_rows::<3>(0).into_owned()).into_inner() * r;
            let t2 = t + step.fixed_rows::<3>(3);
            let c2 = cost(&r2, &t2);
            if c2 < c {
                improved = c - c2 >= 1e-12 * c.max(1e-30);
                (r, t, c) = (r2, t2, c2);
                lambda = (lambda * 0.3).max(1e-9);
                break;
            }
            lambda *= 10.0;
        }
        if !improved {
            break;
        }
    }
    (r, t, c)
}

/// The pixel of world point `x` under pose `(r, t)` and its Jacobian with respect to the left
/// rotation increment `w` (`R <- exp(w) R`) and the translation: `d(pc)/dw = -[R x]_x`,
/// `d(pc)/dt = I` for the camera point `pc = R x + t`, through the pinhole's projection.
/// `None` behind the camera.
fn pixel_jacobian(k: &Intrinsics, r: &Matrix3<f64>, t: &Vector3<f64>, x: &Point3<f64>) -> Option<(Point2<f64>, Matrix2x6<f64>)> {
    let rx = r * x.coords;
    let pc = rx + t;
    let q = project(k, r, t, x)?;
    let iz = 1.0 / pc.z;
    let dn = Matrix2x3::new(iz, 0.0, -pc.x * iz * iz, 0.0, iz, -pc.y * iz * iz);
    let dk = Matrix2::new(k.fx, k.skew, 0.0, k.fy) * dn;
    let mut j = Matrix2x6::zeros();
    j.fixed_view_mut::<2, 3>(0, 0).copy_from(&(dk * -skew(&rx)));
    j.fixed_view_mut::<2, 3>(0, 3).copy_from(&dk);
    Some((q, j))
}

fn project(k: &Intrinsics, r: &Matrix3<f64>, t: &Vector3<f64>, x: &Point3<f64>) -> Option<Point2<f64>> {
    let pc = r * x.coords + t;
    (pc.z > 1e-9).then(|| k.normalized_to_pixel(&nalgebra::Vector2::new(pc.x / pc.z, pc.y / pc.z)))
}

/// The globally optimal pose of SQPnP (Terzakis and Lourakis, ECCV 2020) on normalised rays.
fn sqpnp(k: &Intrinsics, world: &[Point3<f64>], image: &[Point2<f64>]) -> Option<(Matrix3<f64>, Vector3<f64>)> {
    let p3: Vec<(f64, f64, f64)> = world.iter().map(|x| (x.x, x.y, x.z)).collect();
    let p2: Vec<(f64, f64)> = image.iter().map(|u| k.pixel_to_normalized(u)).map(|v| (v.x, v.y)).collect();
    let (r, t) = sqpnp_simple::sqpnp_solve(&p3, &p2)?;
    let r = rotation_from_rvec(&Vector3::new(r.0, r.1, r.2)).into_inner();
    let t = Vector3::new(t.0, t.1, t.2);
    (r.iter().chain(t.iter()).all(|v| v.is_finite())).then_some((r, t))
}

#[cfg(test)]
mod tests {
    use super::*;
    use nalgebra::{DVector, Rotation3};
    use synthcam_core::math::numdiff::central_diff;

    fn k() -> Intrinsics {
        Intrinsics { fx: 1200.0, fy: 1190.0, cx: 640.0, cy: 512.0, skew: 0.3 }
    }

    fn pose() -> (Matrix3<f64>, Vector3<f64>) {
        (Rotation3::from_euler_angles(0.3, -0.5, 1.2).into_inner(), Vector3::new(0.1, -0.2, 1.7))
    }

    #[test]
    fn the_jacobian_matches_finite_differences() {
        let (k, (r, t), x) = (k(), pose(), Point3::new(0.2, -0.1, 0.3));
        let (_, j) = pixel_jacobian(&k, &r, &t, &x).unwrap();
        let f = |p: &DVector<f64>| {
            let r2 = rotation_from_rvec(&Vector3::new(p[0], p[1], p[2])).into_inner() * r;
            let q = project(&k, &r2, &(t + Vector3::new(p[3], p[4], p[5])), &x).unwrap();
            DVector::from_vec(vec![q.x, q.y])
        };
        let num = central_diff(f, &DVector::zeros(6), 1e-6);
        for (a, b) in j.iter().zip(num.iter()) {
            assert!((a - b).abs() < 1e-4 * (1.0 + b.abs()), "analytic {j}\nnumeric {num}");
        }
    }

    #[test]
    fn recovers_a_pose_from_a_curved_and_a_nearly_flat_stretch() {
        // Points on a sphere of radius 0.5 m: a wide patch, and a 60 mm stretch (nearly flat).
        let (k, (r, t)) = (k(), pose());
        for span in [1.2, 0.12] {
            let world: Vec<Point3<f64>> = (0..20)
                .map(|i| {
                    let (a, b) = (span * (i as f64 / 19.0 - 0.5), 0.3 * span * ((i * 7 % 20) as f64 / 19.0 - 0.5));
                    Point3::new(0.5 * a.cos() * b.cos(), 0.5 * a.sin() * b.cos(), 0.5 + 0.5 * b.sin())
                })
                .collect();
            let image: Vec<Point2<f64>> = world.iter().map(|x| project(&k, &r, &t, x).unwrap()).collect();
            let p = fit_pose(&k, &world, &image, None).unwrap();
            let mut truth = Matrix3x4::zeros();
            truth.fixed_view_mut::<3, 3>(0, 0).copy_from(&r);
            truth.set_column(3, &t);
            let truth = k.matrix() * truth;
            assert!((p / p[(2, 3)] - truth / truth[(2, 3)]).amax() < 1e-6 * truth.amax(), "span {span}: {p} vs {truth}");
        }
    }
}
