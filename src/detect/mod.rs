//! Image to 2-D features: CPU, deterministic, no file I/O.
//!
//! This first version holds the sub-pixel corner refiner the renderer's fidelity test uses; the
//! chessboard and dot detectors build on it.

pub mod image;
pub mod subpixel;

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
