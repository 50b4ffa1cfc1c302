//! Image to 2-D features: CPU, deterministic, no file I/O.
//!
//! This first version holds the sub-pixel corner refiner the renderer's fidelity test uses; the
//! chessboard and dot detectors build on it.

pub mod chessboard;
pub mod dots;
pub mod filters;
pub mod grid_order;
pub mod image;
pub mod s_path_order;
pub mod subpixel;
pub mod target;

pub use self::image::ImageF32;
pub use subpixel::{refine_corner, SubpixelParams};

/// Errors of the detectors.
#[derive(Debug, thiserror::Error, Clone, PartialEq)]
#[non_exhaustive]
pub enum DetectError {
    /// Pixel buffer and size disagree.
    #[error("image buffer has {actual} values, expected {expected} for its size")]
    BadBuffer {
        /// Expected length.
        expected: usize,
        /// Actual length.
        actual: usize,
    },
    /// The target is not (fully) there.
    #[error("target not found: {reason}")]
    NotFound {
        /// Why.
        reason: String,
    },
    /// The refinement window leaves the image or has no gradient.
    #[error("corner refinement failed at ({u:.2}, {v:.2}): {reason}")]
    RefineFailed {
        /// Seed u, pixels.
        u: f64,
        /// Seed v, pixels.
        v: f64,
        /// Why.
        reason: &'static str,
    },
}
