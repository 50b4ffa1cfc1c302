//! Ordering an N x N dot grid.
//!
//! The four extreme dots in the directions of u + v and u - v are the grid's corners; the
//! homography that maps them to (0, 0), (N-1, 0), (N-1, N-1), (0, N-1) gives every dot integer
//! grid coordinates (ix, iy). Order: index = ix * N + iy (the course's "x slow, y fast"), with ix
//! growing to the right and iy downwards in the image at the top-left corner: for a target seen
//! without rotation this is the target's own order. A symmetric grid has no marker, so a rotated
//! view relabels the dots consistently (a rotation of the board), which calibration absorbs.
//! Reference: Hartley & Zisserman, Multiple View Geometry, 2nd ed., 4.4 (normalised DLT).

use nalgebra::{Point2, Vector3};

use synthcam_core::math::homography::homography;

use super::dots::Dot;

/// Largest distance (grid units) of a mapped dot from its integer grid position.
pub const MAX_GRID_RESIDUAL: f64 = 0.3;

/// Order `dots` as an `n x n` grid; `None` unless there are exactly n^2 dots that all land on
/// distinct grid positions.
pub fn order_grid(dots: &[Dot], n: usize) -> Option<Vec<Point2<f64>>> {
    if n < 2 || dots.len() != n * n {
        return None;
    }
    let pts: Vec<Point2<f64>> = dots.iter().map(|d| d.centre_px).collect();
    let pick = |f: &dyn Fn(&Point2<f64>) -> f64, max: bool| -> Option<Point2<f64>> {
        let it = pts.iter().copied();
        if max {
            it.max_by(|a, b| f(a).total_cmp(&f(b)))
        } else {
            it.min_by(|a, b| f(a).total_cmp(&f(b)))
        }
    };
    let corners = [pick(&|p| p.x + p.y, false)?, pick(&|p| p.x - p.y, true)?, pick(&|p| p.x + p.y, true)?, pick(&|p| p.x - p.y, false)?];
    let m = (n - 1) as f64;
    let grid = [Point2::new(0.0, 0.0), Point2::new(m, 0.0), Point2::new(m, m), Point2::new(0.0, m)];
    let h = homography(&corners, &grid)?;
    let mut out = vec![None; n * n];
    for p in &pts {
        let q = h * Vector3::new(p.x, p.y, 1.0);
        if q.z.abs() < 1e-12 {
            return None;
        }
        let (gx, gy) = (q.x / q.z, q.y / q.z);
        let (ix, iy) = (gx.round(), gy.round());
        if (gx - ix).abs() > MAX_GRID_RESIDUAL || (gy - iy).abs() > MAX_GRID_RESIDUAL || ix < 0.0 || iy < 0.0 || ix > m || iy > m {
            return None;
        }
        let slot = &mut out[ix as usize * n + iy as usize];
        if slot.is_some() {
            return None;
        }
        *slot = Some(*p);
    }
    out.into_iter().collect()
}

#[cfg(test)]
mod tests {
    use super::*;
    use nalgebra::Matrix3;

    #[test]
    fn orders_a_perspective_grid_x_slow_y_fast() {
        let n = 4;
        let mut dots = Vec::new();
        for ix in 0..n {
            for iy in 0..n {
                // A perspective view of the grid: x' = H (ix, iy, 1).
                let h = Matrix3::new(40.0, 3.0, 100.0, -2.0, 30.0, 50.0, 0.01, 0.02, 1.0);
                let q = h * Vector3::new(ix as f64, iy as f64, 1.0);
                dots.push(Dot { centre_px: Point2::new(q.x / q.z, q.y / q.z), area_px: 10.0, spread_px: 1.5, core_px: 4, contrast: 100.0, touching: false });
            }
        }
        dots.reverse();
        let out = order_grid(&dots, n).unwrap();
        let at = |ix: f64, iy: f64| {
            let h = Matrix3::new(40.0, 3.0, 100.0, -2.0, 30.0, 50.0, 0.01, 0.02, 1.0);
            let q = h * Vector3::new(ix, iy, 1.0);
            Point2::new(q.x / q.z, q.y / q.z)
        };
        assert_eq!(out[0], at(0.0, 0.0));
        assert_eq!(out[1], at(0.0, 1.0));
        assert_eq!(out[n], at(1.0, 0.0));
        assert!(order_grid(&dots[1..], n).is_none());
    }
}
