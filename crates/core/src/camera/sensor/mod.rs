//! An image sensor between the renderer's radiance (grey levels in [0, 255]) and the detector:
//! photon shot noise, dark current, read noise, fixed-pattern noise (PRNU, DSNU), full-well
//! saturation and ADC quantisation ([`emva`]); colour filter arrays ([`bayer`]) and demosaicing
//! ([`demosaic`](mod@demosaic)). Pure CPU code: no file I/O, no GPU.
//!
//! # The EMVA 1288 linear camera model
//! Per pixel and exposure, `mu_p` photons arrive; the sensor turns a fraction `eta` (quantum
//! efficiency) of them into electrons, adds `mu_d` dark electrons, and the ADC converts electrons
//! to digital numbers (DN) with the system gain `K` (DN per electron):
//!
//! * mean: `mu_y = K (eta mu_p + mu_d)` (+ a black level offset),
//! * temporal variance: `sigma_y^2 = K^2 (sigma_d^2 + mu_e) + sigma_q^2`, where `mu_e = eta mu_p`
//!   is Poisson (shot) noise, `sigma_d` the dark (read) noise in electrons and `sigma_q^2 = 1/12 DN^2`
//!   the quantisation noise.
//!
//! Spatial non-uniformity is modelled as a per-pixel gain `1 + prnu z` on the photo signal (PRNU)
//! and a per-pixel dark offset `dsnu_e z` in electrons (DSNU), `z ~ N(0, 1)`, drawn once from a
//! seed ([`FixedPattern`]) so that it is the same in every image, as on a real sensor.
//! The photon transfer and non-uniformity measurements of the standard are in this module's tests.
//!
//! # References
//! * EMVA Standard 1288, "Standard for Characterization of Image Sensors and Cameras",
//!   Release 4.0 Linear (European Machine Vision Association, 2021): sec. 2 (model),
//!   sec. 6 (photon transfer method), sec. 8 (spatial non-uniformity).
//! * H. S. Malvar, L. He, R. Cutler, "High-quality linear interpolation for demosaicing of
//!   Bayer-patterned color images", ICASSP 2004 ([`Demosaic::MalvarHeCutler`]).
//! * B. E. Bayer, "Color imaging array", US patent 3,971,065 (1976) ([`BayerPattern`]).
//! * ITU-R BT.601 (luma weights of [`rgb_to_grey`]).

pub mod bayer;
pub mod demosaic;
pub mod emva;

pub use bayer::{grey_to_rgb, mosaic, BayerPattern};
pub use demosaic::{demosaic, luma, rgb_to_grey, Demosaic, LUMA_BT601};
pub use emva::{dn_to_grey, expected_dn, expose, FixedPattern, SensorModel};

/// Errors of the sensor model.
#[derive(Debug, thiserror::Error, Clone, PartialEq)]
#[non_exhaustive]
pub enum SensorError {
    /// A parameter is out of range or non-finite.
    #[error("sensor field `{field}` is invalid: {reason}")]
    InvalidField {
        /// Name of the offending field, e.g. `"sensor.exposure_s"` or `"output.demosaic"`.
        field: &'static str,
        /// Human-readable explanation including the offending value.
        reason: String,
    },
    /// An image buffer does not hold `width x height` values.
    #[error("image buffer has {got} values, expected {width}x{height}")]
    Size {
        /// Number of values in the buffer.
        got: usize,
        /// Image width in pixels.
        width: usize,
        /// Image height in pixels.
        height: usize,
    },
}

/// `width * height`, or a [`SensorError::Size`] error when `len` differs (or the product overflows).
pub(crate) fn check_len(len: usize, width: usize, height: usize) -> Result<usize, SensorError> {
    match width.checked_mul(height) {
        Some(n) if n == len => Ok(n),
        _ => Err(SensorError::Size { got: len, width, height }),
    }
}

#[cfg(test)]
mod tests;
