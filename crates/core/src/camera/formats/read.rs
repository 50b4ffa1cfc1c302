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

/// Read a Kalibr camchain (as [`super::kalibr_camchain`] writes it, or Kalibr's own
/// `camchain-*.yaml`): each `camN:` block's camera by its fields (`camera_model`, `intrinsics`,
/// `distortion_model`, `distortion_coeffs`, `resolution`) and `cam0_from_camN`, chained from the
/// blocks' `T_cn_cnm1` (`camN_from_cam(N-1)`; identity for `cam0`). Other keys (`rostopic`,
/// `cam_overlaps`, `timeshift_cam_imu`) are ignored.
///
/// # Errors
/// [`CameraFileError::Parse`] for no `cam0:` block, a block out of order, or a `T_cn_cnm1` that
/// is not 4 rows of 4 numbers with a rotation in its top-left 3 x 3; as [`read`] per camera.
pub fn read_camchain(text: &str) -> Result<Vec<(CameraModel, nalgebra::Isometry3<f64>)>, CameraFileError> {
    let mut blocks: Vec<(&str, String)> = Vec::new();
    for line in text.lines() {
        match line.strip_suffix(':').filter(|l| l.starts_with("cam") && !l.starts_with(' ')) {
            Some(name) => blocks.push((name, String::new())),
            None => {
                if let Some((_, body)) = blocks.last_mut() {
                    body.push_str(line);
                    body.push('\n');
                }
            }
        }
    }
    if blocks.is_empty() {
        return Err(parse_err("no cam0: block"));
    }
    let mut out: Vec<(CameraModel, nalgebra::Isometry3<f64>)> = Vec::with_capacity(blocks.len());
    for (n, (name, body)) in blocks.iter().enumerate() {
        if *name != format!("cam{n}") {
            return Err(parse_err(format!("expected cam{n}:, found {name}:")));
        }
        let cam = kalibr(body)?;
        let cam0_from_cam = match out.last() {
            None => nalgebra::Isometry3::identity(),
            Some((_, cam0_from_prev)) => cam0_from_prev * transform_rows(body)?.inverse(),
        };
        out.push((cam, cam0_from_cam));
    }
    Ok(out)
}

/// `T_cn_cnm1`'s four rows `  - [a, b, c, d]` as an isometry.
fn transform_rows(body: &str) -> Result<nalgebra::Isometry3<f64>, CameraFileError> {
    let rows: Vec<Vec<f64>> = body
        .split("T_cn_cnm1:")
        .nth(1)
        .ok_or_else(|| parse_err("a camera after cam0 has no T_cn_cnm1"))?
        .lines()
        .skip(1)
        .take_while(|l| l.trim_start().starts_with("- ["))
        .map(|l| l.trim().trim_start_matches("- [").trim_end_matches(']').split(',').map(|v| v.trim().parse::<f64>()).collect::<Result<Vec<_>, _>>())
        .collect::<Result<_, _>>()
        .map_err(|e| parse_err(format!("T_cn_cnm1: {e}")))?;
    if rows.len() != 4 || rows.iter().any(|r| r.len() != 4) {
        return Err(parse_err("T_cn_cnm1 is not 4 rows of 4 numbers"));
    }
    let m = nalgebra::Matrix3::from_fn(|i, j| rows[i][j]);
    if !((m.transpose() * m - nalgebra::Matrix3::identity()).abs().max() < 1e-6 && m.determinant() > 0.0) {
        return Err(parse_err("T_cn_cnm1's rotation is not a rotation"));
    }
    let rot = nalgebra::UnitQuaternion::from_matrix(&m);
    Ok(nalgebra::Isometry3::from_parts(nalgebra::Translation3::new(rows[0][3], rows[1][3], rows[2][3]), rot))
}
