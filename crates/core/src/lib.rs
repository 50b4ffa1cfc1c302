//! synthcam's foundation, the layer every other crate builds on: maths ([`math`]: SO(3) / SE(3),
//! splines, homographies, exact polygon areas), cameras and their lenses ([`camera`]), calibration
//! targets ([`target`]), robots ([`robot`]: URDF chains, kinematics, the cells) and triangle meshes
//! ([`mesh`]: OBJ, primitives, BVH). Pure values: no GPU, no files but the assets compiled in.
//!
//! Users reach these through the `synthcam` facade (`synthcam::camera`, ...), which re-exports them.

#![deny(missing_docs)]

pub mod camera;
pub mod math;
pub mod mesh;
pub mod robot;
pub mod target;
