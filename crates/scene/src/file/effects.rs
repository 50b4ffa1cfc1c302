//! The scene file's camera-effect tables: `[sensor]`, `[optics]`, `[motion]`, `[output]` (all
//! optional; [`crate::effects`]).
//!
//! ```toml
//! [sensor]            # EMVA 1288 (synthcam_core::camera::sensor::SensorModel; every field optional)
//! exposure_s = 0.01
//! photons_per_s_at_255 = 1e6
//! quantum_efficiency = 0.6
//! full_well_e = 10000
//! dark_current_e_per_s = 5
//! read_noise_e = 3
//! prnu = 0.01
//! dsnu_e = 1
//! gain_dn_per_e = 0.025
//! bit_depth = 8              # ADC: 8, 10, 12, 16
//! seed = 0                   # fixed patterns (PRNU, DSNU)
//!
//! [optics]
//! vignetting = [-0.1, 0.0, 0.0]   # 1 + a1 r^2 + a2 r^4 + a3 r^6, r over the half-diagonal
//! natural_falloff = true          # cos^4 (default true)
//! f_number = 2.8                  # with focal_length_m and focus_distance_m: defocus
//! focal_length_m = 0.016
//! focus_distance_m = 0.8
//! aperture_samples = 16
//! psf_sigma_px = 0.5
//!
//! [motion]                         # crate::motion::Motion
//! twist = [0, 0, 0.5, 0.1, 0, 0]   # camera, its own frame: rad/s, m/s
//! target_twist = [0, 0, 0, 0, 0, 0]
//! line_delay_s = 30e-6             # rolling shutter
//! readout = "top-down"             # or "bottom-up"
//! exposure_s = 0.004               # default: [sensor] exposure_s
//!
//! [output]
//! format = "grey"                  # "bayer-rggb" | "bayer-bggr" | "bayer-grbg" | "bayer-gbrg" | "rgb" | "rgb-<pattern>"
//! demosaic = "bilinear"            # or "malvar"
//! encoding = "png"                 # or "jpeg"
//! jpeg_quality = 95
//! bit_depth = 8                    # PNG sample depth: 8 or 16 (as [render] bit_depth)
//! target_rgb = [[20, 20, 90], [235, 200, 60], [235, 200, 60], [110, 110, 110]]  # colour target: dark, light, margin, background
//! ```

use serde::Deserialize;

use crate::effects::{Effects, Encoding, Output, PixelFormat};
use crate::motion::Motion;
use crate::SceneError;
use synthcam_core::camera::optics::{Optics, ThinLens};
use synthcam_core::camera::sensor::{BayerPattern, Demosaic, SensorModel};

/// `[optics]`.
#[derive(Debug, Clone, Deserialize, Default, PartialEq)]
#[serde(deny_unknown_fields)]
pub struct OpticsSpec {
    /// Radial vignetting polynomial, up to three coefficients.
    #[serde(default)]
    pub vignetting: Vec<f64>,
    /// cos^4 fall-off (default true).
    pub natural_falloff: Option<bool>,
    /// f-number (defocus when given).
    pub f_number: Option<f64>,
    /// Focal length of the lens, metres.
    pub focal_length_m: Option<f64>,
    /// Focus distance, metres.
    pub focus_distance_m: Option<f64>,
    /// Aperture samples (default 16).
    pub aperture_samples: Option<u32>,
    /// Gaussian PSF sigma, pixels.
    pub psf_sigma_px: Option<f64>,
}

fn invalid(field: &str, reason: impl Into<String>) -> SceneError {
    SceneError::InvalidField { field: field.into(), reason: reason.into() }
}

