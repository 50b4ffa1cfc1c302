//! Raster plots (PNG) drawn by `plotters` on an in-memory RGB buffer and encoded by `image`.
//!
//! The font (DejaVu Sans, `assets/fonts/`, Bitstream Vera licence) is embedded and registered with
//! plotters' `ab_glyph` text backend, so plots render the same on a headless machine without font
//! files. Data reaches plotters only through [`lin_range`], [`log_range`] and [`clamp`]: values
//! outside an axis (NaN, infinities, zeros on a log axis) are pinned to its edge or dropped, so no
//! input makes the rasteriser walk billions of off-screen pixels.

use std::sync::OnceLock;

use plotters::coord::Shift;
use plotters::prelude::*;

use super::ReportError;

/// The embedded font.
const DEJAVU_SANS: &[u8] = include_bytes!("../../assets/fonts/DejaVuSans.ttf");

/// The font family every plot uses (the embedded DejaVu Sans).
pub const FONT: &str = "sans-serif";

/// Colours for series (matplotlib's tab10).
pub const PALETTE: [RGBColor; 6] =
    [RGBColor(31, 119, 180), RGBColor(255, 127, 14), RGBColor(44, 160, 44), RGBColor(214, 39, 40), RGBColor(148, 103, 189), RGBColor(140, 86, 75)];

/// The colour of series `k`.
pub fn colour(k: usize) -> RGBColor {
    PALETTE[k % PALETTE.len()]
}

/// A drawing area on the figure's buffer.
pub type Area<'a> = DrawingArea<BitMapBackend<'a>, Shift>;

/// What a drawing closure returns (plotters' errors, boxed).
pub type DrawResult = Result<(), Box<dyn std::error::Error>>;

fn register_font() -> Result<(), ReportError> {
    static REGISTERED: OnceLock<bool> = OnceLock::new();
    let ok = *REGISTERED.get_or_init(|| plotters::style::register_font(FONT, FontStyle::Normal, DEJAVU_SANS).is_ok());
    if ok {
        Ok(())
    } else {
        Err(ReportError::Encode("the embedded font does not parse".into()))
    }
}

