//! `[[light]]` tables in scene and dataset files ([`crate::lighting`]).

use serde::Deserialize;

use crate::{RenderSettings, SceneError};

/// One `[[light]]` table: `kind = "directional"`, `frame` (`"camera"`, default, or `"target"`),
/// `direction = [x, y, z]` (the direction the light travels) and `irradiance` (grey levels per
/// unit albedo on a surface facing it); or `kind = "point"`, `frame`, `position_m` and
/// `intensity` (the irradiance at 1 m on a surface facing it).
#[derive(Debug, Clone, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct LightSpec {
    /// `"directional"` or `"point"` (area lights are issue 41's next step).
    pub kind: String,
    /// The frame of `direction` or `position_m`.
    #[serde(default)]
    pub frame: crate::lighting::LightFrame,
    /// Directional: the direction the light travels.
    pub direction: Option<[f64; 3]>,
    /// Directional: irradiance, grey levels per unit albedo.
    pub irradiance: Option<f64>,
    /// Point: position, metres.
    pub position_m: Option<[f64; 3]>,
    /// Point: irradiance at 1 m, grey levels per unit albedo.
    pub intensity: Option<f64>,
}

/// `settings` with the `[[light]]` tables added to its lighting.
///
/// # Errors
/// [`SceneError::InvalidField`] for a kind other than `"directional"` or a bad light.
pub fn with_lights(mut settings: RenderSettings, lights: &[LightSpec]) -> Result<RenderSettings, SceneError> {
    let missing = |what: &str| SceneError::InvalidField { field: format!("light.{what}"), reason: "is required for this kind of light".into() };
    for l in lights {
        match (l.kind.as_str(), l.direction, l.irradiance, l.position_m, l.intensity) {
            ("directional", Some(d), Some(e), None, None) => settings.lighting.add(l.frame, d, e)?,
            ("point", None, None, Some(p), Some(i)) => settings.lighting.add_point(l.frame, p, i)?,
            ("directional", d, e, None, None) => {
                return Err(missing(if d.is_none() {
                    "direction"
                } else if e.is_none() {
                    "irradiance"
                } else {
                    "kind"
                }))
            }
            ("point", None, None, p, _) => return Err(missing(if p.is_none() { "position_m" } else { "intensity" })),
            ("directional" | "point", ..) => {
                return Err(SceneError::InvalidField {
                    field: "light".into(),
                    reason: "a directional light takes direction and irradiance, a point light position_m and intensity".into(),
                })
            }
            (kind, ..) => {
                return Err(SceneError::InvalidField { field: "light.kind".into(), reason: format!("\"directional\" or \"point\" so far, got {kind:?}") })
            }
        }
    }
    settings.lighting.validate()?;
    Ok(settings)
}
