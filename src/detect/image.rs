//! A minimal owned grey image in f32, row-major, OpenCV pixel convention.

use super::DetectError;

/// Grey image with f32 samples.
#[derive(Debug, Clone, PartialEq)]
pub struct ImageF32 {
    /// Width, pixels.
    pub width: usize,
    /// Height, pixels.
    pub height: usize,
    /// Row-major samples.
    pub data: Vec<f32>,
}

impl ImageF32 {
    /// Wrap a buffer.
    ///
    /// # Errors
    /// [`DetectError::BadBuffer`] when `data.len() != width * height`.
    pub fn new(width: usize, height: usize, data: Vec<f32>) -> Result<Self, DetectError> {
        if data.len() != width * height {
            return Err(DetectError::BadBuffer { expected: width * height, actual: data.len() });
        }
        Ok(Self { width, height, data })
    }

    /// From 8-bit samples.
    ///
    /// # Errors
    /// As [`ImageF32::new`].
    pub fn from_u8(width: usize, height: usize, data: &[u8]) -> Result<Self, DetectError> {
        Self::new(width, height, data.iter().map(|v| f32::from(*v)).collect())
    }

    /// Sample at integer coordinates (no bounds check beyond the slice's own).
    #[inline]
    pub fn at(&self, x: usize, y: usize) -> f32 {
        self.data[y * self.width + x]
    }
}
