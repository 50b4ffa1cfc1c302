//! Everything that touches files: PNG and JSON output written atomically (temporary name, then
//! rename), so a failed run never leaves a truncated image behind.

pub mod calib_io;
pub mod handeye_run;
pub mod io;
pub mod observe;
pub mod overlay;
pub mod plot;
pub mod servo_report;
pub mod servo_run;
pub mod sweep;

pub use io::{encode_png, load_grey, write_atomic, write_image_and_truth};

/// File errors.
#[derive(Debug, thiserror::Error)]
#[non_exhaustive]
pub enum DatasetError {
    /// A file could not be written.
    #[error("cannot write {path}: {source}")]
    Write {
        /// The path.
        path: String,
        /// The OS error.
        source: std::io::Error,
    },
    /// A file could not be read or decoded.
    #[error("cannot read {path}: {reason}")]
    Read {
        /// The path.
        path: String,
        /// Why.
        reason: String,
    },
    /// PNG encoding failed.
    #[error("cannot encode PNG: {0}")]
    Encode(String),
    /// JSON serialisation failed.
    #[error("cannot serialise JSON: {0}")]
    Json(String),
}
