//! PLACEHOLDER until the chessboard detector lands (same API).

use nalgebra::Point2;

use super::{DetectError, ImageF32};

/// Parameters.
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct ChessboardParams {
    /// Inner corners per row.
    pub cols: usize,
    /// Rows.
    pub rows: usize,
}

/// Result.
#[derive(Debug, Clone, PartialEq)]
pub struct ChessboardCorners {
    /// Corners.
    pub points_px: Vec<Point2<f64>>,
}

/// Find.
///
/// # Errors
/// Never.
pub fn find_chessboard(img: &ImageF32, _params: &ChessboardParams) -> Result<Option<ChessboardCorners>, DetectError> {
    if img.data.len() != img.width * img.height {
        return Err(DetectError::BadBuffer { expected: img.width * img.height, actual: img.data.len() });
    }
    Ok(None)
}
