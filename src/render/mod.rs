//! The GPU renderer: the only module that names wgpu.
//!
//! [`GpuContext`] opens a headless device (Vulkan, i.e. lavapipe on machines without a GPU; GL
//! llvmpipe as fallback). [`Renderer`] runs `shaders/render.wgsl`, one compute invocation per pixel,
//! which inverts the lens distortion per pixel, casts rays at the exact target geometry and
//! box-filters each pixel (analytic coverage or supersampling). `post` applies blur, noise and
//! quantisation on the CPU, deterministically.

pub mod bend;
mod buffers;
pub mod context;
mod flat;
pub(crate) mod gpu_scene;
pub(crate) mod post;
pub mod renderer;
pub(crate) mod uniforms;

pub use context::{BackendChoice, GpuContext};
pub use renderer::Renderer;

use crate::scene::{Scene, SceneError};

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
    #[error("image {width}x{height} exceeds the device's storage buffer limit of {max_bytes} bytes")]
    TooLarge {
        /// Width, pixels.
        width: u32,
        /// Height, pixels.
        height: u32,
        /// Device limit.
        max_bytes: u64,
    },
}

/// A rendered grey image.
#[derive(Debug, Clone, PartialEq)]
pub enum GreyImage {
    /// 8-bit.
    U8(image::GrayImage),
    /// 16-bit.
    U16(image::ImageBuffer<image::Luma<u16>, Vec<u16>>),
}

impl GreyImage {
    /// Width and height, pixels.
    pub fn dimensions(&self) -> (u32, u32) {
        match self {
            GreyImage::U8(i) => i.dimensions(),
            GreyImage::U16(i) => i.dimensions(),
        }
    }

    /// The image as the detectors take it (8-bit values as f32).
    ///
    /// # Errors
    /// Never for an image the renderer made; [`crate::detect::DetectError`] for inconsistent buffers.
    pub fn to_detector_image(&self) -> Result<crate::detect::ImageF32, crate::detect::DetectError> {
        let (w, h) = self.dimensions();
        crate::detect::ImageF32::from_u8(w as usize, h as usize, &self.to_u8())
    }

    /// 8-bit pixel values (16-bit images are divided by 257 and rounded).
    pub fn to_u8(&self) -> Vec<u8> {
        match self {
            GreyImage::U8(i) => i.as_raw().clone(),
            GreyImage::U16(i) => i.as_raw().iter().map(|v| ((f64::from(*v)) / 257.0).round() as u8).collect(),
        }
    }
}

/// Blur, noise and quantise a linear render according to the scene's settings.
pub fn finish(scene: &Scene, linear: &[f32]) -> GreyImage {
    let (w, h) = (scene.camera.size.width, scene.camera.size.height);
    let mut img = post::gaussian_blur(linear, w as usize, h as usize, scene.render.blur_sigma_px);
    post::add_noise(&mut img, scene.render.noise_sigma, scene.render.seed);
    if scene.render.bit_depth == 16 {
        GreyImage::U16(image::ImageBuffer::from_raw(w, h, post::quantise_u16(&img)).unwrap_or_else(|| image::ImageBuffer::new(w, h)))
    } else {
        GreyImage::U8(image::GrayImage::from_raw(w, h, post::quantise_u8(&img)).unwrap_or_else(|| image::GrayImage::new(w, h)))
    }
}

impl Renderer {
    /// Render `scene` to a finished grey image (geometry, blur, noise, quantisation).
    ///
    /// # Errors
    /// As [`Renderer::render_linear`].
    pub fn render(&self, scene: &Scene) -> Result<GreyImage, RenderError> {
        let linear = self.render_linear(scene)?;
        Ok(finish(scene, &linear))
    }
}