/// Draw a `width` x `height` figure on a white background with `draw` and return it as PNG bytes.
///
/// # Errors
/// A size of zero or over 16384 px, a drawing error, or PNG encoding.
pub fn figure(width: u32, height: u32, draw: impl FnOnce(&Area<'_>) -> DrawResult) -> Result<Vec<u8>, ReportError> {
    if !(1..=16384).contains(&width) || !(1..=16384).contains(&height) {
        return Err(ReportError::Input { what: "figure", reason: format!("size {width}x{height} px") });
    }
    let mut buf = vec![255u8; width as usize * height as usize * 3];
    draw_on(&mut buf, width, height, draw)?;
    let img = image::RgbImage::from_raw(width, height, buf).ok_or_else(|| ReportError::Encode("buffer size".into()))?;
    png(&img)
}

/// Draw with `draw` on an RGB8 buffer of `width` x `height` (for example an image's raw pixels).
///
/// # Errors
/// A buffer of the wrong size or a drawing error.
pub fn draw_on(buf: &mut [u8], width: u32, height: u32, draw: impl FnOnce(&Area<'_>) -> DrawResult) -> Result<(), ReportError> {
    register_font()?;
    if buf.len() != width as usize * height as usize * 3 {
        return Err(ReportError::Input { what: "figure", reason: format!("{} bytes for {width}x{height} RGB", buf.len()) });
    }
    let root = BitMapBackend::with_buffer(buf, (width, height)).into_drawing_area();
    draw(&root).map_err(|e| ReportError::Encode(e.to_string()))?;
    root.present().map_err(|e| ReportError::Encode(e.to_string()))
}

/// A linear axis range covering the finite `values` with 5 % padding (at least `min_span` wide;
/// (0, 1) when there is no finite value).
pub fn lin_range(values: impl IntoIterator<Item = f64>, min_span: f64) -> (f64, f64) {
    let (lo, hi) = values.into_iter().filter(|v| v.is_finite()).fold((f64::INFINITY, f64::NEG_INFINITY), |(a, b), v| (a.min(v), b.max(v)));
    if lo > hi {
        return (0.0, 1.0);
    }
    let span = (hi - lo).max(min_span.abs()).max(1e-12);
    let mid = 0.5 * (lo + hi);
    (mid - 0.55 * span, mid + 0.55 * span)
}

/// A log axis range of whole decades covering the positive finite `values`, at most
/// `max_decades` deep below the largest (one decade around 1 when there is none).
pub fn log_range(values: impl IntoIterator<Item = f64>, max_decades: i32) -> (f64, f64) {
    let logs = values.into_iter().filter(|v| *v > 0.0 && v.is_finite()).map(f64::log10);
    let (lo, hi) = logs.fold((f64::INFINITY, f64::NEG_INFINITY), |(a, b), v| (a.min(v), b.max(v)));
    if lo > hi {
        return (0.1, 10.0);
    }
    let hi = hi.ceil().clamp(-300.0, 300.0);
    let lo = lo.floor().max(hi - f64::from(max_decades.max(1))).min(hi - 1.0);
    (10f64.powf(lo), 10f64.powf(hi))
}

/// A tick label for a log axis: plain for 0.001 to 99999, else `1e-6` style.
pub fn log_label(v: &f64) -> String {
    let a = v.abs();
    if (1e-3..1e5).contains(&a) {
        let digits = (-a.log10().floor()).clamp(0.0, 3.0) as usize;
        format!("{v:.digits$}")
    } else {
        format!("{v:.0e}")
    }
}

/// A tick label with no decimals (steps, views, pixels).
pub fn int_label(v: &f64) -> String {
    format!("{v:.0}")
}

/// `v` pinned to `[lo, hi]`, or `None` when it is NaN.
pub fn clamp(v: f64, (lo, hi): (f64, f64)) -> Option<f64> {
    (!v.is_nan()).then(|| v.clamp(lo.min(hi), hi.max(lo)))
}

/// The legend in the upper right corner, on a translucent box (so it hides no curve entirely).
pub fn legend<'a, DB: DrawingBackend + 'a, C: plotters::coord::CoordTranslate>(
    chart: &mut ChartContext<'a, DB, C>,
) -> Result<(), DrawingAreaErrorKind<DB::ErrorType>> {
    chart
        .configure_series_labels()
        .position(SeriesLabelPosition::UpperRight)
        .background_style(WHITE.mix(0.75))
        .border_style(BLACK.mix(0.4))
        .label_font((FONT, 14))
        .draw()
}

/// A legend swatch: a short line in `colour`.
pub fn swatch(colour: RGBColor) -> impl Fn((i32, i32)) -> PathElement<(i32, i32)> {
    move |(x, y)| PathElement::new(vec![(x, y), (x + 20, y)], colour.stroke_width(2))
}

/// Encode an RGB image as PNG bytes.
///
/// # Errors
/// Encoding failure.
pub fn png(img: &image::RgbImage) -> Result<Vec<u8>, ReportError> {
    let mut out = Vec::new();
    img.write_to(&mut std::io::Cursor::new(&mut out), image::ImageFormat::Png).map_err(|e| ReportError::Encode(e.to_string()))?;
    Ok(out)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn ranges_cover_their_values_and_survive_bad_input() {
        let (lo, hi) = lin_range([1.0, 3.0, f64::NAN], 0.0);
        assert!(lo < 1.0 && hi > 3.0 && (hi - lo) < 2.5);
        assert_eq!(lin_range([f64::NAN], 1.0), (0.0, 1.0));
        let (lo, hi) = lin_range([5.0], 1.0);
        assert!((hi - lo - 1.1).abs() < 1e-12 && lo < 5.0 && hi > 5.0);
        assert_eq!(log_range([0.02, 30.0, 0.0, -1.0, f64::INFINITY], 6), (0.01, 100.0));
        assert_eq!(log_range([1e-12, 1.0], 4), (1e-4, 1.0));
        assert_eq!(log_range([], 4), (0.1, 10.0));
        assert_eq!(clamp(f64::NEG_INFINITY, (0.1, 10.0)), Some(0.1));
        assert_eq!(clamp(f64::NAN, (0.1, 10.0)), None);
        let labels: Vec<String> = [1e-6, 0.001, 0.01, 0.5, 1.0, 100.0, 1e5].iter().map(log_label).collect();
        assert_eq!(labels, ["1e-6", "0.001", "0.01", "0.5", "1", "100", "1e5"]);
    }

    #[test]
    fn a_figure_draws_text_with_the_embedded_font() {
        let bytes = figure(200, 60, |root| {
            root.draw(&Text::new("synthcam 0.1", (10, 20), (FONT, 20)))?;
            Ok(())
        })
        .expect("figure");
        let img = image::load_from_memory(&bytes).expect("png").to_rgb8();
        // Anti-aliased glyphs: dark pixels and grey edge pixels, none outside the text's box.
        let dark = img.pixels().filter(|p| p[0] < 64).count();
        let grey = img.pixels().filter(|p| p[0] > 64 && p[0] < 192).count();
        assert!(dark > 100 && grey > 50, "dark {dark}, grey {grey}");
        assert!(img.enumerate_pixels().all(|(_, y, p)| p[0] == 255 || (10..50).contains(&y)));
        assert!(matches!(figure(0, 10, |_| Ok(())), Err(ReportError::Input { .. })));
    }
}
