//! `[[light]]` tables in scene and dataset files ([`crate::lighting`]).

use serde::Deserialize;

use crate::{RenderSettings, SceneError};

/// One `[[light]]` table: `kind = "directional"`, `frame` (`"camera"`, default, or `"target"`),
/// `direction = [x, y, z]` (the direction the light travels) and `irradiance` (grey levels per
/// unit albedo on a surface facing it); or `kind = "point"`, `frame`, `position_m` and
/// `intensity` (the irradiance at 1 m on a surface facing it); or `kind = "area"`, `frame`,
/// `position_m` (its centre), `size_m = [w, h]`, `rvec` (default none: facing the frame's +z) and
/// `intensity` (on its axis at 1 m; [`crate::area_light`]).
#[derive(Debug, Clone, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct LightSpec {
    /// `"directional"`, `"point"` or `"area"`.
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
    /// Point and area: irradiance at 1 m, grey levels per unit albedo.
    pub intensity: Option<f64>,
    /// Area: width and height, metres.
    pub size_m: Option<[f64; 2]>,
    /// Area: Rodrigues vector turning the light's frame (rectangle in its x-y plane, emitting
    /// towards +z).
    pub rvec: Option<[f64; 3]>,
}

/// `settings` with the `[[light]]` tables added to its lighting.
///
/// # Errors
/// [`SceneError::InvalidField`] for a kind other than `"directional"` or a bad light.
pub fn with_lights(mut settings: RenderSettings, lights: &[LightSpec]) -> Result<RenderSettings, SceneError> {
    let missing = |what: &str| SceneError::InvalidField { field: format!("light.{what}"), reason: "is required for this kind of light".into() };
    for l in lights {
        if l.kind == "area" {
            if settings.lighting.area.is_some() {
                return Err(SceneError::InvalidField { field: "light".into(), reason: "one area light per scene so far".into() });
            }
            settings.lighting.area = Some(area(l, &missing)?);
            continue;
        }
        if l.size_m.is_some() || l.rvec.is_some() {
            return Err(SceneError::InvalidField { field: "light.size_m".into(), reason: "size_m and rvec belong to area lights".into() });
        }
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
                return Err(SceneError::InvalidField { field: "light.kind".into(), reason: format!("\"directional\", \"point\" or \"area\", got {kind:?}") })
            }
        }
    }
    settings.lighting.validate()?;
    Ok(settings)
}

/// A `kind = "area"` table's light (one per scene).
fn area(l: &LightSpec, missing: &dyn Fn(&str) -> SceneError) -> Result<crate::area_light::AreaLight, SceneError> {
    if l.direction.is_some() || l.irradiance.is_some() {
        return Err(SceneError::InvalidField {
            field: "light".into(),
            reason: "an area light takes position_m, size_m, rvec and intensity (no direction or irradiance)".into(),
        });
    }
    let light = crate::area_light::AreaLight {
        frame: l.frame,
        position_m: l.position_m.ok_or_else(|| missing("position_m"))?,
        rvec: l.rvec.unwrap_or_default(),
        size_m: l.size_m.ok_or_else(|| missing("size_m"))?,
        intensity: l.intensity.ok_or_else(|| missing("intensity"))?,
    };
    light.validate()?;
    Ok(light)
}

#[cfg(test)]
mod tests {
    use super::*;

    fn spec(toml_text: &str) -> Result<RenderSettings, SceneError> {
        #[derive(Deserialize)]
        struct Lights {
            light: Vec<LightSpec>,
        }
        let lights: Lights = toml::from_str(toml_text).expect("toml");
        with_lights(RenderSettings::default(), &lights.light)
    }

    /// An area light table reads into `Lighting::area`; a second one, a missing size, a
    /// direction on an area light, a size on a point light and gloss beside it are named errors.
    #[test]
    fn area_light_tables_read_and_refuse_by_name() {
        let area = "[[light]]\nkind = \"area\"\nposition_m = [0.1, 0.0, 0.0]\nsize_m = [0.2, 0.1]\nintensity = 0.5\n";
        let s = spec(area).expect("area light");
        let a = s.lighting.area.expect("area");
        assert_eq!((a.size_m, a.rvec, a.intensity), ([0.2, 0.1], [0.0; 3], 0.5));
        let cases = [
            (format!("{area}{area}"), "one area light"),
            ("[[light]]\nkind = \"area\"\nposition_m = [0.0, 0.0, 0.0]\nintensity = 0.5\n".to_string(), "light.size_m"),
            (format!("{area}direction = [0.0, 0.0, 1.0]\n"), "no direction"),
            ("[[light]]\nkind = \"point\"\nposition_m = [0.0, 0.0, 0.0]\nintensity = 0.5\nsize_m = [1.0, 1.0]\n".to_string(), "belong to area lights"),
            ("[[light]]\nkind = \"area\"\nposition_m = [0.0, 0.0, 0.0]\nsize_m = [0.0, 1.0]\nintensity = 0.5\n".to_string(), "size_m"),
        ];
        for (text, what) in cases {
            let err = spec(&text).expect_err(what).to_string();
            assert!(err.contains(what), "{what}: {err}");
        }
        let mut glossy = s;
        glossy.lighting.gloss = Some(crate::lighting::Gloss { specular: 0.04, roughness: 0.3 });
        assert!(glossy.lighting.validate().expect_err("gloss").to_string().contains("no gloss"));
    }
}
