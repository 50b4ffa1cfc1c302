//! The EMVA 1288 linear sensor model: photons to electrons to digital numbers (DN), with shot
//! noise, dark current, read noise, PRNU / DSNU fixed patterns, full-well saturation and ADC
//! quantisation.
//!
//! Reference: EMVA Standard 1288 Release 4.0 Linear, sec. 2 (the model: `mu_y = K (eta mu_p +
//! mu_d)`, `sigma_y^2 = K^2 (sigma_d^2 + mu_e) + sigma_q^2`) and sec. 8 (non-uniformity).

use super::{check_len, SensorError};
use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;
use rand_distr::{Distribution, Poisson, StandardNormal};
use rayon::prelude::*;

/// Above this mean (electrons) shot noise is drawn from the normal approximation `N(m, m)`.
const POISSON_NORMAL_LIMIT: f64 = 1.0e4;

/// Parameters of a linear camera (EMVA 1288). Intensities entering the sensor are grey levels
/// in [0, 255]; [`SensorModel::photons_per_s_at_255`] fixes the photometric scale.
#[derive(Debug, Clone, Copy, PartialEq, serde::Serialize, serde::Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct SensorModel {
    /// Exposure time in seconds (>= 0). Default 0.01.
    pub exposure_s: f64,
    /// Photon flux per pixel (photons / s) that grey level 255 gives at the sensor centre
    /// (>= 0). Default 1.0e6.
    pub photons_per_s_at_255: f64,
    /// Quantum efficiency `eta`, electrons per photon, in (0, 1]. Default 0.6.
    pub quantum_efficiency: f64,
    /// Full-well capacity in electrons (> 0 and > `read_noise_e`). Default 10000.
    pub full_well_e: f64,
    /// Mean dark current, electrons per second (>= 0). Default 5.
    pub dark_current_e_per_s: f64,
    /// Temporal dark noise `sigma_d`, electrons (>= 0). Default 3.
    pub read_noise_e: f64,
    /// Photo response non-uniformity: relative standard deviation of the per-pixel gain, in
    /// [0, 1). Default 0.01.
    pub prnu: f64,
    /// Dark signal non-uniformity: standard deviation of the per-pixel dark offset, electrons
    /// (>= 0). Default 1.
    pub dsnu_e: f64,
    /// System gain `K`, DN per electron (> 0). Default 0.025 (8 bits: 255 DN ~ 10200 e).
    pub gain_dn_per_e: f64,
    /// ADC resolution in bits: 8, 10, 12 or 16. Default 8.
    pub bit_depth: u8,
    /// Offset added before quantisation, DN (>= 0). Default 0.
    pub black_level_dn: f64,
    /// Seed of the fixed patterns (PRNU, DSNU), stable across images. Default 0.
    pub seed: u64,
}

impl Default for SensorModel {
    fn default() -> Self {
        Self {
            exposure_s: 0.01,
            photons_per_s_at_255: 1.0e6,
            quantum_efficiency: 0.6,
            full_well_e: 10_000.0,
            dark_current_e_per_s: 5.0,
            read_noise_e: 3.0,
            prnu: 0.01,
            dsnu_e: 1.0,
            gain_dn_per_e: 0.025,
            bit_depth: 8,
            black_level_dn: 0.0,
            seed: 0,
        }
    }
}

fn invalid(field: &'static str, reason: String) -> SensorError {
    SensorError::InvalidField { field, reason }
}

/// `Err` naming `field` unless `ok`; `expect` says what the value must be.
fn require(field: &'static str, v: f64, ok: bool, expect: &str) -> Result<(), SensorError> {
    if ok {
        Ok(())
    } else {
        Err(invalid(field, format!("{expect}, got {v}")))
    }
}

