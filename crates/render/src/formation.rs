//! Image formation after the shader, on the CPU ([`synthcam_scene::effects`] gives the order):
//! vignetting, the Gaussian PSF, the colour filter array, the sensor (EMVA 1288) or the
//! `noise_sigma` shortcut, demosaicing, quantisation. Deterministic for a scene and seed.

use std::sync::{Arc, Mutex};

use nalgebra::Point2;
use rayon::prelude::*;

use super::{post, GreyImage, RenderError};
use synthcam_core::camera::sensor::{self, FixedPattern, SensorModel};
use synthcam_scene::effects::PixelFormat;
use synthcam_scene::Scene;

/// The optics' relative irradiance per pixel (cos^4 of the pixel's ray angle times the radial
/// polynomial; pixels without a ray, beyond a fisheye's reach, 0), once per camera and optics:
/// it unprojects every pixel.
fn irradiance_map(scene: &Scene) -> Result<Arc<Vec<f32>>, RenderError> {
    static CACHE: LastOne<(synthcam_core::camera::CameraModel, bool, [u64; 3]), Vec<f32>> = Mutex::new(None);
    let optics = scene.render.effects.optics;
    let cam = scene.camera;
    let key = (cam, optics.natural_falloff, optics.vignetting.map(f64::to_bits));
    cached(&CACHE, key, || {
        let (w, h) = (cam.size.width as usize, cam.size.height as usize);
        let (cx, cy) = (cam.intrinsics.cx, cam.intrinsics.cy);
        let half_diag = 0.5 * (w as f64).hypot(h as f64);
        Ok((0..w * h)
            .into_par_iter()
            .map(|i| {
                let q = Point2::new((i % w) as f64, (i / w) as f64);
                let cos = cam.unproject_ray(&q).map_or(0.0, |d| d.z / d.norm());
                optics.relative_irradiance(cos, (q.x - cx).hypot(q.y - cy) / half_diag) as f32
            })
            .collect())
    })
}

/// The last value computed for a key, kept for the next frame with the same key (a dataset's
/// frames share their camera and sensor).
type LastOne<K, V> = Mutex<Option<(K, Arc<V>)>>;

/// The value of `cache` for `key`, or `make()` stored under it.
fn cached<K: PartialEq, V>(cache: &LastOne<K, V>, key: K, make: impl FnOnce() -> Result<V, RenderError>) -> Result<Arc<V>, RenderError> {
    if let Ok(c) = cache.lock() {
        if let Some((_, v)) = c.as_ref().filter(|(k, _)| *k == key) {
            return Ok(v.clone());
        }
    }
    let v = Arc::new(make()?);
    if let Ok(mut c) = cache.lock() {
        *c = Some((key, v.clone()));
    }
    Ok(v)
}

/// The sensor's fixed pattern, drawn once per (seed, PRNU, DSNU, size): 2.6 million normals.
fn fixed_pattern(model: &SensorModel, w: usize, h: usize) -> Result<Arc<FixedPattern>, RenderError> {
    static CACHE: LastOne<(u64, u64, u64, usize, usize), FixedPattern> = Mutex::new(None);
    let key = (model.seed, model.prnu.to_bits(), model.dsnu_e.to_bits(), w, h);
    cached(&CACHE, key, || FixedPattern::new(model, w, h).map_err(|e| RenderError::Scene(e.into())))
}

/// Pack sensor DN into the output depth: 16 bits left-justified (`DN << (16 - bits)`, exact), 8
/// bits rounded (`DN 255 / (2^bits - 1)`).
fn pack_dn(model: &SensorModel, dn: &[u16], bit_depth: u8) -> Vec<u16> {
    if bit_depth == 16 {
        let shift = 16 - u32::from(model.bit_depth.min(16));
        dn.iter().map(|v| v << shift).collect()
    } else {
        let max = f64::from(model.max_dn());
        dn.iter().map(|v| (f64::from(*v) * 255.0 / max).round() as u16).collect()
    }
}

/// The raw values the sensor or the shortcut deliver before demosaicing, and the factor to the
/// output's scale (0..=255 for 8 bits, 0..=65535 for 16): the sensor's are already there.
fn raw_values(scene: &Scene, radiance: Vec<f32>) -> Result<(Vec<f32>, f64), RenderError> {
    let (w, h) = (scene.camera.size.width as usize, scene.camera.size.height as usize);
    let rs = &scene.render;
    match &rs.effects.sensor {
        Some(model) => {
            let pattern = fixed_pattern(model, w, h)?;
            let dn = sensor::expose(model, &pattern, &radiance, w, h, rs.seed).map_err(|e| RenderError::Scene(e.into()))?;
            Ok((pack_dn(model, &dn, rs.bit_depth).into_iter().map(f32::from).collect(), 1.0))
        }
        None => {
            let mut img = radiance;
            post::add_noise(&mut img, rs.noise_sigma, rs.seed);
            Ok((img, if rs.bit_depth == 16 { 257.0 } else { 1.0 }))
        }
    }
}

