//! What a real camera adds to the ideal projection: the sensor (EMVA 1288), optics (vignetting,
//! defocus, PSF), motion (blur, rolling shutter) and the output format (Bayer raw, RGB, JPEG).
//! All optional; the defaults reproduce the ideal renderer.
//!
//! Order of image formation (`render::finish`): radiance (the target's grey levels, box-filtered
//! over each pixel, integrated over the exposure and the aperture by the shader) -> vignetting ->
//! Gaussian PSF -> colour filter array -> sensor (photons, electrons, noise, ADC) or the
//! `noise_sigma` shortcut -> demosaicing -> encoding.

use super::motion::Motion;
use super::SceneError;
use synthcam_core::camera::optics::Optics;
use synthcam_core::camera::sensor::{BayerPattern, Demosaic, SensorModel};

/// The pixel layout of the output image.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub enum PixelFormat {
    /// One grey channel.
    #[default]
    Grey,
    /// The raw colour-filter-array image (one channel, the pattern's colour per pixel).
    Bayer(BayerPattern),
    /// RGB demosaiced from the raw image of the pattern.
    Rgb(BayerPattern),
}

/// How images are written.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub enum Encoding {
    /// Lossless PNG (8 or 16 bits).
    #[default]
    Png,
    /// JPEG (8 bits) at a quality in 1..=100.
    Jpeg,
}

/// The output image (`[output]` in scene files).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Output {
    /// Pixel layout.
    pub format: PixelFormat,
    /// Demosaicing for [`PixelFormat::Rgb`].
    pub demosaic: Demosaic,
    /// File encoding.
    pub encoding: Encoding,
    /// JPEG quality, 1..=100.
    pub jpeg_quality: u8,
    /// A colour target: the RGB albedo (grey levels per channel) of its dark, light, margin and
    /// background regions; `None`: grey (every channel the target's grey level). Each channel
    /// renders on its own; the colour filter array samples them.
    pub target_rgb: Option<[[f64; 3]; 4]>,
}

impl Default for Output {
    fn default() -> Self {
        Self { format: PixelFormat::Grey, demosaic: Demosaic::Bilinear, encoding: Encoding::Png, jpeg_quality: 95, target_rgb: None }
    }
}

/// Camera effects beyond the ideal projection.
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct Effects {
    /// The EMVA 1288 sensor; `None`: the `noise_sigma` shortcut.
    pub sensor: Option<SensorModel>,
    /// Optics.
    pub optics: Optics,
    /// Motion during the exposure.
    pub motion: Motion,
    /// Output format.
    pub output: Output,
}

impl Effects {
    /// Check every part.
    ///
    /// # Errors
    /// [`SceneError::InvalidField`] naming the field.
    pub fn validate(&self) -> Result<(), SceneError> {
        if let Some(s) = &self.sensor {
            s.validate()?;
        }
        self.optics.validate().map_err(|e| match e {
            synthcam_core::camera::CameraError::InvalidParameter { field, reason } => SceneError::InvalidField { field: field.into(), reason },
            other => SceneError::Camera(other),
        })?;
        self.motion.validate()?;
        if let Some(rgb) = &self.output.target_rgb {
            if rgb.iter().flatten().any(|v| !v.is_finite() || !(0.0..=255.0).contains(v)) {
                return Err(SceneError::InvalidField { field: "output.target_rgb".into(), reason: format!("grey levels must be in [0, 255], got {rgb:?}") });
            }
        }
        if !(1..=100).contains(&self.output.jpeg_quality) {
            return Err(SceneError::InvalidField {
                field: "output.jpeg_quality".into(),
                reason: format!("must be in 1..=100, got {}", self.output.jpeg_quality),
            });
        }
        Ok(())
    }

    /// Whether the shader must integrate several views per pixel or per row (defocus, motion).
    pub fn needs_views(&self) -> bool {
        self.optics.thin_lens.is_some() || self.motion.is_active()
    }
}
