//! synthcam's estimation layer, on detected pixels: camera calibration ([`calib`]), PnP ([`pnp`]),
//! hand-eye calibration ([`handeye`]) and the visual-servo laws ([`servo`]). f64 nalgebra
//! throughout; each module cites its reference and is tested against an outside value.
//!
//! ```
//! use nalgebra::{Isometry3, Vector3};
//! use synthcam_core::{camera::CameraModel, target::Target};
//! use synthcam_geometry::pnp::pnp_planar;
//! # fn main() -> Result<(), Box<dyn std::error::Error>> {
//! let camera = CameraModel::pinhole(1280, 1024, 1000.0).with_distortion([-0.2, 0.05, 0.0, 0.0, 0.0]);
//! let board = Target::chessboard(10, 7, 0.03).feature_points_m();
//! let cam_from_target = Isometry3::new(Vector3::new(-0.12, -0.08, 0.6), Vector3::new(0.3, -0.2, 0.1));
//! let pixels: Vec<_> = board.iter().map(|p| camera.project(&(cam_from_target * p)).pixel_px).collect();
//! let found = pnp_planar(&camera, &board, &pixels)?; // homography start, then Levenberg-Marquardt
//! assert!((found.cam_from_target.translation.vector - cam_from_target.translation.vector).norm() < 1e-9);
//! # Ok(())
//! # }
//! ```
//!
//! Users reach these through the `synthcam` facade (`synthcam::calib`, ...), which re-exports them.

#![deny(missing_docs)]

pub mod calib;
pub mod handeye;
pub mod pnp;
pub mod servo;
