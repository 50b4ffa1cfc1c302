//! The GPU renderer: the only module that names wgpu.
//!
//! [`GpuContext`] opens a headless device (Vulkan, i.e. lavapipe on machines without a GPU; GL
//! llvmpipe as fallback). [`Renderer`] runs the shaders (`shaders/*.wgsl`), one compute invocation per pixel,
//! which inverts the lens distortion per pixel, casts rays at the exact target geometry and
//! box-filters each pixel (analytic coverage or supersampling). `post` applies blur, noise and
//! quantisation on the CPU, deterministically.
//!
//! ```
//! use synthcam_core::{camera::CameraModel, target::Target};
//! use synthcam_render::Renderer;
//! use synthcam_scene::{Facing, Scene};
//! # fn main() -> Result<(), Box<dyn std::error::Error>> {
//! let camera = CameraModel::pinhole(320, 240, 250.0).with_distortion([-0.3, 0.1, 0.0, 0.0, 0.0]);
//! let scene = Scene::builder()
//!     .camera(camera)
//!     .target(Target::chessboard(8, 6, 0.03))
//!     .facing(Facing { distance_m: 0.5, tilt_x_deg: 20.0, tilt_y_deg: 0.0, roll_deg: 0.0 })
//!     .build()?;
//! let renderer = Renderer::headless()?; // Vulkan (lavapipe without a GPU), else GL
//! let (image, truth) = renderer.render_with_truth(&scene)?;
//! assert_eq!((image.dimensions(), truth.features.len()), ((320, 240), 35));
//! # Ok(())
//! # }
//! ```

#![deny(missing_docs)]

mod background;
pub mod bend;
mod bg_tiles;
mod buffers;
pub mod context;
mod flat;
pub mod formation;
pub(crate) mod gpu_scene;
mod object_pass;
pub(crate) mod objects;
pub(crate) mod post;
pub mod renderer;
mod shader;
mod soft_lattice;
pub(crate) mod tiles;
pub(crate) mod uniforms;
pub mod views;

pub use context::{BackendChoice, GpuContext};
pub use renderer::Renderer;

use rayon::prelude::*;

use synthcam_scene::effects::PixelFormat;
use synthcam_scene::{Scene, SceneError};

/// Errors of the renderer.
#[derive(Debug, thiserror::Error)]
#[non_exhaustive]
pub enum RenderError {
    /// No GPU adapter on any backend.
    #[error("no GPU adapter found (install mesa-vulkan-drivers and libvulkan1 for lavapipe): {0}")]
    NoAdapter(String),
    /// The device failed.
    #[error("GPU device error: {0}")]
    Device(String),
    /// The scene is invalid.
    #[error(transparent)]
    Scene(#[from] SceneError),
    /// The view is degenerate.
    #[error("degenerate view: {0}")]
    Degenerate(String),
    /// The image does not fit in one storage buffer.
    #[error("image {width}x{height} (its pixels, or its views: rows x exposure and aperture samples) exceeds the device's storage buffer limit of {max_bytes} bytes")]
    TooLarge {
        /// Width, pixels.
        width: u32,
        /// Height, pixels.
        height: u32,
        /// Device limit.
        max_bytes: u64,
    },
}

/// A rendered image: grey or a Bayer raw image (one channel), or RGB
/// ([`synthcam_scene::effects::PixelFormat`]).
#[derive(Debug, Clone, PartialEq)]
pub enum GreyImage {
    /// 8-bit.
    U8(image::GrayImage),
    /// 16-bit.
    U16(image::ImageBuffer<image::Luma<u16>, Vec<u16>>),
    /// 8-bit RGB.
    Rgb8(image::RgbImage),
    /// 16-bit RGB.
    Rgb16(image::ImageBuffer<image::Rgb<u16>, Vec<u16>>),
}

impl From<image::DynamicImage> for GreyImage {
    /// A decoded file as stored: grey stays grey and colour stays colour, 8-bit or 16-bit as the
    /// file has it (float images become 16-bit); an alpha channel is dropped.
    fn from(img: image::DynamicImage) -> Self {
        use image::DynamicImage as D;
        match img {
            D::ImageLuma8(i) => GreyImage::U8(i),
            D::ImageLuma16(i) => GreyImage::U16(i),
            D::ImageRgb8(i) => GreyImage::Rgb8(i),
            D::ImageRgb16(i) => GreyImage::Rgb16(i),
            D::ImageLumaA8(_) => GreyImage::U8(img.to_luma8()),
            D::ImageLumaA16(_) => GreyImage::U16(img.to_luma16()),
            D::ImageRgba8(_) => GreyImage::Rgb8(img.to_rgb8()),
            _ => GreyImage::Rgb16(img.to_rgb16()),
        }
    }
}

impl GreyImage {
    /// Width and height, pixels.
    pub fn dimensions(&self) -> (u32, u32) {
        match self {
            GreyImage::U8(i) => i.dimensions(),
            GreyImage::U16(i) => i.dimensions(),
            GreyImage::Rgb8(i) => i.dimensions(),
            GreyImage::Rgb16(i) => i.dimensions(),
        }
    }

