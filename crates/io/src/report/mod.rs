//! Reports: plots, detection overlays, calibration plots and the tables of the
//! servo, hand-eye and sweep runs, put together as [`doc::Document`]s written as markdown and as
//! self-contained HTML ([`html::page`]). Everything here returns bytes or text; the CLI writes them.

pub mod calib;
pub mod doc;
pub mod html;
pub mod overlay;
pub mod plot;
pub mod robustness;
pub mod servo;
pub mod sweep;

/// Errors of the report writers.
#[derive(Debug, thiserror::Error)]
#[non_exhaustive]
pub enum ReportError {
    /// PNG encoding failed.
    #[error("cannot encode PNG: {0}")]
    Encode(String),
    /// The data cannot be drawn (no series, an empty axis, frames of different sizes).
    #[error("cannot draw {what}: {reason}")]
    Input {
        /// Which plot or sheet.
        what: &'static str,
        /// Why.
        reason: String,
    },
}