impl SensorModel {
    /// Checks every field: all floats finite, `exposure_s, photons_per_s_at_255,
    /// dark_current_e_per_s, read_noise_e, dsnu_e, black_level_dn >= 0`, `quantum_efficiency` in
    /// (0, 1], `0 < read_noise_e < full_well_e`, `prnu` in [0, 1), `gain_dn_per_e > 0`, and
    /// `bit_depth` in {8, 10, 12, 16}. The error names the field (`sensor.<name>`).
    pub fn validate(&self) -> Result<(), SensorError> {
        let floats: [(&'static str, f64); 10] = [
            ("sensor.exposure_s", self.exposure_s),
            ("sensor.photons_per_s_at_255", self.photons_per_s_at_255),
            ("sensor.quantum_efficiency", self.quantum_efficiency),
            ("sensor.full_well_e", self.full_well_e),
            ("sensor.dark_current_e_per_s", self.dark_current_e_per_s),
            ("sensor.read_noise_e", self.read_noise_e),
            ("sensor.prnu", self.prnu),
            ("sensor.dsnu_e", self.dsnu_e),
            ("sensor.gain_dn_per_e", self.gain_dn_per_e),
            ("sensor.black_level_dn", self.black_level_dn),
        ];
        for (field, v) in floats {
            require(field, v, v.is_finite(), "must be finite")?;
        }
        for (field, v) in [
            ("sensor.exposure_s", self.exposure_s),
            ("sensor.photons_per_s_at_255", self.photons_per_s_at_255),
            ("sensor.dark_current_e_per_s", self.dark_current_e_per_s),
            ("sensor.read_noise_e", self.read_noise_e),
            ("sensor.dsnu_e", self.dsnu_e),
            ("sensor.black_level_dn", self.black_level_dn),
        ] {
            require(field, v, v >= 0.0, "must be >= 0")?;
        }
        let eta = self.quantum_efficiency;
        require("sensor.quantum_efficiency", eta, eta > 0.0 && eta <= 1.0, "must be in (0, 1]")?;
        let fw = self.full_well_e;
        require("sensor.full_well_e", fw, fw > 0.0, "must be > 0")?;
        if !(fw > self.read_noise_e) {
            return Err(invalid("sensor.full_well_e", format!("must exceed the read noise ({} e), got {fw}", self.read_noise_e)));
        }
        require("sensor.prnu", self.prnu, (0.0..1.0).contains(&self.prnu), "must be in [0, 1)")?;
        require("sensor.gain_dn_per_e", self.gain_dn_per_e, self.gain_dn_per_e > 0.0, "must be > 0")?;
        if ![8, 10, 12, 16].contains(&self.bit_depth) {
            return Err(invalid("sensor.bit_depth", format!("must be 8, 10, 12 or 16, got {}", self.bit_depth)));
        }
        Ok(())
    }

    /// The largest digital number, `2^bit_depth - 1` (saturating at `u32::MAX` for bit depths
    /// of 32 and more, which [`SensorModel::validate`] rejects).
    pub fn max_dn(&self) -> u32 {
        let bits = u32::from(self.bit_depth.min(32));
        u32::try_from((1u64 << bits) - 1).unwrap_or(u32::MAX)
    }

    /// Mean photons per pixel for a grey level (negative grey counts as 0):
    /// `grey / 255 * photons_per_s_at_255 * exposure_s`.
    pub fn mean_photons(&self, grey: f64) -> f64 {
        grey.max(0.0) / 255.0 * self.photons_per_s_at_255 * self.exposure_s
    }

    /// Mean photo-electrons `eta mu_p` for a grey level (no dark current, no PRNU).
    pub fn mean_electrons(&self, grey: f64) -> f64 {
        self.quantum_efficiency * self.mean_photons(grey)
    }
}

/// The mean DN of a pixel without noise, fixed patterns or saturation (EMVA 1288 eq. of the
/// mean): `K (eta mu_p + mu_d) + black_level_dn`, with `mu_d = dark_current_e_per_s *
/// exposure_s`. Constant time.
pub fn expected_dn(model: &SensorModel, grey: f64) -> f64 {
    let dark_e = model.dark_current_e_per_s * model.exposure_s;
    model.gain_dn_per_e * (model.mean_electrons(grey) + dark_e) + model.black_level_dn
}

/// DN scaled back to grey levels in [0, 255] (`dn * 255 / max_dn`): the detector's input.
/// Meaningful for a model that passes [`SensorModel::validate`].
pub fn dn_to_grey(model: &SensorModel, dn: &[u16]) -> Vec<f32> {
    let scale = (255.0 / f64::from(model.max_dn().max(1))) as f32;
    dn.iter().map(|&v| f32::from(v) * scale).collect()
}

/// SplitMix64 finaliser (Steele, Lea, Flood 2014): mixes seeds into well-spread RNG seeds.
fn splitmix64(x: u64) -> u64 {
    let mut z = x.wrapping_add(0x9E37_79B9_7F4A_7C15);
    z = (z ^ (z >> 30)).wrapping_mul(0xBF58_476D_1CE4_E5B9);
    z = (z ^ (z >> 27)).wrapping_mul(0x94D0_49BB_1331_11EB);
    z ^ (z >> 31)
}

/// The per-pixel fixed patterns of a sensor (EMVA 1288 sec. 8): PRNU gain factors and DSNU
/// dark offsets. They depend only on the model's `seed`, `prnu`, `dsnu_e` and the image size,
/// so they are stable across images: the same seed and size give the same pattern.
#[derive(Debug, Clone, PartialEq)]
pub struct FixedPattern {
    /// Per-pixel gain factor on the photo signal, `1 + prnu z` (floored at 0), row-major.
    pub gain: Vec<f32>,
    /// Per-pixel dark signal non-uniformity, `dsnu_e z` electrons (may be negative), row-major;
    /// added to the dark electrons.
    pub offset_e: Vec<f32>,
}

impl FixedPattern {
    /// Draws the pattern of a `width x height` sensor from a ChaCha8 generator seeded with a
    /// hash of (`model.seed`, `width`, `height`), row `y` from its own stream `y` (rows in
    /// parallel, the same values on any thread count); per pixel, first the gain's `z`, then the
    /// offset's. Errors: an invalid model, or a size whose pixel count overflows.
    pub fn new(model: &SensorModel, width: usize, height: usize) -> Result<Self, SensorError> {
        model.validate()?;
        let n = width.checked_mul(height).filter(|&n| n <= isize::MAX as usize / 8).ok_or(SensorError::Size { got: 0, width, height })?;
        let size_hash = splitmix64(((width as u64) << 32) ^ (height as u64) ^ ((width as u64) >> 32));
        let seed = splitmix64(model.seed ^ size_hash);
        let (mut gain, mut offset_e) = (vec![0f32; n], vec![0f32; n]);
        if width == 0 {
            return Ok(Self { gain, offset_e });
        }
        gain.par_chunks_mut(width).zip(offset_e.par_chunks_mut(width)).enumerate().for_each(|(y, (g, o))| {
            let mut rng = ChaCha8Rng::seed_from_u64(seed);
            rng.set_stream(y as u64);
            for (g, o) in g.iter_mut().zip(o.iter_mut()) {
                let zg: f64 = rng.sample(StandardNormal);
                let zo: f64 = rng.sample(StandardNormal);
                *g = (1.0 + model.prnu * zg).max(0.0) as f32;
                *o = (model.dsnu_e * zo) as f32;
            }
        });
        Ok(Self { gain, offset_e })
    }
}

/// Per-image constants of [`expose`].
struct Exposure {
    photons_per_grey: f64,
    eta: f64,
    dark_e: f64,
    full_well_e: f64,
    read_noise_e: f64,
    gain: f64,
    black: f64,
    max_dn: f64,
}

/// Shot noise: a Poisson draw of mean `m` (0 for `m <= 0`; `N(m, m)` above
/// [`POISSON_NORMAL_LIMIT`]; `m` itself when infinite, which saturates).
fn shot(m: f64, rng: &mut ChaCha8Rng) -> f64 {
    if !(m > 0.0) {
        return 0.0;
    }
    if !m.is_finite() {
        return m;
    }
    if m <= POISSON_NORMAL_LIMIT {
        if let Ok(p) = Poisson::new(m) {
            return p.sample(rng);
        }
    }
    let z: f64 = rng.sample(StandardNormal);
    (m + m.sqrt() * z).max(0.0)
}

impl Exposure {
    fn row(&self, pattern: (&[f32], &[f32]), grey: &[f32], out: &mut [u16], rng: &mut ChaCha8Rng) {
        for (((o, &g), &pg), &off) in out.iter_mut().zip(grey).zip(pattern.0).zip(pattern.1) {
            let signal = self.eta * f64::from(g.max(0.0)) * self.photons_per_grey * f64::from(pg);
            let electrons = (shot(signal + self.dark_e, rng) + f64::from(off)).min(self.full_well_e);
            let z: f64 = rng.sample(StandardNormal);
            let dn = (self.gain * (electrons + self.read_noise_e * z) + self.black).round();
            *o = dn.clamp(0.0, self.max_dn) as u16;
        }
    }
}

/// Exposes the sensor to a row-major `width x height` image of grey levels (radiance in the
/// renderer's units, [0, 255] nominal, negative values count as 0) and returns the ADC output in
/// DN, per pixel:
///
/// 1. photons `mu_p = grey / 255 * photons_per_s_at_255 * exposure_s`;
/// 2. electrons `= Poisson(eta mu_p gain_i + dark_current * exposure) + offset_e_i` (PRNU, shot
///    noise with dark current, DSNU; normal approximation `N(m, m)` above 1e4 electrons);
/// 3. clipped at `full_well_e` (saturation), then read noise `N(0, read_noise_e)` added;
/// 4. `DN = round(K electrons + black_level_dn)` clamped to `[0, max_dn]` (ADC quantisation,
///    adding `1/12 DN^2` of variance).
///
/// Deterministic: row `y` draws from its own ChaCha8 stream (`y`) of a generator seeded from
/// `frame_seed`, so the result does not depend on the thread count. Rows run in parallel.
/// Errors: an invalid model, a buffer or pattern of the wrong size, a non-finite grey level.
pub fn expose(
    model: &SensorModel,
    pattern: &FixedPattern,
    radiance_grey: &[f32],
    width: usize,
    height: usize,
    frame_seed: u64,
) -> Result<Vec<u16>, SensorError> {
    model.validate()?;
    let n = check_len(radiance_grey.len(), width, height)?;
    check_len(pattern.gain.len(), width, height)?;
    check_len(pattern.offset_e.len(), width, height)?;
    if let Some(i) = radiance_grey.iter().position(|g| !g.is_finite()) {
        return Err(SensorError::InvalidField { field: "radiance_grey", reason: format!("must be finite, got {} at pixel {i}", radiance_grey[i]) });
    }
    if n == 0 {
        return Ok(Vec::new());
    }
    let ex = Exposure {
        photons_per_grey: model.mean_photons(1.0),
        eta: model.quantum_efficiency,
        dark_e: model.dark_current_e_per_s * model.exposure_s,
        full_well_e: model.full_well_e,
        read_noise_e: model.read_noise_e,
        gain: model.gain_dn_per_e,
        black: model.black_level_dn,
        max_dn: f64::from(model.max_dn()),
    };
    let base_seed = splitmix64(frame_seed ^ 0x5EB5_0F7A_11E5_C0DE);
    let mut out = vec![0u16; n];
    out.par_chunks_mut(width).enumerate().for_each(|(y, row)| {
        let mut rng = ChaCha8Rng::seed_from_u64(base_seed);
        rng.set_stream(y as u64);
        let span = y * width..(y + 1) * width;
        let pat = (&pattern.gain[span.clone()], &pattern.offset_e[span.clone()]);
        ex.row(pat, &radiance_grey[span], row, &mut rng);
    });
    Ok(out)
}
