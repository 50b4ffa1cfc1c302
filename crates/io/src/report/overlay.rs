//! Overlays for people: the detected points and their order drawn on the image.

use image::{Rgb, RgbImage};
use imageproc::drawing::{draw_cross_mut, draw_hollow_circle_mut, draw_line_segment_mut};
use nalgebra::Point2;

use synthcam_detect::ImageF32;

/// The grey image in colour with the points joined in order (blue to red), each marked with a
/// cross, and the first point circled.
pub fn draw_points(img: &ImageF32, points: &[Point2<f64>]) -> RgbImage {
    let mut out = RgbImage::from_fn(img.width as u32, img.height as u32, |x, y| {
        let v = img.data[y as usize * img.width + x as usize].round().clamp(0.0, 255.0) as u8;
        Rgb([v, v, v])
    });
    let n = points.len().max(2) - 1;
    let colour = |i: usize| {
        let t = i as f64 / n as f64;
        Rgb([(255.0 * t) as u8, 64, (255.0 * (1.0 - t)) as u8])
    };
    for (i, w) in points.windows(2).enumerate() {
        draw_line_segment_mut(&mut out, (w[0].x as f32, w[0].y as f32), (w[1].x as f32, w[1].y as f32), colour(i));
    }
    for (i, p) in points.iter().enumerate() {
        draw_cross_mut(&mut out, colour(i), p.x.round() as i32, p.y.round() as i32);
    }
    if let Some(p) = points.first() {
        for r in [6, 7] {
            draw_hollow_circle_mut(&mut out, (p.x.round() as i32, p.y.round() as i32), r, Rgb([0, 255, 0]));
        }
    }
    out
}