impl OpticsSpec {
    /// The optics.
    ///
    /// # Errors
    /// More than three vignetting coefficients, or a thin lens with a field missing.
    pub fn to_optics(&self) -> Result<Optics, SceneError> {
        if self.vignetting.len() > 3 {
            return Err(invalid("optics.vignetting", format!("at most 3 coefficients (r^2, r^4, r^6), got {}", self.vignetting.len())));
        }
        let mut vignetting = [0.0; 3];
        vignetting[..self.vignetting.len()].copy_from_slice(&self.vignetting);
        let thin_lens = match (self.f_number, self.focal_length_m, self.focus_distance_m) {
            (None, None, None) => None,
            (Some(f_number), Some(focal_length_m), Some(focus_distance_m)) => {
                Some(ThinLens { f_number, focal_length_m, focus_distance_m, aperture_samples: self.aperture_samples.unwrap_or(16) })
            }
            _ => return Err(invalid("optics.f_number", "a thin lens needs f_number, focal_length_m and focus_distance_m together")),
        };
        Ok(Optics { natural_falloff: self.natural_falloff.unwrap_or(true), vignetting, thin_lens, psf_sigma_px: self.psf_sigma_px.unwrap_or(0.0) })
    }
}

/// `[output]`.
#[derive(Debug, Clone, Deserialize, Default, PartialEq)]
#[serde(deny_unknown_fields)]
pub struct OutputSpec {
    /// `grey`, `bayer-<pattern>`, `rgb` (RGGB) or `rgb-<pattern>`.
    pub format: Option<String>,
    /// `bilinear` or `malvar`.
    pub demosaic: Option<String>,
    /// `png` or `jpeg`.
    pub encoding: Option<String>,
    /// JPEG quality 1..=100 (default 95).
    pub jpeg_quality: Option<u8>,
    /// PNG sample depth, 8 or 16.
    pub bit_depth: Option<u8>,
    /// Colour target: RGB of the dark, light, margin and background regions.
    pub target_rgb: Option<[[f64; 3]; 4]>,
}

impl OutputSpec {
    /// The output settings.
    ///
    /// # Errors
    /// An unknown format, pattern, demosaicer or encoding, named.
    pub fn to_output(&self) -> Result<Output, SceneError> {
        let d = Output::default();
        let format = match self.format.as_deref().map(str::to_ascii_lowercase).as_deref() {
            None | Some("grey" | "gray" | "mono") => PixelFormat::Grey,
            Some("rgb") => PixelFormat::Rgb(BayerPattern::Rggb),
            Some(s) if s.starts_with("rgb-") => PixelFormat::Rgb(s[4..].parse()?),
            Some(s) if s.starts_with("bayer") => PixelFormat::Bayer(s.parse()?),
            Some(s) => {
                return Err(invalid(
                    "output.format",
                    format!("unknown format `{s}`: expected grey, bayer-rggb, bayer-bggr, bayer-grbg, bayer-gbrg, rgb or rgb-<pattern>"),
                ))
            }
        };
        let demosaic = match &self.demosaic {
            None => d.demosaic,
            Some(s) => s.parse::<Demosaic>()?,
        };
        let encoding = match self.encoding.as_deref() {
            None | Some("png") => Encoding::Png,
            Some("jpeg" | "jpg") => Encoding::Jpeg,
            Some(s) => return Err(invalid("output.encoding", format!("unknown encoding `{s}`: expected png or jpeg"))),
        };
        Ok(Output { format, demosaic, encoding, jpeg_quality: self.jpeg_quality.unwrap_or(d.jpeg_quality), target_rgb: self.target_rgb })
    }
}

/// The four effect tables of a scene file (or a dataset spec).
#[derive(Debug, Clone, Deserialize, Default, PartialEq)]
pub struct EffectTables {
    /// `[sensor]`.
    #[serde(default)]
    pub sensor: Option<SensorModel>,
    /// `[optics]`.
    #[serde(default)]
    pub optics: Option<OpticsSpec>,
    /// `[motion]`.
    #[serde(default)]
    pub motion: Option<Motion>,
    /// `[output]`.
    #[serde(default)]
    pub output: Option<OutputSpec>,
}

