//! `[[cameras]]`: a rig in a scene file. Each entry is a camera table as `[camera]` is, plus its
//! `name` and its pose in the rig frame, `rig_from_cam` (a table as `[pose]`: `R` or `rvec`, and
//! `t_m`); the scene's `[pose]` (or `[facing]`) is then `rig_from_target`. A first camera at the
//! identity makes the rig frame its own, as Kalibr's and mrcal's rigs do.

use std::collections::BTreeSet;

use nalgebra::Isometry3;
use serde::{Deserialize, Deserializer};

use super::{CameraSpec, PoseSpec};
use crate::SceneError;

/// One `[[cameras]]` entry.
#[derive(Debug, Clone)]
pub struct RigCameraSpec {
    /// The camera's name, unique in the rig (its images are named after it).
    pub name: String,
    /// Its pose in the rig frame.
    pub rig_from_cam: PoseSpec,
    /// Its camera table.
    pub camera: CameraSpec,
}

impl<'de> Deserialize<'de> for RigCameraSpec {
    /// The camera table's own fields stay strict (`deny_unknown_fields`): `name` and
    /// `rig_from_cam` are taken out first, the rest must be a camera table.
    fn deserialize<D: Deserializer<'de>>(d: D) -> Result<Self, D::Error> {
        use serde::de::Error;
        let mut v = serde_json::Map::<String, serde_json::Value>::deserialize(d)?;
        let name = match v.remove("name") {
            Some(serde_json::Value::String(s)) => s,
            Some(_) => return Err(D::Error::custom("cameras: `name` must be a string")),
            None => return Err(D::Error::custom("cameras: every camera needs a `name`")),
        };
        let pose = v.remove("rig_from_cam").ok_or_else(|| D::Error::custom(format!("camera {name:?}: `rig_from_cam` (R or rvec, and t_m) is missing")))?;
        let rig_from_cam = PoseSpec::deserialize(pose).map_err(|e| D::Error::custom(format!("camera {name:?}: rig_from_cam: {e}")))?;
        let camera = CameraSpec::deserialize(serde_json::Value::Object(v)).map_err(|e| D::Error::custom(format!("camera {name:?}: {e}")))?;
        Ok(Self { name, rig_from_cam, camera })
    }
}

/// The rig's cameras as `(name, camera table, cam_from_rig)`, checked: at least one, names unique
/// and not empty, every `rig_from_cam` a rigid transform.
///
/// # Errors
/// [`SceneError::InvalidField`] naming the camera.
pub fn rig_cameras(cams: &[RigCameraSpec]) -> Result<Vec<(String, CameraSpec, Isometry3<f64>)>, SceneError> {
    let mut names = BTreeSet::new();
    cams.iter()
        .map(|c| {
            let invalid = |reason: String| SceneError::InvalidField { field: format!("cameras.{}", c.name), reason };
            if c.name.is_empty() || !names.insert(c.name.clone()) {
                return Err(invalid("camera names must be unique and not empty".into()));
            }
            let rig_from_cam = c.rig_from_cam.to_isometry().map_err(|e| invalid(format!("rig_from_cam: {e}")))?;
            Ok((c.name.clone(), c.camera.clone(), rig_from_cam.inverse()))
        })
        .collect()
}

#[cfg(test)]
mod tests {
    use super::super::parse_spec;
    use crate::SceneError;

    const RIG: &str = include_str!("../../assets/scenes/stereo_rig.toml");

    #[test]
    fn each_camera_sees_the_target_through_its_rig_pose() {
        let spec = parse_spec(RIG).expect("spec");
        let scenes = spec.to_rig_scenes_with(&|_: &str| unreachable!("no objects")).expect("scenes");
        let names: Vec<&str> = scenes.iter().map(|(n, _)| n.as_str()).collect();
        assert_eq!(names, ["left", "right"]);
        let (left, right) = (&scenes[0].1, &scenes[1].1);
        assert_eq!((left.camera.intrinsics.fx, right.camera.intrinsics.fx), (1100.0, 1120.0));
        // right_from_target = right_from_rig rig_from_target, rig = left here.
        let rig_from_right = nalgebra::Isometry3::from_parts(
            nalgebra::Translation3::new(0.12, 0.0, 0.0),
            nalgebra::UnitQuaternion::from_scaled_axis(nalgebra::Vector3::new(0.0, -0.03490658503988659, 0.0)),
        );
        let want = rig_from_right.inverse() * left.cam_from_target;
        assert!((right.cam_from_target.to_homogeneous() - want.to_homogeneous()).abs().max() < 1e-12);
        // A single-camera scene is refused by to_scene for a rig, and a rig by nothing else.
        assert!(matches!(spec.to_scene(), Err(SceneError::InvalidField { .. })));
    }

    #[test]
    fn bad_rigs_are_named_errors() {
        let dup = RIG.replace("name = \"right\"", "name = \"left\"");
        let not_rotation = RIG.replace("rvec = [0.0, -0.03490658503988659, 0.0], t_m", "R = [[1.0, 0.0, 0.0], [0.0, 2.0, 0.0], [0.0, 0.0, 1.0]], t_m");
        let both = format!("[camera]\nwidth = 640\nheight = 480\nfx = 500.0\nfy = 500.0\ncx = 319.5\ncy = 239.5\n{RIG}");
        for (what, text) in [("duplicate names", dup), ("not a rotation", not_rotation), ("[camera] and [[cameras]]", both)] {
            let r = parse_spec(&text).and_then(|s| s.to_rig_scenes_with(&|_: &str| unreachable!()));
            assert!(matches!(r, Err(SceneError::InvalidField { .. })), "{what}: {r:?}");
        }
        let unnamed = RIG.replacen("name = \"left\"\n", "", 1);
        assert!(parse_spec(&unnamed).is_err_and(|e| e.to_string().contains("name")));
        let no_pose = RIG.replacen("rig_from_cam = { rvec = [0.0, 0.0, 0.0], t_m = [0.0, 0.0, 0.0] }\n", "", 1);
        assert!(parse_spec(&no_pose).is_err_and(|e| e.to_string().contains("rig_from_cam")));
        let typo = RIG.replacen("fx = 1100.0", "fxx = 1100.0", 1);
        assert!(parse_spec(&typo).is_err_and(|e| e.to_string().contains("fxx")));
    }
}
