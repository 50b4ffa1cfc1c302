//! Small raster plots (PNG) without font files: lines and bars by imageproc, labels in the
//! built-in 8x8 bitmap font (font8x8).

use font8x8::UnicodeFonts;
use image::{Rgb, RgbImage};
use imageproc::drawing::{draw_antialiased_line_segment_mut, draw_filled_rect_mut, draw_hollow_rect_mut, draw_line_segment_mut};
use imageproc::pixelops::interpolate;
use imageproc::rect::Rect;

/// Colours for series.
pub const PALETTE: [Rgb<u8>; 6] = [Rgb([31, 119, 180]), Rgb([255, 127, 14]), Rgb([44, 160, 44]), Rgb([214, 39, 40]), Rgb([148, 103, 189]), Rgb([140, 86, 75])];

/// Write `text` with its top-left corner at (x, y), `scale` pixels per font pixel.
pub fn text(img: &mut RgbImage, x: i32, y: i32, s: &str, colour: Rgb<u8>, scale: i32) {
    for (k, ch) in s.chars().enumerate() {
        let Some(glyph) = font8x8::BASIC_FONTS.get(ch) else { continue };
        for (row, bits) in glyph.iter().enumerate() {
            for col in 0..8 {
                if bits & (1 << col) != 0 {
                    for dy in 0..scale {
                        for dx in 0..scale {
                            let (px, py) = (x + (k as i32 * 8 + col) * scale + dx, y + row as i32 * scale + dy);
                            if px >= 0 && py >= 0 && (px as u32) < img.width() && (py as u32) < img.height() {
                                img.put_pixel(px as u32, py as u32, colour);
                            }
                        }
                    }
                }
            }
        }
    }
}

/// A plotting panel: a pixel rectangle and the data ranges it shows.
#[derive(Debug, Clone, Copy)]
pub struct Panel {
    /// Left, top, width, height in pixels.
    pub rect: (i32, i32, i32, i32),
    /// x range.
    pub x: (f64, f64),
    /// y range.
    pub y: (f64, f64),
}

impl Panel {
    /// Pixel of a data point.
    pub fn px(&self, x: f64, y: f64) -> (f32, f32) {
        let (l, t, w, h) = self.rect;
        let u = l as f64 + (x - self.x.0) / (self.x.1 - self.x.0) * w as f64;
        let v = (t + h) as f64 - (y - self.y.0) / (self.y.1 - self.y.0) * h as f64;
        (u as f32, v as f32)
    }

    /// Frame, title, axis labels and ticks (`xt`, `yt`: value and label).
    pub fn axes(&self, img: &mut RgbImage, title: &str, xlabel: &str, ylabel: &str, xt: &[(f64, String)], yt: &[(f64, String)]) {
        let (l, t, w, h) = self.rect;
        let black = Rgb([0, 0, 0]);
        let grey = Rgb([225, 225, 225]);
        for (v, _) in yt {
            let (_, py) = self.px(self.x.0, *v);
            draw_line_segment_mut(img, (l as f32, py), ((l + w) as f32, py), grey);
        }
        draw_hollow_rect_mut(img, Rect::at(l, t).of_size(w as u32, h as u32), black);
        text(img, l + 10, t - 42, title, black, 2);
        text(img, l + w / 2 - 4 * xlabel.len() as i32, t + h + 22, xlabel, black, 1);
        text(img, l - 60, t - 10, ylabel, black, 1);
        for (v, s) in xt {
            let (px, _) = self.px(*v, self.y.0);
            draw_line_segment_mut(img, (px, (t + h) as f32), (px, (t + h + 4) as f32), black);
            text(img, px as i32 - 4 * s.len() as i32, t + h + 8, s, black, 1);
        }
        for (v, s) in yt {
            let (_, py) = self.px(self.x.0, *v);
            draw_line_segment_mut(img, ((l - 4) as f32, py), (l as f32, py), black);
            text(img, l - 8 - 8 * s.len() as i32, py as i32 - 4, s, black, 1);
        }
    }

    /// A polyline through data points (anti-aliased), a filled square at each point.
    pub fn line(&self, img: &mut RgbImage, pts: &[(f64, f64)], colour: Rgb<u8>) {
        self.styled_line(img, pts, colour, false);
    }

    /// A polyline, solid with filled markers or dashed with hollow ones (so that a second run
    /// drawn over the first leaves it visible).
    pub fn styled_line(&self, img: &mut RgbImage, pts: &[(f64, f64)], colour: Rgb<u8>, dashed: bool) {
        for (k, w) in pts.windows(2).enumerate() {
            if dashed && k % 2 == 1 {
                continue;
            }
            let (a, b) = (self.px(w[0].0, w[0].1), self.px(w[1].0, w[1].1));
            draw_antialiased_line_segment_mut(img, (a.0 as i32, a.1 as i32), (b.0 as i32, b.1 as i32), colour, interpolate);
        }
        for p in pts {
            let (u, v) = self.px(p.0, p.1);
            let r = Rect::at(u as i32 - 2, v as i32 - 2).of_size(5, 5);
            if dashed {
                draw_hollow_rect_mut(img, r, colour);
            } else {
                draw_filled_rect_mut(img, r, colour);
            }
        }
    }

    /// A vertical bar from y = 0 (or the bottom) to `y` at data x, `width` pixels wide.
    pub fn bar(&self, img: &mut RgbImage, x: f64, y: f64, width: u32, colour: Rgb<u8>) {
        let (u, top) = self.px(x, y);
        let (_, base) = self.px(x, self.y.0.max(0.0));
        let (a, b) = (top.min(base) as i32, (top - base).abs().max(1.0) as u32);
        draw_filled_rect_mut(img, Rect::at(u as i32 - width as i32 / 2, a).of_size(width, b), colour);
    }
}

/// A white canvas.
pub fn canvas(w: u32, h: u32) -> RgbImage {
    RgbImage::from_pixel(w, h, Rgb([255, 255, 255]))
}

/// Encode an RGB image as PNG bytes.
///
/// # Errors
/// Encoding failure.
pub fn png(img: &RgbImage) -> Result<Vec<u8>, super::ReportError> {
    let mut out = Vec::new();
    image::DynamicImage::ImageRgb8(img.clone())
        .write_to(&mut std::io::Cursor::new(&mut out), image::ImageFormat::Png)
        .map_err(|e| super::ReportError::Encode(e.to_string()))?;
    Ok(out)
}
