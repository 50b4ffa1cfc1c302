//! [`Facing`]: a target's pose by distance and tilts, its centre on the optical axis: the pose a
//! person means by "the board half a metre away, turned 30 degrees".

use nalgebra::{Isometry3, Translation3, UnitQuaternion, Vector3};
use serde::{Deserialize, Serialize};

use super::SceneError;
use synthcam_core::target::Target;

/// `cam_from_target` by distance and tilts: the target's centre (the mean of its feature points)
/// on the optical axis at `distance_m`, the target turned by `tilt_x_deg` about the camera's x
/// axis, then `tilt_y_deg` about y, then `roll_deg` about the optical axis. All zero: the target
/// faces the camera, its x axis along the image's u, its y along v.
///
/// The `[facing]` table of a scene file and Python's `synthcam.facing(...)` are the same fields.
///
/// ```
/// use synthcam_scene::Facing;
/// use synthcam_core::target::Target;
/// let board = Target::chessboard(9, 7, 0.03);
/// let pose = Facing { distance_m: 0.6, tilt_x_deg: 30.0, ..Facing::default() }.cam_from_target(&board)?;
/// // the board's centre (4.5 and 3.5 squares from its corner) lies on the optical axis
/// let centre = pose * nalgebra::Point3::new(0.135, 0.105, 0.0);
/// assert!(centre.x.abs() < 1e-12 && centre.y.abs() < 1e-12 && (centre.z - 0.6).abs() < 1e-12);
/// # Ok::<(), synthcam_scene::SceneError>(())
/// ```
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct Facing {
    /// Distance from the camera centre to the target's centre along the optical axis, metres.
    pub distance_m: f64,
    /// Turn about the camera's x axis (top edge away from the camera when positive), degrees.
    pub tilt_x_deg: f64,
    /// Turn about the camera's y axis, degrees.
    pub tilt_y_deg: f64,
    /// Turn about the optical axis, degrees.
    pub roll_deg: f64,
}

impl Default for Facing {
    /// Half a metre away, facing the camera.
    fn default() -> Self {
        Self { distance_m: 0.5, tilt_x_deg: 0.0, tilt_y_deg: 0.0, roll_deg: 0.0 }
    }
}

impl Facing {
    /// Facing the camera `distance_m` away.
    pub fn at(distance_m: f64) -> Self {
        Self { distance_m, ..Self::default() }
    }

    /// `cam_from_target` of `target` in this pose.
    ///
    /// # Errors
    /// [`SceneError::InvalidField`]: a non-finite field or a distance that is not positive.
    pub fn cam_from_target(&self, target: &Target) -> Result<Isometry3<f64>, SceneError> {
        let fields = [("distance_m", self.distance_m), ("tilt_x_deg", self.tilt_x_deg), ("tilt_y_deg", self.tilt_y_deg), ("roll_deg", self.roll_deg)];
        if let Some((name, v)) = fields.iter().find(|(_, v)| !v.is_finite()) {
            return Err(SceneError::InvalidField { field: format!("facing.{name}"), reason: format!("must be finite, got {v}") });
        }
        if self.distance_m <= 0.0 {
            return Err(SceneError::InvalidField { field: "facing.distance_m".into(), reason: format!("must be positive, got {}", self.distance_m) });
        }
        let centre = target.feature_centre_m().coords;
        let rot = UnitQuaternion::from_axis_angle(&Vector3::z_axis(), self.roll_deg.to_radians())
            * UnitQuaternion::from_axis_angle(&Vector3::y_axis(), self.tilt_y_deg.to_radians())
            * UnitQuaternion::from_axis_angle(&Vector3::x_axis(), self.tilt_x_deg.to_radians());
        Ok(Isometry3::from_parts(Translation3::new(0.0, 0.0, self.distance_m), rot) * Translation3::from(-centre))
    }
}

#[cfg(test)]
mod tests {
    use nalgebra::Point3;

    use super::*;

    #[test]
    fn tilts_turn_about_the_camera_axes_in_order() {
        let board = Target::chessboard(3, 3, 0.1); // inner corners 2 x 2: centre (0.15, 0.15)
        let pose = Facing { distance_m: 1.0, tilt_x_deg: 90.0, ..Facing::default() }.cam_from_target(&board).unwrap();
        // +90 degrees about x sends the target's +y (one square below the centre) to the camera's +z
        let p = pose * Point3::new(0.15, 0.25, 0.0);
        assert!((p - Point3::new(0.0, 0.0, 1.1)).norm() < 1e-12, "{p}");
        // roll after the tilts: +90 about z sends the target's +x to the camera's +y
        let pose = Facing { distance_m: 1.0, roll_deg: 90.0, ..Facing::default() }.cam_from_target(&board).unwrap();
        assert!((pose * Point3::new(0.25, 0.15, 0.0) - Point3::new(0.0, 0.1, 1.0)).norm() < 1e-12);
    }

    #[test]
    fn bad_fields_are_named() {
        let board = Target::chessboard(3, 3, 0.1);
        let e = Facing { distance_m: 0.0, ..Facing::default() }.cam_from_target(&board).unwrap_err();
        assert!(e.to_string().contains("facing.distance_m"), "{e}");
        let e = Facing { roll_deg: f64::NAN, ..Facing::default() }.cam_from_target(&board).unwrap_err();
        assert!(e.to_string().contains("facing.roll_deg"), "{e}");
    }
}