    /// The image as the detectors take it (8-bit values as f32).
    ///
    /// # Errors
    /// Never for an image the renderer made; [`synthcam_detect::DetectError`] for inconsistent buffers.
    pub fn to_detector_image(&self) -> Result<synthcam_detect::ImageF32, synthcam_detect::DetectError> {
        let (w, h) = self.dimensions();
        synthcam_detect::ImageF32::from_u8(w as usize, h as usize, &self.to_u8())
    }

    /// 8-bit grey values (16-bit images are divided by 257 and rounded; RGB images give their
    /// luma, ITU-R BT.601).
    pub fn to_u8(&self) -> Vec<u8> {
        let luma = |p: [f64; 3], scale: f64| (synthcam_core::camera::sensor::luma(p) / scale).round().clamp(0.0, 255.0) as u8;
        match self {
            GreyImage::U8(i) => i.as_raw().clone(),
            GreyImage::U16(i) => i.as_raw().iter().map(|v| ((f64::from(*v)) / 257.0).round() as u8).collect(),
            GreyImage::Rgb8(i) => i.pixels().map(|p| luma(p.0.map(f64::from), 1.0)).collect(),
            GreyImage::Rgb16(i) => i.pixels().map(|p| luma(p.0.map(f64::from), 257.0)).collect(),
        }
    }
}

pub use formation::finish;

impl Renderer {
    /// The radiance the sensor sees: [`Renderer::render_linear`], or for a colour target
    /// (`[output] target_rgb`) one render per channel with that channel's albedo, sampled by the
    /// colour filter array (Bayer and RGB output) or combined as BT.601 luma (grey output).
    ///
    /// # Errors
    /// As [`Renderer::render_linear`].
    pub fn render_radiance(&self, scene: &Scene) -> Result<Vec<f32>, RenderError> {
        let Some(albedo) = scene.render.effects.output.target_rgb else { return self.render_linear(scene) };
        let channel = |c: usize| self.render_linear(&Scene { target: scene.target.with_greys(albedo.map(|region| region[c])), ..scene.clone() });
        let channels = [channel(0)?, channel(1)?, channel(2)?];
        // Per pixel straight from the channel planes (no interleaved copy: this is per frame).
        let w = (scene.camera.size.width as usize).max(1);
        let pick = |i: usize| match scene.render.effects.output.format {
            PixelFormat::Bayer(p) | PixelFormat::Rgb(p) => channels[p.channel_at(i % w, i / w)][i],
            PixelFormat::Grey => synthcam_core::camera::sensor::luma(channels.each_ref().map(|c| f64::from(c[i]))) as f32,
        };
        Ok((0..channels[0].len()).into_par_iter().map(pick).collect())
    }

    /// Render `scene` to a finished grey image (geometry, blur, noise, quantisation).
    ///
    /// # Errors
    /// As [`Renderer::render_linear`].
    pub fn render(&self, scene: &Scene) -> Result<GreyImage, RenderError> {
        formation::finish_owned(scene, self.render_radiance(scene)?)
    }
}
