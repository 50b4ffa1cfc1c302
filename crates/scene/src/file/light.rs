//! `[[light]]` tables in scene and dataset files ([`crate::lighting`]).

use serde::Deserialize;

use crate::{RenderSettings, SceneError};

/// One `[[light]]` table: `kind = "directional"`, `frame` (`"camera"`, default, or `"target"`),
/// `direction = [x, y, z]` (the direction the light travels) and `irradiance` (grey levels per
/// unit albedo on a surface facing it).
#[derive(Debug, Clone, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct LightSpec {
    /// Only `"directional"` so far (point and area lights are issue 41's next step).
    pub kind: String,
    /// The frame of `direction`.
    #[serde(default)]
    pub frame: crate::lighting::LightFrame,
    /// The direction the light travels.
    pub direction: [f64; 3],
    /// Irradiance, grey levels per unit albedo.
    pub irradiance: f64,
}

/// `settings` with the `[[light]]` tables added to its lighting.
///
/// # Errors
/// [`SceneError::InvalidField`] for a kind other than `"directional"` or a bad light.
pub fn with_lights(mut settings: RenderSettings, lights: &[LightSpec]) -> Result<RenderSettings, SceneError> {
    for l in lights {
        if l.kind != "directional" {
            return Err(SceneError::InvalidField { field: "light.kind".into(), reason: format!("only \"directional\" lights so far, got {:?}", l.kind) });
        }
        settings.lighting.add(l.frame, l.direction, l.irradiance)?;
    }
    settings.lighting.validate()?;
    Ok(settings)
}
