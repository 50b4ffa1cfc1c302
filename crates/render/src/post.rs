//! Gaussian blur (point-spread function) and additive Gaussian noise, on the CPU
//! (`super::formation` orders them with the other effects). Deterministic: the noise comes
//! from a ChaCha8 generator seeded with the scene seed and is drawn in row-major pixel order, so the
//! same scene and seed give the same bytes on any machine and backend.

use rand::SeedableRng;
use rand_chacha::ChaCha8Rng;
use rand_distr::{Distribution, Normal};

/// Separable Gaussian blur with standard deviation `sigma_px`, kernel radius ceil(4 sigma),
/// clamp-to-edge borders. `sigma_px <= 0` returns the input unchanged.
pub fn gaussian_blur(img: &[f32], width: usize, height: usize, sigma_px: f64) -> Vec<f32> {
    if sigma_px <= 0.0 || width == 0 || height == 0 {
        return img.to_vec();
    }
    let radius = (4.0 * sigma_px).ceil() as isize;
    let mut kernel: Vec<f64> = (-radius..=radius).map(|i| (-0.5 * (i as f64 / sigma_px).powi(2)).exp()).collect();
    let sum: f64 = kernel.iter().sum();
    kernel.iter_mut().for_each(|k| *k /= sum);
    let pass = |src: &[f32], horizontal: bool| -> Vec<f32> {
        let mut dst = vec![0.0f32; src.len()];
        for y in 0..height {
            for x in 0..width {
                let mut acc = 0.0f64;
                for (k, kv) in kernel.iter().enumerate() {
                    let o = k as isize - radius;
                    let (sx, sy) = if horizontal {
                        ((x as isize + o).clamp(0, width as isize - 1) as usize, y)
                    } else {
                        (x, (y as isize + o).clamp(0, height as isize - 1) as usize)
                    };
                    acc += kv * f64::from(src[sy * width + sx]);
                }
                dst[y * width + x] = acc as f32;
            }
        }
        dst
    };
    let tmp = pass(img, true);
    pass(&tmp, false)
}

/// Add N(0, sigma^2) noise in place, seeded; `sigma <= 0` does nothing.
pub fn add_noise(img: &mut [f32], sigma: f64, seed: u64) {
    if sigma <= 0.0 {
        return;
    }
    let mut rng = ChaCha8Rng::seed_from_u64(seed);
    let Ok(normal) = Normal::new(0.0, sigma) else { return };
    for v in img.iter_mut() {
        *v = (f64::from(*v) + normal.sample(&mut rng)) as f32;
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn blur_preserves_mean_and_constant() {
        let img = vec![100.0f32; 20 * 10];
        let b = gaussian_blur(&img, 20, 10, 1.5);
        assert!(b.iter().all(|v| (v - 100.0).abs() < 1e-3));
        let mut step = vec![0.0f32; 40];
        step[20..].iter_mut().for_each(|v| *v = 200.0);
        let b = gaussian_blur(&step, 40, 1, 2.0);
        assert!((b[19] + b[20] - 200.0).abs() < 1e-3, "a symmetric blur keeps the edge at 19.5");
    }

    #[test]
    fn noise_is_seeded_and_has_the_right_sigma() {
        let mut a = vec![128.0f32; 100_000];
        let mut b = a.clone();
        add_noise(&mut a, 2.0, 7);
        add_noise(&mut b, 2.0, 7);
        assert_eq!(a, b);
        let mean = a.iter().map(|v| f64::from(*v)).sum::<f64>() / a.len() as f64;
        let var = a.iter().map(|v| (f64::from(*v) - mean).powi(2)).sum::<f64>() / a.len() as f64;
        // 100k samples: the standard error of sigma is ~0.2 %.
        assert!((var.sqrt() - 2.0).abs() < 0.02, "sigma {}", var.sqrt());
    }
}
