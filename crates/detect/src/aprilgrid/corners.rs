//! AprilGrid tag corners: each is the X-junction of the tag's black border and the black square
//! at its gap crossing (white gap on the other two sides), refined by
//! [`refine_junction`](crate::markers::corners) with:
//!
//! * the homography of the detected tags at the corner's gap crossing (the tag and up to three
//!   neighbours, 4 point pairs each, RMS-checked); when it fails, the tag's own four corners;
//!   the fit starts at the tag's own sub-pixel corner (a homography over several tags is pixels
//!   off under strong distortion);
//! * the corners of tags that were not decoded (cut by the image border, blurred, partly hidden)
//!   where at least two decoded tags of the 3 x 3 neighbourhood predict them: the fit starts at the
//!   prediction and may move up to `max_predicted_shift_px`; the sign and fit checks below keep
//!   it from other features (no tag gives wrong ids: each corner's id comes from the grid);
//! * the uniform area: half-size `min(border_bits * cell, spacing * tag)` on the grid (the tag's
//!   black border, the gap square and the two white gap strips);
//! * the sign probe: towards the tag's centre is dark.
//!
//! Reference: Kalibr `GridCalibrationTargetAprilgrid::computeObservation` (which refines the tag
//! corners with `cv::cornerSubPix` in a 2 x 2 window); OpenCV `charuco_detector.cpp`
//! (`interpolateCornersCharucoLocalHom`).

use nalgebra::{Point2, Vector2};
use rayon::prelude::*;

use crate::markers::corners::{local_homography, refine_junction, Area, CornerParams, Junction};
use crate::par::worth_parallel;
use crate::{ImageF32, MarkerDetection};
use synthcam_core::target::AprilGrid;

/// Direction away from the tag of each corner (Kalibr's order, y up the page).
const OUTWARD: [[i64; 2]; 4] = [[-1, -1], [1, -1], [1, 1], [-1, 1]];

/// The refined corners: ids `4 k + c` ascending and positions. `tags` are sorted by id, corners
/// in Kalibr's order.
pub(super) fn refine(img: &ImageF32, grid: &AprilGrid, tags: &[MarkerDetection], params: &CornerParams) -> (Vec<u32>, Vec<Point2<f64>>) {
    let [nx, ny] = grid.tags;
    let mut at: Vec<Option<usize>> = vec![None; nx as usize * ny as usize];
    for (i, t) in tags.iter().enumerate() {
        if let Some(slot) = t.id.checked_sub(grid.first_id).and_then(|k| at.get_mut(k as usize)) {
            *slot = Some(i);
        }
    }
    let tag_at = |x: i64, y: i64| -> Option<(u32, usize)> {
        if x < 0 || y < 0 || x >= i64::from(nx) || y >= i64::from(ny) {
            return None;
        }
        let k = (y * i64::from(nx) + x) as u32;
        Some((k, at[k as usize]?))
    };
    // Every corner of a decoded tag, and every corner of an undecoded tag (cut by the image
    // border, blurred, partly hidden) that two decoded tags around its gap crossing predict.
    let ring = |k: u32| -> Vec<(u32, usize)> {
        let (x, y) = (i64::from(k % nx), i64::from(k / nx));
        (-1..=1).flat_map(|dy| (-1..=1).map(move |dx| (x + dx, y + dy))).filter(|&(u, v)| (u, v) != (x, y)).filter_map(|(u, v)| tag_at(u, v)).collect()
    };
    let jobs: Vec<(u32, u32, usize)> =
        (0..nx * ny).filter(|&k| at[k as usize].is_some() || ring(k).len() >= 2).flat_map(|k| (0..4).map(move |c| (4 * k + c as u32, k, c))).collect();
    let job = |&(id, k, c): &(u32, u32, usize)| -> Option<(u32, Point2<f64>)> {
        let (x, y) = (i64::from(k % nx), i64::from(k / nx));
        let [sx, sy] = OUTWARD[c];
        // An undecoded tag is predicted by the decoded tags of its 3 x 3 neighbourhood.
        let around: Vec<(u32, usize)> = match tag_at(x, y) {
            Some(_) => [(x, y), (x + sx, y), (x, y + sy), (x + sx, y + sy)].iter().filter_map(|&(u, v)| tag_at(u, v)).collect(),
            None => ring(k),
        };
        let pairs = |set: &[(u32, usize)]| -> (Vec<Point2<f64>>, Vec<Point2<f64>>) {
            let src = set.iter().flat_map(|&(k, _)| grid.tag_corners_m(k).map(|p| Point2::new(p.x, p.y))).collect();
            let dst = set.iter().flat_map(|&(_, i)| tags[i].corners_px).collect();
            (src, dst)
        };
        let h = (around.len() > 1)
            .then(|| {
                let (src, dst) = pairs(&around);
                local_homography(&src, &dst, params)
            })
            .flatten()
            .or_else(|| {
                let (src, dst) = pairs(&around[..1.min(around.len())]);
                local_homography(&src, &dst, params)
            })?;
        let margin_m = (f64::from(grid.border_bits) * grid.cell_m()).min(grid.spacing * grid.tag_m);
        let corner = grid.tag_corners_m(k)[c];
        let junction = Junction {
            h,
            c: Point2::new(corner.x, corner.y),
            margin_m,
            area: Area::Square,
            probe_m: Vector2::new(-(sx as f64), -(sy as f64)) * (0.5 * margin_m),
            probe_light: false,
            // The tag's own corner: its sides are fitted to the sub-pixel, and a homography of
            // several tags is pixels off under strong distortion.
            seed_px: tag_at(x, y).map(|(_, i)| tags[i].corners_px[c]),
            predicted: tag_at(x, y).is_none(),
        };
        Some((id, refine_junction(img, &junction, params)?))
    };
    let mut found: Vec<(u32, Point2<f64>)> = if worth_parallel(jobs.len(), params.parallel_min_corners.max(1)) {
        jobs.par_iter().filter_map(job).collect()
    } else {
        jobs.iter().filter_map(job).collect()
    };
    found.sort_by_key(|f| f.0);
    found.into_iter().unzip()
}
