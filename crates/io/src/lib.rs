//! synthcam's files: image datasets with truth ([`dataset`]: PNG / JSON written atomically, COCO,
//! WebDataset, MCAP, shards and manifests) and reports ([`report`]: plots, overlays, markdown and
//! self-contained HTML). The only layer besides the command line that touches the filesystem.
//!
//! Users reach these through the `synthcam` facade (`synthcam::dataset`, ...), which re-exports them.

#![deny(missing_docs)]

pub mod dataset;
pub mod report;
