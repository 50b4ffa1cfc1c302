//! # synthcam
//!
//! A synthetic-camera pipeline for robotics vision: a headless GPU renderer (wgpu; lavapipe or
//! llvmpipe without a GPU) that inverts the lens model per pixel in the shader (OpenCV's
//! Brown-Conrady with up to 14 coefficients, Kannala-Brandt fisheye beyond 180 degrees, Double
//! Sphere), anti-aliased and deterministic, with exact truth labels; and the vision stack that
//! runs on its pixels: [`detect`] (chessboards, dot grids, the S-path, ChArUco, AprilGrid),
//! [`calib`] (Zhang or a focal sweep, then Levenberg-Marquardt), [`pnp`], [`handeye`], [`servo`]
//! (PBVS, IBVS) and the closed-loop simulator `sim` with its robots ([`robot`]).
//!
//! ## The front door
//!
//! Render a distorted board with truth, detect it, calibrate from the views and write OpenCV YAML
//! (the example `calibrate_from_renders` is the same code):
//!
//! ```
//! use synthcam::prelude::*;
//! # fn main() -> Result<(), Box<dyn std::error::Error>> {
//! let camera = CameraModel::pinhole(1280, 1024, 1000.0).with_distortion([-0.25, 0.08, 0.0, 0.0, 0.0]);
//! let (board, renderer) = (Target::chessboard(10, 7, 0.03), Renderer::headless()?);
//! let mut detections = Vec::new();
//! for (tilt_x_deg, tilt_y_deg) in [(0.0, 0.0), (30.0, 0.0), (-30.0, 10.0), (0.0, 30.0), (10.0, -30.0), (25.0, 25.0)] {
//!     let facing = Facing { distance_m: 0.5, tilt_x_deg, tilt_y_deg, roll_deg: 0.0 };
//!     let scene = Scene::builder().camera(camera).target(board.clone()).facing(facing).noise(1.0).build()?;
//!     let (image, _truth) = renderer.render_with_truth(&scene)?; // truth: every corner's exact pixel
//!     detections.push(detect(&image.to_detector_image()?, &TargetSpec::for_target(&board))?);
//! }
//! let views = views_from_detections(&detections, &TargetSpec::for_target(&board), 0.03)?;
//! let result = calibrate(&views.views, camera.size, &CalibParams::default())?;
//! std::fs::write(std::env::temp_dir().join("camera.yaml"), opencv_yaml(&result.camera, result.rms_px)?)?;
//! assert!((result.camera.intrinsics.fx - 1000.0).abs() < 0.5);
//! # Ok(())
//! # }
//! ```
//!
//! ## Module map (dependencies point one way)
//! [`math`] <- [`camera`] / [`target`] / [`robot`] / [`mesh`] <- [`scene`] <- [`detect`] <-
//! [`calib`] / [`pnp`] / [`handeye`] / [`servo`] <- `render` <- `sim` <- `dataset` / `report`
//! <- `cli` (the binary) and the Python module (`python/`). Modules below `render` are pure (no
//! file I/O, no wgpu, no global state). Only `render` names wgpu; only `dataset`, `report` and
//! the CLI touch the filesystem (checked by `tests/e2e/architecture.rs`). `render`, `sim`,
//! `dataset` and `report` need the default `render` feature. ARCHITECTURE.md says where to add a
//! lens, a target, a detector or an effect.
//!
//! # Conventions
//! - Camera frame: x right, y down, z forward.
//! - Pixels: OpenCV's; the centre of the top-left pixel is (0, 0), an image spans
//!   [-0.5, W-0.5] x [-0.5, H-0.5].
//! - Board frame: the target's own, for rendering, truth and calibration alike: origin at the
//!   board's outer corner, x along its columns, y along its rows (a chessboard's first inner
//!   corner at `(square, square, 0)`, as OpenCV's ChArUco boards; an AprilGrid in Kalibr's frame,
//!   origin at tag 0's corner; see [`calib::views`]).
//! - Distortion: OpenCV order (k1, k2, p1, p2, k3, ...) plus skew = `K[0][1]` in pixels; see
//!   [`camera`] for the mapping to other conventions.
//! - Transforms: `Isometry3<f64>` named `a_from_b` (maps b coordinates into a), e.g.
//!   `cam_from_target`.
//! - Units: SI and radians; names carry the unit where it is not SI (`_px`, `_deg`).
//! - Intensities: grey levels in [0, 255] before quantisation.

#![deny(missing_docs)]

// The layers, one crate each (ARCHITECTURE.md), re-exported under their module names.
pub use synthcam_core::{camera, math, mesh, robot, target};
#[cfg(feature = "render")]
pub use synthcam_course as course;
pub use synthcam_detect as detect;
pub use synthcam_geometry::{calib, handeye, pnp, servo};
#[cfg(feature = "render")]
pub use synthcam_io::{dataset, report};
#[cfg(feature = "render")]
pub use synthcam_render as render;
pub use synthcam_scene as scene;
#[cfg(feature = "render")]
pub use synthcam_sim as sim;

pub mod error;
pub mod prelude;

pub use error::Error;
/// The image types of the API.
pub use image;
/// The linear-algebra types of the API (poses, points, matrices).
pub use nalgebra;
