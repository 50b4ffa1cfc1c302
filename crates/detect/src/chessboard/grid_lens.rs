//! A whole-grid prediction for structure recovery: the board plane seen through a homography
//! and one radial lens term, fitted to the corners a partial grid holds.
//!
//! The grid's own predictions ([`Grid::predict`]) extrapolate from the two or three nearest
//! corners of a row or column. Towards a fisheye's fold or a strong barrel lens's border the
//! squares shrink from one row to the next by a third or more, and those extrapolations overshoot
//! by more than the validating fit can walk back (a third of a step). A board is a plane, so its
//! image is a homography of the grid followed by the lens; Fitzgibbon's one-parameter division
//! model about the image centre ([`Division`]) stands for the lens. For each lambda the homography is linear in the undistorted corners; lambda
//! is found by a one-dimensional search on the reprojection RMS in the image. Its prediction is
//! one more guess for a corner the local ones miss: only what the image shows there validates it.
//!
//! Reference: A. W. Fitzgibbon, "Simultaneous linear estimation of multiple view geometry and
//! lens distortion", CVPR 2001 (the division model); Hartley and Zisserman, *Multiple View
//! Geometry*, 2nd ed., Algorithm 4.2 (the normalised DLT).

use nalgebra::{Matrix3, Point2};
use synthcam_core::math::golden::grid_then_golden_min;

use super::super::division::Division;
use super::super::grid::Grid;
use super::super::markers::corners::homography;

/// The searched range of lambda r_max^2 (r_max the farthest corner's distance from the centre):
/// a 190-degree fisheye needs about -0.9 at the fold, a pincushion lens a few tenths above 0.
const KAPPA_RANGE: (f64, f64) = (-1.2, 0.6);
/// Grid steps of the coarse search over the range.
const KAPPA_STEPS: usize = 18;
/// Golden-section steps refining the best grid cell (each shrinks it by 0.618).
const GOLDEN_STEPS: usize = 20;
/// Fewest corners to fit (a homography and lambda: 9 unknowns, with room to spare).
const MIN_CORNERS: usize = 9;

/// The fitted model: grid cell (i, j) -> undistorted pixel by `h`, then the lens.
#[derive(Debug, Clone, Copy, PartialEq)]
pub(super) struct GridLens {
    h: Matrix3<f64>,
    lens: Division,
}

impl GridLens {
    /// The model fitted to `g`'s corners, lens about `centre`; `None` with fewer than
    /// [`MIN_CORNERS`] or a degenerate fit.
    pub(super) fn fit(g: &Grid, centre: Point2<f64>) -> Option<Self> {
        let mut cells: Vec<((i32, i32), Point2<f64>)> = g.cells.iter().map(|(k, q)| (*k, *q)).collect();
        if cells.len() < MIN_CORNERS {
            return None;
        }
        cells.sort_unstable_by_key(|c| c.0);
        let grid: Vec<Point2<f64>> = cells.iter().map(|((i, j), _)| Point2::new(f64::from(*i), f64::from(*j))).collect();
        let image: Vec<Point2<f64>> = cells.iter().map(|c| c.1).collect();
        let r2_max = image.iter().map(|p| (p - centre).norm_squared()).fold(0.0, f64::max);
        if !(r2_max > 0.0 && r2_max.is_finite()) {
            return None;
        }
        let at = |kappa: f64| Self::with_lambda(&grid, &image, centre, kappa / r2_max);
        let cost = |kappa: f64| at(kappa).map_or(f64::INFINITY, |m| m.rms(&grid, &image));
        let step = (KAPPA_RANGE.1 - KAPPA_RANGE.0) / KAPPA_STEPS as f64;
        let kappas = (0..=KAPPA_STEPS).map(|k| KAPPA_RANGE.0 + k as f64 * step);
        let (kappa, rms) = grid_then_golden_min(cost, kappas, step, GOLDEN_STEPS)?;
        if rms.is_finite() {
            at(kappa)
        } else {
            None
        }
    }

    /// The homography for a given `lambda`, fitted to the undistorted corners.
    fn with_lambda(grid: &[Point2<f64>], image: &[Point2<f64>], centre: Point2<f64>, lambda: f64) -> Option<Self> {
        let lens = Division { centre, lambda };
        let ideal: Vec<Point2<f64>> = image.iter().map(|p| lens.undistort(p)).collect();
        Some(Self { h: homography(grid, &ideal)?, lens })
    }

    /// Reprojection RMS in the image, pixels.
    fn rms(&self, grid: &[Point2<f64>], image: &[Point2<f64>]) -> f64 {
        let ss: f64 = grid.iter().zip(image).map(|(c, q)| self.project(c).map_or(f64::INFINITY, |p| (p - q).norm_squared())).sum();
        (ss / grid.len().max(1) as f64).sqrt()
    }

    /// The pixel of grid cell `c` (fractional cells allowed); `None` behind the plane's horizon.
    fn project(&self, c: &Point2<f64>) -> Option<Point2<f64>> {
        let v = self.h * c.to_homogeneous();
        if !(v.z.abs() > 1e-12) {
            return None;
        }
        self.lens.distort(&Point2::new(v.x / v.z, v.y / v.z))
    }

    /// The predicted pixel of cell (i, j).
    pub(super) fn predict(&self, i: i32, j: i32) -> Option<Point2<f64>> {
        self.project(&Point2::new(f64::from(i), f64::from(j)))
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A grid seen through a known homography and an equidistant fisheye (r = f theta, which the
    /// division model only approximates): the outer ring, left out of the fit, is predicted
    /// within a small fraction of its shrunken step, where the grid's own linear extrapolation
    /// overshoots by far more.
    #[test]
    fn predicts_the_outer_ring_of_a_fisheye_grid() {
        let (f, c) = (330.0, Point2::new(640.0, 512.0));
        // the board plane: cell (i, j) at (0.1 i - 0.4, 0.1 j - 0.3, 0.25) in the camera, tilted
        let ray = |i: i32, j: i32| {
            let (x, y) = (0.1 * f64::from(i) - 0.45, 0.1 * f64::from(j) - 0.3);
            nalgebra::Vector3::new(x, y, 0.25 + 0.2 * x)
        };
        let pixel = |i: i32, j: i32| {
            let v = ray(i, j);
            let theta = (v.x.hypot(v.y)).atan2(v.z);
            let rho = v.x.hypot(v.y);
            c + nalgebra::Vector2::new(v.x, v.y) * (f * theta / rho)
        };
        let mut g = Grid::default();
        for i in 1..8 {
            for j in 1..6 {
                g.cells.insert((i, j), pixel(i, j));
            }
        }
        let model = GridLens::fit(&g, c).expect("a fit");
        let mut worst: f64 = 0.0;
        for (i, j) in (0..=8).flat_map(|i| [(i, 0), (i, 6)]).chain((1..6).flat_map(|j| [(0, j), (8, j)])) {
            let err = (model.predict(i, j).expect("in reach") - pixel(i, j)).norm();
            worst = worst.max(err);
        }
        let linear = (pixel(1, 3).coords * 2.0 - pixel(2, 3).coords - pixel(0, 3).coords).norm();
        assert!(worst < 0.25 * linear, "model {worst:.2} px, linear extrapolation {linear:.2} px");
    }
}
