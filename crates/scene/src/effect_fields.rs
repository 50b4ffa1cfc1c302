//! Numeric fields of the render settings and camera effects by their scene-file names
//! (`sensor.exposure_s`, `optics.f_number`, `motion.twist.3`, ...), so that a dataset spec can
//! sample each from a range per image (`[ranges]`, `synthcam_io::dataset`).

use super::{RenderSettings, SceneError};

/// The field names [`set_field`] takes, besides a light's ([`LIGHT_FIELDS`]).
pub const FIELDS: [&str; 25] = [
    "render.ambient",
    "render.specular",
    "render.roughness",
    "render.noise_sigma",
    "render.blur_sigma_px",
    "sensor.exposure_s",
    "sensor.photons_per_s_at_255",
    "sensor.quantum_efficiency",
    "sensor.dark_current_e_per_s",
    "sensor.read_noise_e",
    "sensor.prnu",
    "sensor.dsnu_e",
    "sensor.gain_dn_per_e",
    "optics.f_number",
    "optics.focus_distance_m",
    "optics.psf_sigma_px",
    "optics.vignetting.0",
    "motion.exposure_s",
    "motion.line_delay_s",
    "motion.twist.0",
    "motion.twist.1",
    "motion.twist.2",
    "motion.twist.3",
    "motion.twist.4",
    "motion.twist.5",
];

/// A light's fields: `light.N.*` of the N-th directional `[[light]]` (from 0), its irradiance
/// and the components of its direction (normalised where it is used); `point.N.*` of the N-th
/// point light, its intensity and position.
pub const LIGHT_FIELDS: [&str; 8] = [
    "light.N.irradiance",
    "light.N.direction.0",
    "light.N.direction.1",
    "light.N.direction.2",
    "point.N.intensity",
    "point.N.position_m.0",
    "point.N.position_m.1",
    "point.N.position_m.2",
];

/// The slot of a `light.N.*` or `point.N.*` field.
fn light_slot<'r>(render: &'r mut RenderSettings, field: &str) -> Result<&'r mut f64, SceneError> {
    let (kind, rest) = field.split_once('.').ok_or_else(|| unknown(field))?;
    let (n, what) = rest.split_once('.').ok_or_else(|| unknown(field))?;
    let n: usize = n.parse().map_err(|_| unknown(field))?;
    let absent =
        || SceneError::InvalidField { field: field.into(), reason: format!("a range for it needs {kind} light number {n} (counting from 0) in `[[light]]`") };
    let l = &mut render.lighting;
    match kind {
        "light" => {
            let light = l.lights.get_mut(n).and_then(Option::as_mut).ok_or_else(absent)?;
            match what {
                "irradiance" => Ok(&mut light.irradiance),
                "direction.0" => Ok(&mut light.direction[0]),
                "direction.1" => Ok(&mut light.direction[1]),
                "direction.2" => Ok(&mut light.direction[2]),
                _ => Err(unknown(field)),
            }
        }
        "point" => {
            let lamp = l.points.get_mut(n).and_then(Option::as_mut).ok_or_else(absent)?;
            match what {
                "intensity" => Ok(&mut lamp.intensity),
                "position_m.0" => Ok(&mut lamp.position_m[0]),
                "position_m.1" => Ok(&mut lamp.position_m[1]),
                "position_m.2" => Ok(&mut lamp.position_m[2]),
                _ => Err(unknown(field)),
            }
        }
        _ => Err(unknown(field)),
    }
}

fn missing(field: &str, table: &str) -> SceneError {
    SceneError::InvalidField {
        field: field.into(),
        reason: format!("a range for it needs a `[{table}]` table (with a thin lens for f_number and focus_distance_m)"),
    }
}

/// Set `field` of `render` to `value` (validate the settings afterwards).
///
/// # Errors
/// An unknown field, or a field of a `[sensor]` or thin lens the settings do not have.
pub fn set_field(render: &mut RenderSettings, field: &str, value: f64) -> Result<(), SceneError> {
    if field.starts_with("light.") || field.starts_with("point.") {
        *light_slot(render, field)? = value;
        return Ok(());
    }
    if !FIELDS.contains(&field) {
        return Err(unknown(field));
    }
    if field == "render.ambient" {
        render.lighting.ambient = Some(value);
        return Ok(());
    }
    if let Some(part) = field.strip_prefix("render.").filter(|p| *p == "specular" || *p == "roughness") {
        let gloss = render
            .lighting
            .gloss
            .as_mut()
            .ok_or_else(|| SceneError::InvalidField { field: field.into(), reason: "a range for it needs a glossy target (`[render] specular`)".into() })?;
        *(if part == "specular" { &mut gloss.specular } else { &mut gloss.roughness }) = value;
        return Ok(());
    }
    let linked_exposure = render.effects.sensor.is_some_and(|s| s.exposure_s == render.effects.motion.exposure_s);
    let fx = &mut render.effects;
    let sensor = fx.sensor.as_mut();
    let lens = fx.optics.thin_lens.as_mut();
    let slot: &mut f64 = match field {
        "render.noise_sigma" => &mut render.noise_sigma,
        "render.blur_sigma_px" => &mut render.blur_sigma_px,
        "optics.psf_sigma_px" => &mut fx.optics.psf_sigma_px,
        "optics.vignetting.0" => &mut fx.optics.vignetting[0],
        "motion.exposure_s" => &mut fx.motion.exposure_s,
        "motion.line_delay_s" => &mut fx.motion.line_delay_s,
        f if f.starts_with("motion.twist.") => {
            let i: usize = f["motion.twist.".len()..].parse().ok().filter(|i| *i < 6).ok_or_else(|| unknown(f))?;
            &mut fx.motion.twist[i]
        }
        f if f.starts_with("optics.") => {
            let lens = lens.ok_or_else(|| missing(f, "optics"))?;
            match f {
                "optics.f_number" => &mut lens.f_number,
                "optics.focus_distance_m" => &mut lens.focus_distance_m,
                _ => return Err(unknown(f)),
            }
        }
        f if f.starts_with("sensor.") => {
            let s = sensor.ok_or_else(|| missing(f, "sensor"))?;
            match f {
                "sensor.exposure_s" => &mut s.exposure_s,
                "sensor.photons_per_s_at_255" => &mut s.photons_per_s_at_255,
                "sensor.quantum_efficiency" => &mut s.quantum_efficiency,
                "sensor.dark_current_e_per_s" => &mut s.dark_current_e_per_s,
                "sensor.read_noise_e" => &mut s.read_noise_e,
                "sensor.prnu" => &mut s.prnu,
                "sensor.dsnu_e" => &mut s.dsnu_e,
                "sensor.gain_dn_per_e" => &mut s.gain_dn_per_e,
                _ => return Err(unknown(f)),
            }
        }
        f => return Err(unknown(f)),
    };
    *slot = value;
    // A motion that took the sensor's exposure keeps following it.
    if field == "sensor.exposure_s" && linked_exposure {
        render.effects.motion.exposure_s = value;
    }
    Ok(())
}

fn unknown(field: &str) -> SceneError {
    SceneError::InvalidField {
        field: format!("ranges.{field}"),
        reason: format!("no such numeric field; expected one of {}, {}", FIELDS.join(", "), LIGHT_FIELDS.join(", ")),
    }
}
