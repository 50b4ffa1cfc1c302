//! Truth per effect, the detection and the ordered comparison of the detected corners with the
//! truth ([`super`]'s module docs), and the in-memory JPEG round trip.

use super::conditions::{condition_strength, Condition};
use super::{centre_depth_m, snr_at, Effect, RobustnessError};
use synthcam_detect::chessboard::TRUSTED_CORNER_PX;
use synthcam_detect::{find_chessboard, ChessboardParams};
use synthcam_render::GreyImage;
use synthcam_scene::{Scene, TruthLabels};

/// The truth of `effect` per feature of `scene`, in the target's order (NaN where it does not
/// exist: a rolling-shutter point whose row time did not converge).
pub fn truth_points(effect: Effect, scene: &Scene, truth: &TruthLabels) -> Vec<[f64; 2]> {
    let rolling = scene.render.effects.motion.rolling();
    truth
        .features
        .iter()
        .map(|f| match effect {
            Effect::RollingShutter if rolling => f.effects.rolling_shutter_px.unwrap_or([f64::NAN; 2]),
            Effect::MotionBlur => f.effects.trajectory_px.get(2).copied().unwrap_or(f.pixel_px),
            _ => f.pixel_px,
        })
        .collect()
}

/// Per-corner errors of `found` (detector order, `cols` per row, or `rows` per row when
/// transposed: `found_cols`) against `truth` (target order): the grid symmetry with the smallest
/// RMS over the finite truth points. Empty when the counts differ.
pub fn match_errors(found: &[[f64; 2]], found_cols: usize, truth: &[[f64; 2]], grid: [u32; 2]) -> Vec<f64> {
    matched_errors(found, found_cols, truth, grid).into_iter().map(|(_, e)| e).collect()
}

/// [`match_errors`] with the index in `found` of each error's corner.
pub fn matched_errors(found: &[[f64; 2]], found_cols: usize, truth: &[[f64; 2]], grid: [u32; 2]) -> Vec<(usize, f64)> {
    let (cols, rows) = (grid[0] as usize, grid[1] as usize);
    if found.len() != truth.len() || found.len() != cols * rows || cols == 0 || rows == 0 {
        return Vec::new();
    }
    // A transposed result (rows per row) is brought to `cols` per row first.
    let index = |k: usize| if found_cols == cols { k } else { (k % cols) * rows + k / cols };
    let errors = |perm: &Vec<usize>| -> Vec<(usize, f64)> {
        perm.iter()
            .zip(truth)
            .filter(|(_, t)| t[0].is_finite() && t[1].is_finite())
            .map(|(&i, t)| (index(i), (found[index(i)][0] - t[0]).hypot(found[index(i)][1] - t[1])))
            .collect()
    };
    let rms_of = |v: &Vec<(usize, f64)>| rms(&v.iter().map(|(_, e)| *e).collect::<Vec<_>>());
    crate::world::grid_orderings(cols, rows).iter().map(errors).min_by(|a, b| rms_of(a).total_cmp(&rms_of(b))).unwrap_or_default()
}

/// Root mean square (NaN for none).
pub fn rms(e: &[f64]) -> f64 {
    if e.is_empty() {
        return f64::NAN;
    }
    (e.iter().map(|x| x * x).sum::<f64>() / e.len() as f64).sqrt()
}

/// Encode `img` as JPEG at `quality` and decode it again, in memory (8-bit grey).
///
/// # Errors
/// [`RobustnessError::Jpeg`].
pub fn jpeg_round_trip(img: &GreyImage, quality: u8) -> Result<GreyImage, RobustnessError> {
    let bytes = synthcam_render::formation::jpeg_bytes(img, quality).map_err(|e| RobustnessError::Jpeg(e.to_string()))?;
    let back = image::load_from_memory_with_format(&bytes, image::ImageFormat::Jpeg).map_err(|e| RobustnessError::Jpeg(e.to_string()))?;
    Ok(GreyImage::U8(back.to_luma8()))
}

/// A detection scored against the truth.
pub(super) struct Score {
    pub detected: bool,
    /// RMS and largest error over the corners the detector trusts (those a calibration keeps).
    pub rms_px: f64,
    pub max_px: f64,
    pub n_corners: usize,
    /// Corners the detector flags as untrusted (`ChessboardCorners::untrusted`).
    pub untrusted: usize,
}

