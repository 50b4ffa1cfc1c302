//! Small numerical helpers shared by the camera, calibration and pose code:
//! finite-difference Jacobians ([`numdiff`]) and rotation utilities on SO(3)
//! ([`so3`]: skew matrices, Rodrigues vectors, projection onto SO(3)), exact polygon clipping and
//! polygon-disc areas ([`polygon`]), golden-section search ([`golden`]).
//!
//! Reference: Nocedal & Wright, "Numerical Optimization" (2006), ch. 8 (finite
//! differences); OpenCV calib3d docs, `cv::Rodrigues`.

pub mod golden;
pub mod homography;
pub mod numdiff;
pub mod polygon;
pub mod se3;
pub mod so3;
pub mod spline;
