//! Validation of `[poses]` ([`PosesSpec`]) into a [`PoseMode`].

use super::{check_finite, check_margin, check_range, invalid, BoardRanges, PoseMode, PosesSpec};
use crate::dataset::error::SpecError;
use synthcam_core::camera::CameraModel;
use synthcam_core::robot::Cell;
use synthcam_core::target::Target;

impl PosesSpec {
    /// A board's partial-view range ([`PosesSpec::Board`]'s `inside_fraction`), validated.
    pub(super) fn inside_fraction(&self) -> Result<Option<[f64; 2]>, SpecError> {
        match self {
            PosesSpec::Board { inside_fraction: Some(r), .. } => check_range("poses.inside_fraction", Some(r), 0.0, 1.0).map(Some),
            _ => Ok(None),
        }
    }

    /// A rig's `min_cameras` (default 1), within 1..=cameras; only board mode takes it, and only
    /// for a rig.
    pub(super) fn min_cameras(&self, cameras: usize) -> Result<usize, SpecError> {
        match self {
            PosesSpec::Board { min_cameras: Some(n), .. } if cameras == 0 => {
                Err(invalid("poses.min_cameras", format!("applies to [[cameras]] rigs; this dataset has one [camera] (got {n})")))
            }
            PosesSpec::Board { min_cameras: Some(n), .. } if *n == 0 || *n > cameras => {
                Err(invalid("poses.min_cameras", format!("must be in 1..={cameras} (the rig's cameras), got {n}")))
            }
            PosesSpec::Board { min_cameras: Some(n), .. } => Ok(*n),
            _ => Ok(1),
        }
    }

    /// The validated mode, whether the visibility constraint applies, and its margin.
    pub(super) fn to_mode(&self, target: &Target, camera: &CameraModel) -> Result<(PoseMode, bool, f64), SpecError> {
        match self {
            PosesSpec::Board { distance_m, tilt_deg, roll_deg, offset_x_m, offset_y_m, tilt_from, full_target_visible, margin_px, .. } => {
                if !target.is_planar() {
                    return Err(invalid("poses.mode", "\"board\" needs a planar target (chessboard, dot-grid or charuco); use \"robot\" for the s-path"));
                }
                // A fisheye that reaches beyond 90 degrees sees boards behind its camera plane.
                let behind_ok = camera.lens.max_angle_rad() > std::f64::consts::FRAC_PI_2;
                let d = check_range("poses.distance_m", Some(distance_m), f64::MIN, f64::MAX)?;
                if !(d[0] > 0.0) && !behind_ok {
                    return Err(invalid("poses.distance_m", format!("must be > 0 (a lens that sees behind its camera plane allows <= 0), got {d:?}")));
                }
                let ranges = BoardRanges {
                    distance_m: d,
                    tilt_deg: check_range("poses.tilt_deg", Some(tilt_deg), 0.0, 89.0)?,
                    roll_deg: check_range("poses.roll_deg", roll_deg.as_ref(), -360.0, 360.0)?,
                    offset_x_m: check_range("poses.offset_x_m", offset_x_m.as_ref(), f64::MIN, f64::MAX)?,
                    offset_y_m: check_range("poses.offset_y_m", offset_y_m.as_ref(), f64::MIN, f64::MAX)?,
                    tilt_from: tilt_from.unwrap_or_default(),
                };
                Ok((PoseMode::Board(ranges), full_target_visible.unwrap_or(true), check_margin("poses.margin_px", *margin_px)?))
            }
            PosesSpec::Course { margin_px } => Ok((PoseMode::Course, true, check_margin("poses.margin_px", *margin_px)?)),
            PosesSpec::Robot { q0_rad, spread_rad, base_t_m, tool_from_cam_t_m, tool_from_cam_r, full_target_visible, margin_px } => {
                if !matches!(target, Target::SPath(_)) {
                    return Err(invalid("poses.mode", "\"robot\" looks at the s-path target (kind = \"s-path\")"));
                }
                let d = Cell::default();
                let s = Cell {
                    q0_rad: q0_rad.unwrap_or(d.q0_rad),
                    spread_rad: spread_rad.unwrap_or(d.spread_rad),
                    base_t_m: base_t_m.unwrap_or(d.base_t_m),
                    tool_from_cam_t_m: tool_from_cam_t_m.unwrap_or(d.tool_from_cam_t_m),
                    tool_from_cam_r: tool_from_cam_r.unwrap_or(d.tool_from_cam_r),
                };
                check_finite("poses.q0_rad", &s.q0_rad)?;
                if !(s.spread_rad >= 0.0) || !s.spread_rad.is_finite() {
                    return Err(invalid("poses.spread_rad", format!("must be finite and >= 0, got {}", s.spread_rad)));
                }
                check_finite("poses.base_t_m", &s.base_t_m)?;
                check_finite("poses.tool_from_cam_t_m", &s.tool_from_cam_t_m)?;
                let m = nalgebra::Matrix3::from_fn(|i, j| s.tool_from_cam_r[i][j]);
                let orth = (m.transpose() * m - nalgebra::Matrix3::identity()).abs().max();
                if !(orth <= 1e-6) || !(m.determinant() > 0.0) {
                    return Err(invalid("poses.tool_from_cam_R", format!("is not a rotation (|R^T R - I|max = {orth:.2e})")));
                }
                Ok((PoseMode::Robot(s), full_target_visible.unwrap_or(true), check_margin("poses.margin_px", *margin_px)?))
            }
        }
    }
}
