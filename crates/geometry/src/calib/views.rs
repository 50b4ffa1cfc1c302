//! Detections into calibration views: each found board's points paired with their board points
//! (by id for coded boards, in order for chessboards), minus the corners the detector says a
//! calibration should leave out. The CLI's `calibrate` and Python's `synthcam.calibrate` both go
//! through [`views_from_detections`].
//!
//! The board frame is the target's own (as rendered and as the truth's `cam_from_target`): its
//! origin at the board's outer corner, x along the columns, y along the rows, z into the board. A
//! chessboard's first inner corner is at `(square, square, 0)` there, as in OpenCV's
//! `CharucoBoard::getChessboardCorners`; OpenCV's chessboard tutorials put it at the origin
//! instead (their `tvec` = ours + R (square, square, 0)). An AprilGrid's frame is Kalibr's (origin
//! at tag 0's bottom-left corner), which its renders and truth use too.

use nalgebra::{Point2, Point3};

use super::{CalibError, View};
use synthcam_detect::chessboard::corners_to_leave_out;
use synthcam_detect::target::{Detection, TargetSpec};

/// Fewest points a view keeps (a homography, with some to spare; a smaller board needs all).
pub const MIN_VIEW_POINTS: usize = 8;

/// The views of some detections, and which detection each came from.
#[derive(Debug, Clone, PartialEq, Default)]
pub struct BoardViews {
    /// One view per detection used.
    pub views: Vec<View>,
    /// The index (into the detections) of each view.
    pub used: Vec<usize>,
    /// Per view, the index (into its detection's `points_px`) of each of its points: the
    /// untrusted corners left out shift the rest.
    pub point_indices: Vec<Vec<usize>>,
    /// The detections not used, with the reason.
    pub skipped: Vec<SkippedDetection>,
}

/// A detection [`views_from_detections`] did not use.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct SkippedDetection {
    /// Index into the detections.
    pub index: usize,
    /// Why: the board was not found, or too few trusted points are left.
    pub reason: String,
}

/// The calibration views of `detections` of `target` (squares `square_m` wide; AprilGrid: tag
/// edge): boards not found and views left with fewer than [`MIN_VIEW_POINTS`] points are
/// skipped, with the reason.
///
/// # Errors
/// [`CalibError::BadOption`]: a target `calib` does not take (dot grids, S-path) or a square
/// that is not a positive length; [`CalibError::BadDetection`]: a found detection whose points do
/// not match the board (a chessboard's count, ids that are not on it or not one per point).
pub fn views_from_detections(detections: &[Detection], target: &TargetSpec, square_m: f64) -> Result<BoardViews, CalibError> {
    if !(square_m > 0.0 && square_m.is_finite()) {
        return Err(CalibError::BadOption { reason: format!("the square must be a positive length in metres, got {square_m}") });
    }
    let board = target
        .board_points_m(square_m)
        .ok_or_else(|| CalibError::BadOption { reason: format!("calibration takes a chessboard, ChArUco or AprilGrid target, not {target:?}") })?;
    let mut out = BoardViews::default();
    for (index, det) in detections.iter().enumerate() {
        if !det.found {
            out.skipped.push(SkippedDetection { index, reason: "board not found".into() });
            continue;
        }
        let (view, indices) = view_of(det, &board).map_err(|reason| CalibError::BadDetection { index, reason })?;
        if view.len() < MIN_VIEW_POINTS.min(board.len()) {
            let reason = format!("only {} points left (a view needs {MIN_VIEW_POINTS}; untrusted corners are left out)", view.len());
            out.skipped.push(SkippedDetection { index, reason });
            continue;
        }
        out.views.push(view);
        out.used.push(index);
        out.point_indices.push(indices);
    }
    Ok(out)
}

