//! synthcam's files: image datasets with truth ([`dataset`]: PNG / JSON written atomically, COCO,
//! WebDataset, MCAP, shards and manifests) and reports ([`report`]: plots, overlays, markdown and
//! self-contained HTML). The only layer besides the command line that touches the filesystem.
//!
//! ```
//! use synthcam_core::{camera::CameraModel, target::Target};
//! use synthcam_io::dataset::formats::coco::coco_json;
//! use synthcam_scene::{truth_labels, Facing, Scene};
//! # fn main() -> Result<(), Box<dyn std::error::Error>> {
//! let scene = Scene::builder()
//!     .camera(CameraModel::pinhole(640, 480, 500.0))
//!     .target(Target::chessboard(8, 6, 0.03))
//!     .facing(Facing { distance_m: 0.5, tilt_x_deg: 0.0, tilt_y_deg: 15.0, roll_deg: 0.0 })
//!     .build()?;
//! // COCO keypoints of one image's truth (pixel positions as the truth has them, OpenCV's convention).
//! let json: serde_json::Value = serde_json::from_slice(&coco_json(&[truth_labels(&scene)], &["000000.png".into()])?)?;
//! assert_eq!(json["annotations"][0]["num_keypoints"], 35);
//! # Ok(())
//! # }
//! ```
//!
//! Users reach these through the `synthcam` facade (`synthcam::dataset`, ...), which re-exports them.

#![deny(missing_docs)]

pub mod dataset;
pub mod report;
