//! Atomic file output.

use std::io::Write;
use std::path::Path;

use image::ImageEncoder;

use super::DatasetError;
use synthcam_render::GreyImage;
use synthcam_scene::truth::TruthLabels;

/// Encode a grey image as PNG in memory.
///
/// # Errors
/// [`DatasetError::Encode`].
pub fn encode_png(img: &GreyImage) -> Result<Vec<u8>, DatasetError> {
    let mut out = Vec::new();
    let enc = image::codecs::png::PngEncoder::new_with_quality(&mut out, image::codecs::png::CompressionType::Fast, image::codecs::png::FilterType::Adaptive);
    let res = match img {
        GreyImage::U8(i) => enc.write_image(i.as_raw(), i.width(), i.height(), image::ExtendedColorType::L8),
        // The encoder takes 16-bit samples in native byte order and writes PNG's big-endian.
        GreyImage::U16(i) => enc.write_image(bytemuck::cast_slice(i.as_raw()), i.width(), i.height(), image::ExtendedColorType::L16),
        GreyImage::Rgb8(i) => enc.write_image(i.as_raw(), i.width(), i.height(), image::ExtendedColorType::Rgb8),
        GreyImage::Rgb16(i) => enc.write_image(bytemuck::cast_slice(i.as_raw()), i.width(), i.height(), image::ExtendedColorType::Rgb16),
    };
    res.map_err(|e| DatasetError::Encode(e.to_string()))?;
    Ok(out)
}

/// Encode an image as JPEG (baseline, `quality` 1..=100) in memory; 16-bit images are reduced
/// to 8 bits first (JPEG holds 8).
///
/// # Errors
/// [`DatasetError::Encode`].
pub fn encode_jpeg(img: &GreyImage, quality: u8) -> Result<Vec<u8>, DatasetError> {
    synthcam_render::formation::jpeg_bytes(img, quality).map_err(|e| DatasetError::Encode(e.to_string()))
}

/// Encode `img` as the scene's output asks ([`synthcam_scene::effects::Encoding`]): PNG or JPEG.
///
/// # Errors
/// [`DatasetError::Encode`].
pub fn encode_image(img: &GreyImage, output: &synthcam_scene::effects::Output) -> Result<Vec<u8>, DatasetError> {
    match output.encoding {
        synthcam_scene::effects::Encoding::Png => encode_png(img),
        synthcam_scene::effects::Encoding::Jpeg => encode_jpeg(img, output.jpeg_quality),
    }
}

/// Write `bytes` to `path` through a temporary file in the same folder and a rename.
///
/// # Errors
/// [`DatasetError::Write`]; the temporary file is removed on failure.
pub fn write_atomic(path: &Path, bytes: &[u8]) -> Result<(), DatasetError> {
    let err = |source| DatasetError::Write { path: path.display().to_string(), source };
    let file_name = path.file_name().map(|n| n.to_string_lossy().into_owned()).unwrap_or_default();
    let tmp = path.with_file_name(format!(".{file_name}.tmp{}", std::process::id()));
    let result = (|| {
        let mut f = std::fs::File::create(&tmp)?;
        f.write_all(bytes)?;
        f.sync_all()?;
        std::fs::rename(&tmp, path)
    })();
    if let Err(e) = result {
        let _ = std::fs::remove_file(&tmp);
        return Err(err(e));
    }
    Ok(())
}

/// Write `png_path` and the truth JSON beside it (same stem, `.json`). Both are encoded before
/// anything is written.
///
/// # Errors
/// Encoding or writing failed; nothing half-written is left.
pub fn write_image_and_truth(png_path: &Path, img: &GreyImage, truth: &TruthLabels) -> Result<(), DatasetError> {
    let png = encode_png(img)?;
    let json = truth_json(truth)?;
    write_png_and_json(png_path, &png, &json)
}

/// The truth JSON bytes as [`write_image_and_truth`] writes them.
///
/// # Errors
/// [`DatasetError::Json`].
pub fn truth_json(truth: &TruthLabels) -> Result<Vec<u8>, DatasetError> {
    serde_json::to_vec_pretty(truth).map_err(|e| DatasetError::Json(e.to_string()))
}

/// Write encoded PNG bytes to `png_path` and JSON bytes beside it (same stem, `.json`), each
/// atomically; when the JSON fails the PNG is removed again.
///
/// # Errors
/// [`DatasetError::Write`]; nothing half-written is left.
pub fn write_png_and_json(png_path: &Path, png: &[u8], json: &[u8]) -> Result<(), DatasetError> {
    write_atomic(png_path, png)?;
    let json_path = png_path.with_extension("json");
    if let Err(e) = write_atomic(&json_path, json) {
        let _ = std::fs::remove_file(png_path);
        return Err(e);
    }
    Ok(())
}

/// Decode an image file (PNG, JPEG) to grey f32 samples (colour is converted with the usual luma
/// weights, as `cv2.cvtColor(..., COLOR_BGR2GRAY)`).
///
/// # Errors
/// [`DatasetError::Read`] for a missing, unreadable, truncated or unsupported file.
pub fn load_grey(path: &Path) -> Result<synthcam_detect::ImageF32, DatasetError> {
    load_grey_u8(path).map(|g| g.to_f32())
}

/// Decode an image file to 8-bit grey (as [`load_grey`], without the conversion to f32).
///
/// # Errors
/// [`DatasetError::Read`] when the file cannot be opened or decoded.
pub fn load_grey_u8(path: &Path) -> Result<synthcam_detect::ImageU8, DatasetError> {
    let err = |reason: String| DatasetError::Read { path: path.display().to_string(), reason };
    let img = image::ImageReader::open(path).map_err(|e| err(e.to_string()))?.with_guessed_format().map_err(|e| err(e.to_string()))?;
    let grey = img.decode().map_err(|e| err(e.to_string()))?.to_luma8();
    let (w, h) = grey.dimensions();
    synthcam_detect::ImageU8::new(w as usize, h as usize, grey.into_raw()).map_err(|e| err(e.to_string()))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn sixteen_bit_png_keeps_its_values() {
        // 0x0102 and 0xfe01 read back byte-swapped (0x0201, 0x01fe) when the encoder is given
        // big-endian bytes on a little-endian machine.
        let raw: Vec<u16> = vec![0x0102, 0xfe01, 0, 65535, 257 * 110, 12345];
        let img = GreyImage::U16(image::ImageBuffer::from_raw(3, 2, raw.clone()).expect("size"));
        let png = encode_png(&img).expect("encode");
        let back = image::load_from_memory(&png).expect("decode").into_luma16();
        assert_eq!(back.into_raw(), raw);
    }
}