/// One found detection's view and the index of each of its points in the detection; `Err` says
/// why its points do not fit `board`.
fn view_of(det: &Detection, board: &[Point3<f64>]) -> Result<(View, Vec<usize>), String> {
    let n = board.len();
    let ids: Vec<usize> = match &det.ids {
        Some(ids) if ids.len() == det.points_px.len() => ids.iter().map(|&i| i as usize).collect(),
        Some(ids) => return Err(format!("{} ids for {} points", ids.len(), det.points_px.len())),
        None if det.points_px.len() == n => (0..n).collect(),
        None => return Err(format!("{} points, the board has {n} (give ids for a partial view)", det.points_px.len())),
    };
    if let Some(&bad) = ids.iter().find(|&&i| i >= n) {
        return Err(format!("id {bad} is not on the board ({n} points)"));
    }
    let leave_out = corners_to_leave_out(det.position_sigma_px.as_deref().unwrap_or_default(), &det.untrusted);
    let pairs = ids.into_iter().zip(&det.points_px).enumerate().filter(|(k, _)| !leave_out.contains(k));
    Ok(pairs.map(|(k, (id, p))| ((board[id], Point2::new(p.x, p.y)), k)).unzip())
}

#[cfg(test)]
mod tests {
    use super::*;

    fn found(points: usize) -> Detection {
        Detection { found: true, points_px: (0..points).map(|k| Point2::new(k as f64, 2.0 * k as f64)).collect(), ..Default::default() }
    }

    #[test]
    fn chessboard_views_pair_points_with_the_target_frame() {
        let target = TargetSpec::Chessboard { cols: 4, rows: 3 };
        let dets = [found(12), Detection::default(), found(12)];
        let v = views_from_detections(&dets, &target, 0.05).unwrap();
        assert_eq!(v.used, vec![0, 2]);
        assert_eq!(v.skipped, vec![SkippedDetection { index: 1, reason: "board not found".into() }]);
        // point 5 is row 1, column 1: one square in from the first inner corner at (0.05, 0.05)
        let (x, q) = v.views[0][5];
        assert!((x - Point3::new(0.1, 0.1, 0.0)).norm() < 1e-15 && q == Point2::new(5.0, 10.0), "{x} {q}");
    }

    #[test]
    fn untrusted_corners_are_left_out_and_thin_views_skipped() {
        let target = TargetSpec::Chessboard { cols: 4, rows: 3 };
        let mut d = found(12);
        d.position_sigma_px = Some(vec![0.01; 12]);
        d.position_sigma_px.as_mut().unwrap()[3] = f64::INFINITY; // its fit failed
        d.untrusted = vec![3];
        let v = views_from_detections(&[d.clone()], &target, 0.05).unwrap();
        assert_eq!(v.views[0].len(), 11);
        assert!(v.views[0].iter().all(|(_, q)| q.x != 3.0));
        d.position_sigma_px = Some(vec![f64::INFINITY; 12]);
        d.untrusted = (0..12).collect();
        let v = views_from_detections(&[d], &target, 0.05).unwrap();
        assert!(v.views.is_empty() && v.skipped[0].reason.contains("only 0"), "{:?}", v.skipped);
    }

    #[test]
    fn points_that_do_not_fit_the_board_are_typed_errors() {
        let chess = TargetSpec::Chessboard { cols: 4, rows: 3 };
        assert!(matches!(views_from_detections(&[found(11)], &chess, 0.05), Err(CalibError::BadDetection { index: 0, .. })));
        let mut d = found(9);
        d.ids = Some((0..9).map(|i| i * 2).collect()); // id 16 beyond 12 points
        assert!(matches!(views_from_detections(&[d], &chess, 0.05), Err(CalibError::BadDetection { .. })));
        assert!(matches!(views_from_detections(&[], &TargetSpec::DotGrid { n: 3 }, 0.05), Err(CalibError::BadOption { .. })));
        assert!(matches!(views_from_detections(&[], &chess, f64::NAN), Err(CalibError::BadOption { .. })));
    }
}
