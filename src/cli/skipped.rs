//! Inputs a command leaves out, with the reason, as `detect` and `calibrate` list them.

use serde::Serialize;

/// An input left out, and why.
#[derive(Debug, Clone, Serialize)]
pub struct Skipped {
    /// File name.
    pub file: String,
    /// Why it was left out.
    pub reason: String,
}

impl Skipped {
    /// An input left out for `reason`.
    pub fn new(file: impl Into<String>, reason: impl Into<String>) -> Self {
        Self { file: file.into(), reason: reason.into() }
    }

    /// An image of `size` (width, height) left out because the first image was `first`; the
    /// warning goes to standard error.
    pub fn other_size(file: impl Into<String>, size: (usize, usize), first: (usize, usize), hint: &str) -> Self {
        let file = file.into();
        let reason = format!("image size {}x{} differs from the first image's {}x{}{hint}", size.0, size.1, first.0, first.1);
        eprintln!("warning: skipping {file}: {reason}");
        Self { file, reason }
    }
}
