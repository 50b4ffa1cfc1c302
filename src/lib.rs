//! # synthcam
//!
//! A synthetic-camera pipeline for robotics vision: a headless GPU renderer (wgpu; lavapipe or
//! llvmpipe without a GPU) that draws calibration targets and the 3-D S-path dot target with
//! Brown-Conrady distortion and skew applied in the shader, anti-aliased and deterministic, with
//! exact truth labels; and the vision stack that runs on its pixels: [`detect`] (chessboard
//! corners, dots, S-path ordering), [`calib`] (Zhang + Levenberg-Marquardt), [`robot`] (the
//! course's ABB IRB 1200).
//!
//! ## Module map (dependencies point one way)
//! `math` <- `camera` / `target` / `robot` / [`mesh`] <- `scene` <- `detect` / `calib` <- `render` / `dataset`
//! <- `cli`.
//! Modules below `render` are pure (no file I/O, no wgpu, no global state). Only [`render`] names
//! wgpu; only [`dataset`] and `cli` touch the filesystem (checked by `tests/e2e/architecture.rs`).
//!
//! # Conventions
//! - Camera frame: x right, y down, z forward.
//! - Pixels: OpenCV's; the centre of the top-left pixel is (0, 0), an image spans
//!   [-0.5, W-0.5] x [-0.5, H-0.5].
//! - Distortion: OpenCV order (k1, k2, p1, p2, k3) plus skew = `K[0][1]` in pixels; see [`camera`] for
//!   the mapping to the course's k1..k5 and alpha.
//! - Transforms: `Isometry3<f64>` named `a_from_b` (maps b coordinates into a), e.g.
//!   `cam_from_target`.
//! - Units: SI and radians; names carry the unit where it is not SI (`_px`, `_deg`).
//! - Intensities: grey levels in [0, 255] before quantisation.

#![deny(missing_docs)]

pub mod calib;
pub mod camera;
#[cfg(feature = "render")]
pub mod dataset;
pub mod detect;
pub mod error;
pub mod handeye;
pub mod math;
pub mod mesh;
pub mod pnp;
#[cfg(feature = "render")]
pub mod render;
#[cfg(feature = "render")]
pub mod report;
pub mod robot;
pub mod scene;
pub mod servo;
#[cfg(feature = "render")]
pub mod sim;
pub mod target;

pub use error::Error;
/// The image types of the API.
pub use image;
/// The linear-algebra types of the API (poses, points, matrices).
pub use nalgebra;