impl Score {
    /// The experiment's record of this score for `effect` at `level` (of `strength`), view `view`.
    pub(super) fn run(self, effect: Effect, level: f64, strength: f64, view: usize) -> super::RobustnessRun {
        let Score { detected, rms_px, max_px, n_corners, untrusted } = self;
        super::RobustnessRun { effect, level, strength, view, detected, rms_px, max_px, n_corners, untrusted }
    }
}

/// Detect the board in `image` and compare its trusted corners with `truth_px`.
pub(super) fn detect_and_score(image: &GreyImage, truth_px: &[[f64; 2]], grid: [u32; 2]) -> Result<Score, RobustnessError> {
    let params = ChessboardParams::new(grid[0] as usize, grid[1] as usize);
    let Some(board) = find_chessboard(&image.to_detector_image()?, &params)? else {
        return Ok(Score { detected: false, rms_px: f64::NAN, max_px: f64::NAN, n_corners: 0, untrusted: 0 });
    };
    let found: Vec<[f64; 2]> = board.points_px.iter().map(|p| [p.x, p.y]).collect();
    let untrusted = board.untrusted(TRUSTED_CORNER_PX);
    let matched = matched_errors(&found, board.cols, truth_px, grid);
    let e: Vec<f64> = matched.iter().filter(|(i, _)| !untrusted.contains(i)).map(|(_, e)| *e).collect();
    let max = e.iter().copied().fold(f64::NAN, f64::max);
    Ok(Score { detected: !matched.is_empty(), rms_px: rms(&e), max_px: max, n_corners: found.len(), untrusted: untrusted.len() })
}

/// The strength of `effect` at `level` in `scene` (module docs).
pub(super) fn strength(effect: Effect, scene: &Scene, level: f64, truth: &TruthLabels) -> f64 {
    let fx = &scene.render.effects;
    match effect {
        Effect::Blur | Effect::MotionBlur | Effect::Jpeg => level,
        Effect::Gradient => condition_strength(truth, Condition::Gradient, level),
        Effect::Highlight => condition_strength(truth, Condition::Highlight, level),
        Effect::Clutter => condition_strength(truth, Condition::Clutter, level),
        Effect::Shadow => condition_strength(truth, Condition::Shadow, level),
        Effect::Defocus => fx.optics.thin_lens.map_or(0.0, |l| l.coc_radius_px(scene.camera.intrinsics.fx, centre_depth_m(scene))),
        Effect::Noise => fx.sensor.map_or(f64::INFINITY, |m| snr_at(&m, 128.0)),
        Effect::RollingShutter => {
            let d: Vec<f64> =
                truth.features.iter().filter_map(|f| f.effects.rolling_shutter_px.map(|q| (q[0] - f.pixel_px[0]).hypot(q[1] - f.pixel_px[1]))).collect();
            if d.is_empty() {
                0.0
            } else {
                d.iter().sum::<f64>() / d.len() as f64
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn grid(cols: usize, rows: usize) -> Vec<[f64; 2]> {
        (0..rows * cols).map(|k| [(k % cols) as f64 * 10.0, (k / cols) as f64 * 10.0]).collect()
    }

    #[test]
    fn every_symmetry_and_the_transpose_match_exactly() {
        let truth = grid(4, 3);
        let reversed: Vec<[f64; 2]> = truth.iter().rev().copied().collect();
        assert_eq!(match_errors(&reversed, 4, &truth, [4, 3]), vec![0.0; 12]);
        let mirrored: Vec<[f64; 2]> = (0..12).map(|k| truth[(k / 4) * 4 + 3 - k % 4]).collect();
        assert_eq!(match_errors(&mirrored, 4, &truth, [4, 3]), vec![0.0; 12]);
        // The same corners listed 3 per row (the grid seen transposed).
        let transposed: Vec<[f64; 2]> = (0..12).map(|k| truth[(k % 3) * 4 + k / 3]).collect();
        assert_eq!(match_errors(&transposed, 3, &truth, [4, 3]), vec![0.0; 12]);
        let shifted: Vec<[f64; 2]> = truth.iter().map(|p| [p[0] + 0.3, p[1] - 0.4]).collect();
        assert!((rms(&match_errors(&shifted, 4, &truth, [4, 3])) - 0.5).abs() < 1e-12);
        assert!(match_errors(&truth[..11], 4, &truth, [4, 3]).is_empty());
        assert!(rms(&[]).is_nan());
    }
}
