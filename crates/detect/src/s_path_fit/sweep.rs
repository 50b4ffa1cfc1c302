//! Turning a window's pose about its own chord: the degree of freedom a nearly straight stretch
//! of dots leaves open where the camera is known.
//!
//! Points on a line at known spacings fix the line in space (the perspective of a known ruler),
//! not the rotation about it. So the pose fitted to a window of consecutive dots
//! ([`super::seeds::verified_windows`]) is nearly free to turn about the window's chord where
//! the window's path points lie close to a line, and there the right placement's camera verifies
//! against few of the view's dots. The S's straightest 15-dot stretches bow only 32 mm off their
//! chord, about four times the strays of a target whose dots lie up to 7 mm off: on such a render
//! (`benches/spath_independent.py`, seed 34805, view A_16) the true labels of 15-dot windows of
//! its 34-dot arc, fitted once (SQPnP), projected 10-20 of the view's 52 dots near their points.
//! Each placement's pose is therefore turned about the chord through the window's centroid over
//! [`REACH_DEG`] either way, and the turn whose projection of the path has the most points with a
//! dot near them is kept: hypothesise and verify (Fischler and Bolles, 1981), exhaustive over the
//! loosest parameter on a grid ([`STEP_DEG`]) fine enough for the match radius to catch the right
//! turn near the window. Where the window's curve holds the pose, the fitted pose (turn 0, on
//! the grid) is already the best.

use nalgebra::{Matrix3, Matrix3x4, Point2, Point3, Vector3};
use std::collections::HashMap;

use super::dlt::Dlt;
use super::grow::{facing_projections, match_projection};
use super::{correspondences, Labels};
use crate::dots::Dot;
use synthcam_core::camera::Intrinsics;
use synthcam_core::math::so3::rotation_from_rvec;
use synthcam_core::target::SPath;

/// Largest turn about the chord tried either way, degrees.
const REACH_DEG: f64 = 90.0;

/// Step between the turns tried, degrees: a point 0.4 m from the chord moves 10 mm (the match
/// radius on the course's target) under a turn of 1.4 degrees, so half a step stays inside it.
const STEP_DEG: f64 = 1.5;

/// The dots' centres, binned in square cells for radius queries (a view's hundred dots: a k-d tree
/// crate would serve, but bins about the dots' spacing are a dozen lines and no dependency).
struct DotGrid {
    cell: f64,
    bins: HashMap<(i64, i64), Vec<Point2<f64>>>,
}

impl DotGrid {
    fn new(dots: &[Dot], cell: f64) -> Self {
        let mut bins: HashMap<(i64, i64), Vec<Point2<f64>>> = HashMap::new();
        for d in dots {
            bins.entry(Self::key(&d.centre_px, cell)).or_default().push(d.centre_px);
        }
        Self { cell, bins }
    }

    fn key(p: &Point2<f64>, cell: f64) -> (i64, i64) {
        ((p.x / cell).floor() as i64, (p.y / cell).floor() as i64)
    }

    /// Is any dot within `tol` px of `q`?
    fn any_within(&self, q: &Point2<f64>, tol: f64) -> bool {
        if !(q.x.is_finite() && q.y.is_finite() && tol.is_finite()) {
            return false;
        }
        let (cx, cy) = Self::key(q, self.cell);
        let reach = (tol / self.cell).ceil().min(1e6) as i64;
        if (2 * reach + 1).pow(2) as usize > self.bins.len() {
            // A radius spanning more cells than hold dots: every dot is nearer to test.
            return self.bins.values().flatten().any(|p| (p - q).norm() <= tol);
        }
        (cx - reach..=cx + reach).any(|x| (cy - reach..=cy + reach).any(|y| self.bins.get(&(x, y)).is_some_and(|v| v.iter().any(|p| (p - q).norm() <= tol))))
    }
}

/// A pose `K [R | t]` split into `R` and `t` (the camera of [`Dlt::fit`] with known intrinsics).
fn split(k: &Intrinsics, dlt: &Dlt) -> Option<(Matrix3<f64>, Vector3<f64>)> {
    let m: Matrix3x4<f64> = k.matrix().try_inverse()? * dlt.p;
    Some((m.fixed_view::<3, 3>(0, 0).into_owned(), m.column(3).into_owned()))
}

/// The camera whose world is turned by `angle` radians about the line through `c` along the unit
/// `axis`: `X -> c + A (X - c)`, so `R' = R A` and `t' = R (c - A c) + t`.
fn turned(k: &Intrinsics, (r, t): &(Matrix3<f64>, Vector3<f64>), c: &Point3<f64>, axis: &Vector3<f64>, angle: f64) -> Dlt {
    let a = rotation_from_rvec(&(axis * angle)).into_inner();
    let (r2, t2) = (r * a, r * (c.coords - a * c.coords) + t);
    let mut rt = Matrix3x4::zeros();
    rt.fixed_view_mut::<3, 3>(0, 0).copy_from(&r2);
    rt.set_column(3, &t2);
    Dlt { p: k.matrix() * rt }
}

