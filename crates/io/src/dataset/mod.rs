//! Everything that touches files: PNG and JSON output written atomically (temporary name, then
//! rename), so a failed run never leaves a truncated image behind.

pub mod background;
pub mod error;
pub mod extras;
pub mod formats;
pub mod generate;
pub mod io;
pub mod manifest;
pub mod meshes;
pub mod objects;
pub mod poses;
pub mod rng;
pub mod shard;
pub mod spec;

pub use error::SpecError;
pub use io::{encode_image, encode_jpeg, encode_png, load_grey, load_grey_u8, truth_json, write_atomic, write_image_and_truth, write_png_and_json};
pub use meshes::MeshLibrary;

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
    /// The dataset spec is invalid.
    #[error(transparent)]
    Spec(#[from] SpecError),
    /// A command-line value is invalid.
    #[error("invalid {what}: {reason}")]
    InvalidArgument {
        /// Which argument.
        what: String,
        /// Why.
        reason: String,
    },
    /// The output folder holds a dataset of another spec.
    #[error("{path} exists and differs from this spec: the folder holds another dataset (use a new folder)")]
    SpecMismatch {
        /// The spec copy in the folder.
        path: String,
    },
    /// Rendering failed.
    #[error("rendering image {k}: {reason}")]
    Render {
        /// Image index.
        k: u64,
        /// Why.
        reason: String,
    },
    /// A dataset folder is incomplete or has images that do not match its manifest.
    #[error("{}", manifest::incomplete_message(missing, bad))]
    Incomplete {
        /// Indices not listed in any manifest.
        missing: Vec<u64>,
        /// Listed images whose files are missing or do not match.
        bad: Vec<manifest::BadImage>,
    },
}
