//! Reading the camera files of [`super`] back. OpenCV's `%YAML:1.0` header and `!!opencv-matrix`
//! tags are not YAML a general parser accepts, and mrcal's file is a Python literal, so the
//! reader looks the few keys up itself (keys and flow lists `[a, b, ...]`, as these formats write
//! them).

use super::CameraFileError;
use crate::camera::{CameraModel, Distortion, DoubleSphere, Fisheye, ImageSize, Intrinsics, Lens};

fn parse_err(what: impl Into<String>) -> CameraFileError {
    CameraFileError::Parse(what.into())
}

/// The text after `key` up to the end of its line, unquoted.
fn scalar<'a>(text: &'a str, key: &str) -> Option<&'a str> {
    let i = text.find(key)? + key.len();
    let rest = text[i..].trim_start_matches(['\'', '"', ':', ' ']);
    Some(rest.lines().next()?.trim().trim_matches(['\'', '"', ','].as_ref()).trim())
}

/// The first flow list `[...]` after `key`.
fn numbers(text: &str, key: &str) -> Result<Vec<f64>, CameraFileError> {
    let i = text.find(key).ok_or_else(|| parse_err(format!("no `{key}`")))?;
    let open = text[i..].find('[').ok_or_else(|| parse_err(format!("`{key}` has no list")))? + i + 1;
    let close = text[open..].find(']').ok_or_else(|| parse_err(format!("`{key}`: unclosed list")))? + open;
    let body = text[open..close].trim();
    if body.is_empty() {
        return Ok(Vec::new());
    }
    body.split(',').map(|v| v.trim().parse::<f64>().map_err(|e| parse_err(format!("`{key}`: {v:?}: {e}")))).collect()
}

fn uint(text: &str, key: &str) -> Result<u32, CameraFileError> {
    let v = scalar(text, key).ok_or_else(|| parse_err(format!("no `{key}`")))?;
    v.parse().map_err(|e| parse_err(format!("`{key}`: {v:?}: {e}")))
}

fn from_k(size: ImageSize, k: &[f64], lens: Lens) -> Result<CameraModel, CameraFileError> {
    if k.len() != 9 {
        return Err(parse_err(format!("camera_matrix has {} values, not 9", k.len())));
    }
    let cam = CameraModel { size, intrinsics: Intrinsics { fx: k[0], skew: k[1], cx: k[2], fy: k[4], cy: k[5] }, lens };
    cam.validate()?;
    Ok(cam)
}

fn opencv(text: &str) -> Result<CameraModel, CameraFileError> {
    let size = ImageSize { width: uint(text, "image_width")?, height: uint(text, "image_height")? };
    let d = numbers(text, "distortion_coefficients")?;
    let lens = match scalar(text, "model:") {
        Some("fisheye") => Lens::Fisheye(Fisheye { k: d.as_slice().try_into().map_err(|_| parse_err("a fisheye D has 4 values"))? }),
        _ => Lens::OpenCv(Distortion::from_opencv(&d)?),
    };
    from_k(size, &numbers(text, "camera_matrix")?, lens)
}

fn ros(text: &str) -> Result<CameraModel, CameraFileError> {
    let size = ImageSize { width: uint(text, "image_width")?, height: uint(text, "image_height")? };
    let d = numbers(text, "distortion_coefficients")?;
    let lens = match scalar(text, "distortion_model") {
        Some("plumb_bob" | "rational_polynomial") => Lens::OpenCv(Distortion::from_opencv(&d)?),
        Some("equidistant") => Lens::Fisheye(Fisheye { k: d.as_slice().try_into().map_err(|_| parse_err("equidistant has 4 values"))? }),
        other => return Err(parse_err(format!("unknown ROS distortion_model {other:?}"))),
    };
    from_k(size, &numbers(text, "camera_matrix")?, lens)
}

fn kalibr(text: &str) -> Result<CameraModel, CameraFileError> {
    let r = numbers(text, "resolution")?;
    let [w, h] = r.as_slice() else { return Err(parse_err("resolution is not [w, h]")) };
    let size = ImageSize { width: *w as u32, height: *h as u32 };
    let i = numbers(text, "intrinsics")?;
    let d = numbers(text, "distortion_coeffs")?;
    let (k, lens) = match (scalar(text, "camera_model"), scalar(text, "distortion_model"), i.len()) {
        (Some("pinhole"), Some("radtan"), 4) => (&i[..], Lens::OpenCv(Distortion::from_opencv(&d)?)),
        (Some("pinhole"), Some("equidistant"), 4) => {
            (&i[..], Lens::Fisheye(Fisheye { k: d.as_slice().try_into().map_err(|_| parse_err("equidistant has 4 values"))? }))
        }
        (Some("ds"), Some("none"), 6) => (&i[2..], Lens::DoubleSphere(DoubleSphere { xi: i[0], alpha: i[1] })),
        (m, dm, n) => return Err(parse_err(format!("unsupported Kalibr camera {m:?}-{dm:?} with {n} intrinsics"))),
    };
    from_k(size, &[k[0], 0.0, k[2], 0.0, k[1], k[3], 0.0, 0.0, 1.0], lens)
}

fn mrcal(text: &str) -> Result<CameraModel, CameraFileError> {
    let r = numbers(text, "'imagersize'")?;
    let [w, h] = r.as_slice() else { return Err(parse_err("imagersize is not [w, h]")) };
    let size = ImageSize { width: *w as u32, height: *h as u32 };
    let i = numbers(text, "'intrinsics'")?;
    let model = scalar(text, "'lensmodel'").unwrap_or_default();
    let n: usize =
        model.strip_prefix("LENSMODEL_OPENCV").and_then(|n| n.parse().ok()).ok_or_else(|| parse_err(format!("unsupported mrcal lens model {model:?}")))?;
    if i.len() != 4 + n {
        return Err(parse_err(format!("{model} has {} intrinsics, not {}", i.len(), 4 + n)));
    }
    from_k(size, &[i[0], 0.0, i[2], 0.0, i[1], i[3], 0.0, 0.0, 1.0], Lens::OpenCv(Distortion::from_opencv(&i[4..])?))
}

/// Read any camera file written by [`super`]'s writers (told apart by their keys).
///
/// # Errors
/// [`CameraFileError::Parse`] for text of none of the formats or a missing key;
/// [`CameraFileError::Camera`] for an invalid camera.
pub fn read(text: &str) -> Result<CameraModel, CameraFileError> {
    if text.contains("'lensmodel'") {
        mrcal(text)
    } else if text.contains("camera_model:") {
        kalibr(text)
    } else if text.trim_start().starts_with("%YAML") {
        opencv(text)
    } else if text.contains("distortion_model:") {
        ros(text)
    } else {
        Err(parse_err("neither OpenCV, ROS, Kalibr nor mrcal keys found"))
    }
}
