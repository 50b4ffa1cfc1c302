//! synthcam's foundation, the layer every other crate builds on: maths ([`math`]: SO(3) / SE(3),
//! splines, homographies, exact polygon areas), cameras and their lenses ([`camera`]), calibration
//! targets ([`target`]), robots ([`robot`]: URDF chains, kinematics, the cells) and triangle meshes
//! ([`mesh`]: OBJ, primitives, BVH). Pure values: no GPU, no files but the assets compiled in.
//!
//! ```
//! use nalgebra::Point3;
//! use synthcam_core::camera::CameraModel;
//! use synthcam_core::target::Target;
//! # fn main() -> Result<(), Box<dyn std::error::Error>> {
//! // 1280 x 1024 px, fx = fy = 1000 px, barrel distortion in OpenCV's order (k1, k2, p1, p2, k3).
//! let camera = CameraModel::pinhole(1280, 1024, 1000.0).with_distortion([-0.25, 0.08, 0.0, 0.0, 0.0]);
//! let p_cam = Point3::new(0.12, -0.05, 0.5); // camera frame: x right, y down, z forward, metres
//! let seen = camera.project(&p_cam);
//! assert!(seen.visible());
//! // The lens inverted: the pixel's ray points back at the point.
//! let ray = camera.unproject(&seen.pixel_px)?;
//! assert!((ray.normalize() - p_cam.coords.normalize()).norm() < 1e-9);
//! // A 10 x 7-square chessboard of 30 mm squares has 9 x 6 inner corners (the target frame's points).
//! assert_eq!(Target::chessboard(10, 7, 0.03).feature_points_m().len(), 54);
//! # Ok(())
//! # }
//! ```
//!
//! Users reach these through the `synthcam` facade (`synthcam::camera`, ...), which re-exports them.

#![deny(missing_docs)]

pub mod camera;
pub mod math;
pub mod mesh;
pub mod robot;
pub mod target;
