//! Image to 2-D features: CPU, deterministic, no file I/O.
//!
//! Holds the sub-pixel corner refiners (gradient-orthogonality [`refine_corner`] and the unbiased
//! saddle-model fit [`refine_saddle`]), the chessboard detector [`find_chessboard`] (saddle
//! response in `response`, grid growing in [`grid`], X-junction test in `xcorner`), the dot
//! detector and orderings (S-path: chain from the start dot in [`s_path_order`], indexing by the
//! known 3-D path in [`s_path_fit`]), the square-marker detector [`find_markers`] with the
//! ChArUco ([`find_charuco`]) and Kalibr AprilGrid ([`find_aprilgrid`]) detectors built on it,
//! and the target dispatch.
//!
//! Reference: OpenCV `findChessboardCorners` / `cornerSubPix`; Geiger et al. 2012, "Automatic
//! camera and range sensor calibration using a single shot".
//!
//! # Layering
//! The detectors sit below the renderer and know nothing of it: this crate cannot even name it
//! (`synthcam-render` is not among its dependencies, so the import is a compile error, kept as a test):
//! ```compile_fail,E0432
//! use synthcam_render::Renderer;
//! ```
//! while the targets of `synthcam-core`, below it, are in reach:
//! ```
//! use synthcam_core::target::Target;
//! ```

#![deny(missing_docs)]

pub mod aprilgrid;
pub mod charuco;
pub mod chessboard;
pub(crate) mod division;
pub mod dots;
pub(crate) mod edge_surround;
pub(crate) mod filters;
pub mod grid;
pub mod grid_order;
pub mod image;
pub mod markers;
pub mod outline;
pub(crate) mod par;
pub(crate) mod pool;
pub(crate) mod response;
mod runs;
pub mod s_path_fit;
pub mod s_path_order;
pub mod saddle_fit;
pub mod subpixel;
pub mod target;
pub(crate) mod xcorner;

pub use self::image::{GreyWindow, ImageF32, ImageU8};
pub use aprilgrid::{find_aprilgrid, AprilGridDetection, AprilGridParams};
pub use charuco::{find_charuco, find_charuco_u8, CharucoDetection, CharucoParams};
pub use chessboard::{find_chessboard, ChessboardCorners, ChessboardParams};
pub use markers::{find_markers, CornerParams, MarkerDetection, MarkerParams, MarkerSet};
pub use saddle_fit::{refine_saddle, SaddleFit, SaddleFitParams};
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
    /// The image has no pixels.
    #[error("image is empty ({width} x {height})")]
    EmptyImage {
        /// Width, pixels.
        width: usize,
        /// Height, pixels.
        height: usize,
    },
    /// Invalid detector parameters.
    #[error("invalid parameters: {reason}")]
    BadParams {
        /// Why.
        reason: &'static str,
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
