//! `use synthcam::prelude::*;`: the types and functions of the common path (a camera and a target
//! in a scene, rendered with truth, detected, calibrated, posed, written out), and the nalgebra
//! types they take. Everything else is one module path away (see the crate's module map).

pub use nalgebra::{Isometry3, Point2, Point3, Vector3};

pub use crate::calib::{calibrate, views_from_detections, BoardViews, CalibModel, CalibParams, CalibResult, View};
pub use crate::camera::formats::{kalibr_yaml, mrcal_cameramodel, opencv_yaml, ros_yaml};
pub use crate::camera::{CameraModel, ImageSize, Lens};
pub use crate::detect::target::{detect, Detection, TargetSpec};
pub use crate::detect::ImageF32;
pub use crate::pnp::{pnp_general, pnp_planar, PnpResult};
#[cfg(feature = "render")]
pub use crate::render::{GreyImage, Renderer};
pub use crate::scene::{Facing, Scene, TruthLabels};
pub use crate::target::{AprilGrid, Charuco, Chessboard, Dictionary, DotGrid, Target};
pub use crate::Error;