impl EffectTables {
    /// The effects (defaults where a table is absent); a motion without its own exposure takes
    /// the sensor's.
    ///
    /// # Errors
    /// Any invalid field, named.
    pub fn to_effects(&self) -> Result<Effects, SceneError> {
        let mut motion = self.motion.unwrap_or_default();
        if let (Some(s), true) = (&self.sensor, motion.exposure_s == 0.0) {
            motion.exposure_s = s.exposure_s;
        }
        let effects = Effects {
            sensor: self.sensor,
            optics: self.optics.as_ref().map(OpticsSpec::to_optics).transpose()?.unwrap_or_default(),
            motion,
            output: self.output.as_ref().map(OutputSpec::to_output).transpose()?.unwrap_or_default(),
        };
        effects.validate()?;
        Ok(effects)
    }

    /// The `[output]` bit depth, when given.
    pub fn bit_depth(&self) -> Option<u8> {
        self.output.as_ref().and_then(|o| o.bit_depth)
    }
}

/// The `[render]` settings with the four effect tables applied (a scene file, a dataset spec and
/// a scenario carry the same tables): effects validated, `[output] bit_depth` over `[render]`'s.
///
/// # Errors
/// Any invalid field, named.
pub fn render_settings(
    render: &crate::file::RenderSpec,
    sensor: Option<SensorModel>,
    optics: Option<&OpticsSpec>,
    motion: Option<Motion>,
    output: Option<&OutputSpec>,
) -> Result<crate::RenderSettings, SceneError> {
    if render.roughness.is_some() && render.specular.is_none() {
        return Err(SceneError::InvalidField {
            field: "render.roughness".into(),
            reason: "a glossy coating needs `specular` (its reflectance at normal incidence)".into(),
        });
    }
    let tables = EffectTables { sensor, optics: optics.cloned(), motion, output: output.cloned() };
    let mut settings = render.to_settings();
    settings.effects = tables.to_effects()?;
    settings.bit_depth = tables.bit_depth().unwrap_or(settings.bit_depth);
    Ok(settings)
}

/// `[render]` table.
#[derive(Debug, Clone, Deserialize, Default)]
#[serde(deny_unknown_fields)]
pub struct RenderSpec {
    /// Sub-samples per axis (default 16).
    pub samples: Option<u32>,
    /// Gaussian noise sigma, grey levels.
    pub noise_sigma: Option<f64>,
    /// Gaussian blur sigma, pixels.
    pub blur_sigma_px: Option<f64>,
    /// Noise seed.
    pub seed: Option<u64>,
    /// 8 or 16.
    pub bit_depth: Option<u8>,
    /// The ambient term of the lighting ([`crate::lighting`]; default 1 without `[[light]]`, 0
    /// with).
    pub ambient: Option<f64>,
    /// The target's glossy coating: reflectance at normal incidence ([`crate::lighting::Gloss`];
    /// with `roughness`, default 0.3).
    pub specular: Option<f64>,
    /// The coating's roughness in (0, 1] (needs `specular`).
    pub roughness: Option<f64>,
}

impl RenderSpec {
    /// Settings with defaults filled in.
    pub fn to_settings(&self) -> crate::RenderSettings {
        let d = crate::RenderSettings::default();
        crate::RenderSettings {
            samples: self.samples.unwrap_or(d.samples),
            noise_sigma: self.noise_sigma.unwrap_or(d.noise_sigma),
            blur_sigma_px: self.blur_sigma_px.unwrap_or(d.blur_sigma_px),
            seed: self.seed.unwrap_or(d.seed),
            bit_depth: self.bit_depth.unwrap_or(d.bit_depth),
            effects: d.effects,
            lighting: crate::lighting::Lighting {
                ambient: self.ambient,
                gloss: self.specular.map(|specular| crate::lighting::Gloss { specular, roughness: self.roughness.unwrap_or(0.3) }),
                ..d.lighting
            },
        }
    }
}