/// Path points the camera sees (facing it, in front) whose projection has a dot within `fraction`
/// of the projected spacing there (as [`match_projection`] matches).
fn support(dlt: &Dlt, grid: &DotGrid, path: &SPath, fraction: f64) -> usize {
    let proj = facing_projections(dlt, path);
    let spacing = |i: usize, q: &Point2<f64>| {
        [i.checked_sub(1), Some(i + 1)]
            .into_iter()
            .flatten()
            .filter_map(|k| proj.get(k).copied().flatten())
            .map(|p| (p - q).norm())
            .fold(f64::INFINITY, f64::min)
    };
    proj.iter().enumerate().filter(|(i, q)| q.is_some_and(|q| grid.any_within(&q, fraction * spacing(*i, &q)))).count()
}

/// The best turn about the window's chord of the pose fitted to one placement `labels`: (points
/// supported, camera), `None` where no pose fits.
fn best_turn(labels: &[(usize, usize)], dots: &[Dot], path: &SPath, k: &Intrinsics, grid: &DotGrid, fraction: f64) -> Option<(usize, Dlt)> {
    let (world, image) = correspondences(labels, dots, path);
    let rt = split(k, &Dlt::fit(&world, &image, Some(k))?)?;
    let axis = (world.last()? - world.first()?).try_normalize(1e-9)?;
    let c = Point3::from(world.iter().fold(Vector3::zeros(), |a, p| a + p.coords) / world.len() as f64);
    let steps = (REACH_DEG / STEP_DEG).round() as i64;
    (-steps..=steps)
        .map(|s| turned(k, &rt, &c, &axis, (s as f64 * STEP_DEG).to_radians()))
        .map(|cam| (support(&cam, grid, path, fraction), cam))
        .max_by_key(|(n, _)| *n)
}

/// Over the placements of one window (`placements`, labellings of the same dots), the `keep`
/// best turns ([`best_turn`]), each as the dots its camera matches ([`match_projection`] within
/// `fraction` of the projected spacing).
pub(super) fn best_turns(placements: &[(f64, Labels)], dots: &[Dot], path: &SPath, k: &Intrinsics, fraction: f64, keep: usize) -> Vec<Labels> {
    let Some(first) = placements.first() else { return Vec::new() };
    let (_, image) = correspondences(&first.1, dots, path);
    let mut steps: Vec<f64> = image.windows(2).map(|w| (w[1] - w[0]).norm()).collect();
    steps.sort_by(f64::total_cmp);
    let cell = steps.get(steps.len() / 2).copied().unwrap_or(8.0).max(4.0);
    let grid = DotGrid::new(dots, cell);
    let mut turns: Vec<(usize, Dlt)> = placements.iter().filter_map(|(_, l)| best_turn(l, dots, path, k, &grid, fraction)).collect();
    turns.sort_by_key(|t| std::cmp::Reverse(t.0));
    turns.into_iter().take(keep).map(|(_, cam)| match_projection(&cam, dots, path, fraction)).collect()
}

#[cfg(test)]
mod tests {
    use super::*;
    use nalgebra::{Rotation3, Unit};

    #[test]
    fn a_turned_camera_sees_the_world_turned_about_the_line() {
        let k = Intrinsics { fx: 1500.0, fy: 1400.0, cx: 640.0, cy: 512.0, skew: 0.0 };
        let rt = (Rotation3::from_euler_angles(0.3, -0.2, 0.1).into_inner(), Vector3::new(0.1, -0.2, 1.5));
        let (c, axis) = (Point3::new(0.2, 0.1, 0.4), Vector3::new(1.0, 2.0, -0.5).normalize());
        let cam = turned(&k, &rt, &c, &axis, 0.7);
        let a = Rotation3::from_axis_angle(&Unit::new_normalize(axis), 0.7);
        for x in [Point3::new(0.0, 0.0, 0.0), Point3::new(0.3, -0.1, 0.2), Point3::new(-0.2, 0.4, 0.6)] {
            // The world point turned about the line, seen by the camera as it was.
            let y = c + a * (x - c);
            let p = k.matrix() * (rt.0 * y.coords + rt.1);
            let want = Point2::new(p.x / p.z, p.y / p.z);
            assert!((cam.project(&x).unwrap() - want).norm() < 1e-9);
        }
    }
}
