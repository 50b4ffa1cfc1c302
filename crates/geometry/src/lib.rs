//! synthcam's estimation layer, on detected pixels: camera calibration ([`calib`]), PnP ([`pnp`]),
//! hand-eye calibration ([`handeye`]) and the visual-servo laws ([`servo`]). f64 nalgebra
//! throughout; each module cites its reference and is tested against an outside value.
//!
//! Users reach these through the `synthcam` facade (`synthcam::calib`, ...), which re-exports them.

#![deny(missing_docs)]

pub mod calib;
pub mod handeye;
pub mod pnp;
pub mod servo;