/// Blur, vignette, expose and quantise a linear render according to the scene's settings.
///
/// # Errors
/// [`RenderError::Scene`] when the sensor rejects the image (a buffer of the wrong size).
pub fn finish(scene: &Scene, linear: &[f32]) -> Result<GreyImage, RenderError> {
    finish_owned(scene, linear.to_vec())
}

/// [`finish`] on a render the caller gives up (no copy of it).
pub(crate) fn finish_owned(scene: &Scene, mut img: Vec<f32>) -> Result<GreyImage, RenderError> {
    let (w, h) = (scene.camera.size.width, scene.camera.size.height);
    let fx = &scene.render.effects;
    let t0 = std::time::Instant::now();
    if fx.optics.vignettes() {
        let map = irradiance_map(scene)?;
        img.par_iter_mut().zip(map.par_iter()).for_each(|(v, f)| *v = (f64::from(*v) * f64::from(*f)) as f32);
    }
    let t1 = std::time::Instant::now();
    let sigma = scene.render.blur_sigma_px.hypot(fx.optics.psf_sigma_px);
    if sigma > 0.0 {
        img = post::gaussian_blur(&img, w as usize, h as usize, sigma);
    }
    // The colour filter array's raw image: a grey target's radiance itself (every channel has
    // the same albedo), a colour target's channels already sampled (`Renderer::render_radiance`).
    let t2 = std::time::Instant::now();
    let (raw, scale) = raw_values(scene, img)?;
    let ms = |a: std::time::Instant, b: std::time::Instant| (b - a).as_secs_f64() * 1e3;
    log::debug!("formation: vignetting {:.1} ms, blur {:.1} ms, sensor or noise {:.1} ms", ms(t0, t1), ms(t1, t2), ms(t2, std::time::Instant::now()));
    let sixteen = scene.render.bit_depth == 16;
    let size_err = || RenderError::Device("image buffer size".into());
    Ok(match fx.output.format {
        PixelFormat::Grey | PixelFormat::Bayer(_) if sixteen => {
            GreyImage::U16(image::ImageBuffer::from_raw(w, h, quantise(&raw, scale, 65535.0)).ok_or_else(size_err)?)
        }
        PixelFormat::Grey | PixelFormat::Bayer(_) => GreyImage::U8(image::GrayImage::from_raw(w, h, quantise(&raw, scale, 255.0)).ok_or_else(size_err)?),
        PixelFormat::Rgb(pattern) => {
            let rgb = sensor::demosaic(&raw, w as usize, h as usize, pattern, fx.output.demosaic).map_err(|e| RenderError::Scene(e.into()))?;
            let flat: Vec<f32> = rgb.iter().flatten().copied().collect();
            if sixteen {
                GreyImage::Rgb16(image::ImageBuffer::from_raw(w, h, quantise(&flat, scale, 65535.0)).ok_or_else(size_err)?)
            } else {
                GreyImage::Rgb8(image::RgbImage::from_raw(w, h, quantise(&flat, scale, 255.0)).ok_or_else(size_err)?)
            }
        }
    })
}

/// Scale, round and clamp to `[0, max]` (`max` 255 or 65535) in the output's sample type.
fn quantise<T: TryFrom<u16> + Default + Send>(vals: &[f32], scale: f64, max: f64) -> Vec<T> {
    vals.par_iter().map(|v| T::try_from((f64::from(*v) * scale).round().clamp(0.0, max) as u16).unwrap_or_default()).collect()
}

/// Encode `img` as baseline JPEG at `quality` (1..=100) in memory (no file I/O: the dataset writes
/// the bytes, experiments decode them again); 16-bit images are reduced to 8 bits first.
///
/// # Errors
/// [`RenderError::Device`] with the encoder's message.
pub fn jpeg_bytes(img: &GreyImage, quality: u8) -> Result<Vec<u8>, RenderError> {
    let mut out = Vec::new();
    let mut enc = image::codecs::jpeg::JpegEncoder::new_with_quality(&mut out, quality.clamp(1, 100));
    let (w, h) = img.dimensions();
    let res = match img {
        GreyImage::Rgb8(i) => enc.encode(i.as_raw(), w, h, image::ExtendedColorType::Rgb8),
        GreyImage::Rgb16(i) => {
            let v: Vec<u8> = i.as_raw().iter().map(|v| (f64::from(*v) / 257.0).round() as u8).collect();
            enc.encode(&v, w, h, image::ExtendedColorType::Rgb8)
        }
        _ => enc.encode(&img.to_u8(), w, h, image::ExtendedColorType::L8),
    };
    res.map_err(|e| RenderError::Device(format!("JPEG encoding: {e}")))?;
    Ok(out)
}
