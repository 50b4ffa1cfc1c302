//! The `[camera]` table of scene files, dataset specs and scenarios (see [`super`]).

use serde::Deserialize;

use synthcam_core::camera::{CameraError, CameraModel, Distortion, DoubleSphere, Fisheye, ImageSize, Intrinsics, Lens};

/// The lens model of a `[camera]` table.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, Deserialize, serde::Serialize)]
#[serde(rename_all = "kebab-case")]
pub enum ModelName {
    /// OpenCV's model, `dist` of 4, 5, 8, 12 or 14 values.
    #[default]
    Opencv,
    /// OpenCV's fisheye (Kannala-Brandt) model, `dist = [k1, k2, k3, k4]`.
    Fisheye,
    /// Double Sphere, `xi` and `alpha`.
    DoubleSphere,
}

/// `[camera]` table.
#[derive(Debug, Clone, PartialEq, Deserialize, serde::Serialize)]
#[serde(deny_unknown_fields)]
pub struct CameraSpec {
    /// Image width, pixels.
    pub width: u32,
    /// Image height, pixels.
    pub height: u32,
    /// Focal length along x, pixels.
    pub fx: f64,
    /// Focal length along y, pixels.
    pub fy: f64,
    /// Principal point x, pixels (OpenCV convention).
    pub cx: f64,
    /// Principal point y, pixels.
    pub cy: f64,
    /// `K[0][1]`, pixels.
    #[serde(default)]
    pub skew: f64,
    /// Lens model (default `opencv`).
    #[serde(default)]
    pub model: ModelName,
    /// The model's coefficients: OpenCV order (4, 5, 8, 12 or 14 values) or fisheye `k1..k4`.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub dist: Option<Vec<f64>>,
    /// Double Sphere `xi`.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub xi: Option<f64>,
    /// Double Sphere `alpha`.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub alpha: Option<f64>,
}

fn bad(field: &'static str, reason: String) -> CameraError {
    CameraError::InvalidParameter { field, reason }
}

impl CameraSpec {
    fn lens(&self) -> Result<Lens, CameraError> {
        let dist = self.dist.as_deref();
        match self.model {
            ModelName::Opencv | ModelName::Fisheye if self.xi.is_some() || self.alpha.is_some() => {
                Err(bad(if self.xi.is_some() { "xi" } else { "alpha" }, "only the double-sphere model has xi and alpha".into()))
            }
            ModelName::Opencv => Ok(Lens::OpenCv(Distortion::from_opencv(dist.unwrap_or(&[0.0; 5]))?)),
            ModelName::Fisheye => match dist.unwrap_or(&[0.0; 4]) {
                &[k1, k2, k3, k4] => Ok(Lens::Fisheye(Fisheye { k: [k1, k2, k3, k4] })),
                d => Err(bad("dist", format!("the fisheye model has 4 coefficients [k1, k2, k3, k4], got {}", d.len()))),
            },
            ModelName::DoubleSphere => {
                if dist.is_some() {
                    return Err(bad("dist", "the double-sphere model has no dist; give xi and alpha".into()));
                }
                let xi = self.xi.ok_or_else(|| bad("xi", "the double-sphere model needs xi".into()))?;
                let alpha = self.alpha.ok_or_else(|| bad("alpha", "the double-sphere model needs alpha".into()))?;
                Ok(Lens::DoubleSphere(DoubleSphere { xi, alpha }))
            }
        }
    }

    /// The camera model this table describes (the lens checked for its model's shape; the
    /// values are checked by [`CameraModel::validate`]).
    ///
    /// # Errors
    /// A `dist` of the wrong length for its model, `xi`/`alpha` on a model without them.
    pub fn to_model(&self) -> Result<CameraModel, CameraError> {
        Ok(CameraModel {
            size: ImageSize { width: self.width, height: self.height },
            intrinsics: Intrinsics { fx: self.fx, fy: self.fy, cx: self.cx, cy: self.cy, skew: self.skew },
            lens: self.lens()?,
        })
    }

    /// The table describing `camera` (OpenCV: at least the 5 Brown-Conrady values).
    pub fn from_model(camera: &CameraModel) -> Self {
        let k = &camera.intrinsics;
        let p = camera.lens.params();
        let (model, dist, xi, alpha) = match camera.lens {
            Lens::OpenCv(d) => (ModelName::Opencv, Some(p[..d.opencv_len().max(5)].to_vec()), None, None),
            Lens::Fisheye(_) => (ModelName::Fisheye, Some(p[..4].to_vec()), None, None),
            Lens::DoubleSphere(d) => (ModelName::DoubleSphere, None, Some(d.xi), Some(d.alpha)),
        };
        Self { width: camera.size.width, height: camera.size.height, fx: k.fx, fy: k.fy, cx: k.cx, cy: k.cy, skew: k.skew, model, dist, xi, alpha }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn spec(extra: &str) -> Result<CameraModel, String> {
        let text = format!("width = 640\nheight = 480\nfx = 300.0\nfy = 300.0\ncx = 319.5\ncy = 239.5\n{extra}");
        let s: CameraSpec = toml::from_str(&text).map_err(|e| e.to_string())?;
        s.to_model().map_err(|e| e.to_string())
    }

    #[test]
    fn every_model_parses_and_round_trips() {
        for (extra, kind) in [
            ("", "opencv"),
            ("dist = [-0.1, 0.01, 0.0, 0.0]", "opencv"),
            ("dist = [-0.1, 0.01, 0.0, 0.0, 0.0, 0.01, 0.0, 0.0, 1e-4, 0.0, 0.0, 0.0, 0.01, 0.0]", "opencv"),
            ("model = \"fisheye\"\ndist = [0.05, -0.01, 0.0, 0.0]", "fisheye"),
            ("model = \"double-sphere\"\nxi = -0.2\nalpha = 0.6", "double-sphere"),
        ] {
            let cam = spec(extra).unwrap_or_else(|e| panic!("{extra}: {e}"));
            assert_eq!(cam.lens.kind().name(), kind);
            let back = CameraSpec::from_model(&cam).to_model().expect("round trip");
            assert_eq!(back, cam, "{extra}");
        }
    }

    #[test]
    fn wrong_shapes_name_the_field() {
        for (extra, field) in [
            ("dist = [0.1, 0.2, 0.3]", "dist"),
            ("model = \"fisheye\"\ndist = [0.1, 0.2, 0.3, 0.4, 0.5]", "dist"),
            ("model = \"double-sphere\"\nxi = 0.1", "alpha"),
            ("model = \"double-sphere\"\nxi = 0.1\nalpha = 0.5\ndist = [0.0]", "dist"),
            ("xi = 0.1", "xi"),
        ] {
            let e = spec(extra).expect_err(extra);
            assert!(e.contains(field), "{extra}: {e}");
        }
        assert!(spec("model = \"kannala\"").is_err());
    }
}
