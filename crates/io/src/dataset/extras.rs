//! Extra per-image outputs: depth (`.depth.npy`, float32 metres, NaN where nothing is seen, +inf
//! on a panorama) and instance masks (`.mask.png`, 16-bit: 0 nothing, 1 the target, 2 + i object
//! i, 65535 a background image), both from
//! [`synthcam_scene::depth::depth_mask`].

use std::path::Path;

use super::io::write_atomic;
use super::DatasetError;
use synthcam_scene::depth::DepthMask;

/// NPY (format 1.0) bytes of a row-major `height x width` little-endian float32 array.
///
/// Written by hand: the format is a 10-byte preamble and a Python dict literal
/// (<https://numpy.org/doc/stable/reference/generated/numpy.lib.format.html>); the `npyz` crate
/// would add a parser stack (pest, num-bigint) for these few lines.
pub fn encode_npy_f32(width: u32, height: u32, data: &[f32]) -> Vec<u8> {
    let dict = format!("{{'descr': '<f4', 'fortran_order': False, 'shape': ({height}, {width}), }}");
    // Magic, version, header length, the dict padded with spaces to a 64-byte boundary, '\n'.
    let unpadded = 10 + dict.len() + 1;
    let header_len = unpadded.next_multiple_of(64) - 10;
    let mut out = Vec::with_capacity(10 + header_len + data.len() * 4);
    out.extend_from_slice(b"\x93NUMPY\x01\x00");
    out.extend_from_slice(&(header_len as u16).to_le_bytes());
    out.extend_from_slice(dict.as_bytes());
    out.resize(10 + header_len - 1, b' ');
    out.push(b'\n');
    for v in data {
        out.extend_from_slice(&v.to_le_bytes());
    }
    out
}

/// 16-bit grey PNG bytes of the instance ids.
///
/// # Errors
/// [`DatasetError::Encode`].
pub fn encode_mask_png(m: &DepthMask) -> Result<Vec<u8>, DatasetError> {
    use image::ImageEncoder;
    let mut out = Vec::new();
    let enc = image::codecs::png::PngEncoder::new(&mut out);
    enc.write_image(bytemuck::cast_slice(&m.instance), m.width, m.height, image::ExtendedColorType::L16).map_err(|e| DatasetError::Encode(e.to_string()))?;
    Ok(out)
}

/// Write `stem.depth.npy` and/or `stem.mask.png` beside the image `image_path`.
///
/// # Errors
/// Encoding or writing fails (no partial file is left).
pub fn write_extras(image_path: &Path, m: &DepthMask, depth: bool, mask: bool) -> Result<(), DatasetError> {
    if depth {
        write_atomic(&image_path.with_extension("depth.npy"), &encode_npy_f32(m.width, m.height, &m.depth_m))?;
    }
    if mask {
        write_atomic(&image_path.with_extension("mask.png"), &encode_mask_png(m)?)?;
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn npy_header_is_aligned_and_parsable() {
        let b = encode_npy_f32(3, 2, &[1.0, 2.0, 3.0, 4.0, 5.0, f32::NAN]);
        assert_eq!(&b[..8], b"\x93NUMPY\x01\x00");
        let hl = u16::from_le_bytes([b[8], b[9]]) as usize;
        assert_eq!((10 + hl) % 64, 0);
        let header = std::str::from_utf8(&b[10..10 + hl]).unwrap();
        assert!(header.contains("'shape': (2, 3)") && header.ends_with('\n'), "{header}");
        assert_eq!(b.len(), 10 + hl + 24);
        assert_eq!(f32::from_le_bytes(b[10 + hl + 4..10 + hl + 8].try_into().unwrap()), 2.0);
    }
}
