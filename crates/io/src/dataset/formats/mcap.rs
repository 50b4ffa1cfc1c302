//! ROS 2 bags in MCAP (<https://mcap.dev/spec>): per frame a `sensor_msgs/msg/Image` on
//! `/cam0/image_raw`, a `sensor_msgs/msg/CameraInfo` on `/cam0/camera_info` and a
//! `tf2_msgs/msg/TFMessage` on `/tf` (Kalibr's topic names), all `cdr` with `ros2msg` schemas
//! ([`super::ros2_msgs`]), uncompressed chunks with the usual indexes.

use std::collections::BTreeMap;
use std::io::{Seek, Write};

use ::mcap::records::MessageHeader;
use ::mcap::{McapError, WriteOptions, Writer};

use super::ros2_msgs::{
    camera_info_cdr, camera_info_definition, image_cdr, image_definition, tf_message_cdr, tf_message_definition, CameraInfo, FrameTransform, RawImage,
    CAMERA_INFO_SCHEMA, IMAGE_SCHEMA, TF_SCHEMA,
};
use super::FormatError;
use synthcam_core::camera::formats::ros_camera_info;
use synthcam_render::GreyImage;
use synthcam_scene::file::CameraSpec;

/// The camera's frame id (its optical frame: x right, y down, z forward, as OpenCV's).
pub const CAMERA_FRAME: &str = "cam0";
/// Image topic.
pub const IMAGE_TOPIC: &str = "/cam0/image_raw";
/// Camera-info topic.
pub const CAMERA_INFO_TOPIC: &str = "/cam0/camera_info";
/// Transform topic.
pub const TF_TOPIC: &str = "/tf";

/// One frame of a series.
#[derive(Debug, Clone, PartialEq)]
pub struct SeriesFrame {
    /// Time stamp, nanoseconds.
    pub stamp_ns: u64,
    /// The image.
    pub image: RawImage,
    /// The transforms at this time.
    pub transforms: Vec<FrameTransform>,
}

/// Messages written per topic.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub struct McapCounts {
    /// `/cam0/image_raw`.
    pub images: u64,
    /// `/cam0/camera_info`.
    pub camera_infos: u64,
    /// `/tf`.
    pub tf: u64,
    /// The first message's time stamp, nanoseconds (0 when there is none).
    pub start_ns: u64,
    /// The last message's time stamp, nanoseconds.
    pub end_ns: u64,
}

/// ROS's `CameraInfo` of a synthcam camera ([`synthcam_core::camera::formats::ros_camera_info`], which
/// also writes ROS's camera YAML): `plumb_bob` for OpenCV's model with at most 5 coefficients,
/// `rational_polynomial` with 8, `equidistant` for the fisheye model.
///
/// # Errors
/// [`FormatError::Unsupported`] for the double-sphere model and OpenCV's thin-prism or tilt
/// terms, which `CameraInfo` cannot name, or a camera that is not valid.
pub fn camera_info(cam: &CameraSpec) -> Result<CameraInfo, FormatError> {
    let unsupported = |e: &dyn std::fmt::Display| FormatError::Unsupported { format: "mcap", reason: e.to_string() };
    let info = ros_camera_info(&cam.to_model().map_err(|e| unsupported(&e))?).map_err(|e| unsupported(&e))?;
    let r = [1.0, 0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 1.0];
    Ok(CameraInfo { width: cam.width, height: cam.height, distortion_model: info.distortion_model, d: info.d, k: info.k, r, p: info.p })
}

/// A rendered image as `sensor_msgs/msg/Image` data (`mono8`, `mono16`, `rgb8`, `rgb16`).
pub fn raw_image(img: &GreyImage) -> RawImage {
    let (width, height) = img.dimensions();
    let (encoding, bytes_per_px, data): (&'static str, u32, Vec<u8>) = match img {
        GreyImage::U8(i) => ("mono8", 1, i.as_raw().clone()),
        GreyImage::U16(i) => ("mono16", 2, i.as_raw().iter().flat_map(|v| v.to_le_bytes()).collect()),
        GreyImage::Rgb8(i) => ("rgb8", 3, i.as_raw().clone()),
        GreyImage::Rgb16(i) => ("rgb16", 6, i.as_raw().iter().flat_map(|v| v.to_le_bytes()).collect()),
    };
    RawImage { encoding, width, height, step: width * bytes_per_px, data }
}

/// Decode an encoded image (PNG, JPEG) to `sensor_msgs/msg/Image` data.
///
/// # Errors
/// [`FormatError::Corrupt`] naming `what` when it does not decode.
pub fn decode_raw_image(bytes: &[u8], what: &str) -> Result<RawImage, FormatError> {
    let img = image::load_from_memory(bytes).map_err(|e| FormatError::Corrupt { path: what.to_string(), reason: e.to_string() })?;
    Ok(raw_image(&GreyImage::from(img)))
}

struct Channels {
    image: u16,
    info: u16,
    tf: u16,
}

fn add_channels<W: Write + Seek>(w: &mut Writer<W>) -> Result<Channels, McapError> {
    let meta = BTreeMap::new();
    let mut channel = |schema: &str, definition: String, topic: &str| -> Result<u16, McapError> {
        let id = w.add_schema(schema, "ros2msg", definition.as_bytes())?;
        w.add_channel(id, topic, "cdr", &meta)
    };
    Ok(Channels {
        image: channel(IMAGE_SCHEMA, image_definition(), IMAGE_TOPIC)?,
        info: channel(CAMERA_INFO_SCHEMA, camera_info_definition(), CAMERA_INFO_TOPIC)?,
        tf: channel(TF_SCHEMA, tf_message_definition(), TF_TOPIC)?,
    })
}

/// Write a bag of `frames` seen by `camera` to `w`. `mcap_err` wraps the writer's errors.
///
/// # Errors
/// The first error of `frames`, or the writer's (through `mcap_err`).
pub fn write_series<W, I>(w: W, camera: &CameraInfo, frames: I, mcap_err: &dyn Fn(McapError) -> FormatError) -> Result<McapCounts, FormatError>
where
    W: Write + Seek,
    I: IntoIterator<Item = Result<SeriesFrame, FormatError>>,
{
    let opts = WriteOptions::new().compression(None).profile("ros2").library(concat!("synthcam ", env!("CARGO_PKG_VERSION")));
    let mut writer = opts.create(w).map_err(mcap_err)?;
    let ch = add_channels(&mut writer).map_err(mcap_err)?;
    let mut counts = McapCounts::default();
    for (seq, frame) in frames.into_iter().enumerate() {
        let frame = frame?;
        let seq = u32::try_from(seq).unwrap_or(u32::MAX);
        let t = frame.stamp_ns;
        let mut put =
            |channel_id: u16, data: &[u8]| writer.write_to_known_channel(&MessageHeader { channel_id, sequence: seq, log_time: t, publish_time: t }, data);
        put(ch.tf, &tf_message_cdr(t, &frame.transforms)).map_err(mcap_err)?;
        put(ch.info, &camera_info_cdr(t, CAMERA_FRAME, camera)).map_err(mcap_err)?;
        put(ch.image, &image_cdr(t, CAMERA_FRAME, &frame.image)).map_err(mcap_err)?;
        counts.start_ns = if counts.images == 0 { t } else { counts.start_ns.min(t) };
        counts.end_ns = counts.end_ns.max(t);
        counts.images += 1;
        counts.camera_infos += 1;
        counts.tf += 1;
    }
    writer.finish().map_err(mcap_err)?;
    Ok(counts)
}

#[cfg(test)]
mod tests {
    use super::*;

    fn cam(model: &str, dist: &str) -> CameraSpec {
        toml::from_str(&format!("width = 64\nheight = 48\nfx = 50.0\nfy = 51.0\ncx = 31.5\ncy = 23.5\nmodel = \"{model}\"\n{dist}")).unwrap()
    }

    #[test]
    fn camera_info_names_each_lens_model() {
        let i = camera_info(&cam("opencv", "dist = [0.1, -0.2, 0.001, 0.002]")).unwrap();
        assert_eq!((i.distortion_model, i.d.as_slice()), ("plumb_bob", [0.1, -0.2, 0.001, 0.002, 0.0].as_slice()));
        assert_eq!(i.k, [50.0, 0.0, 31.5, 0.0, 51.0, 23.5, 0.0, 0.0, 1.0]);
        assert_eq!((i.p[2], i.p[6], i.p[10]), (31.5, 23.5, 1.0));
        let i = camera_info(&cam("opencv", "dist = [0.1, -0.2, 0.0, 0.0, 0.01, 0.3, 0.0, 0.0]")).unwrap();
        assert_eq!((i.distortion_model, i.d.len()), ("rational_polynomial", 8));
        let i = camera_info(&cam("fisheye", "dist = [0.1, 0.01, 0.0, 0.0]")).unwrap();
        assert_eq!((i.distortion_model, i.d.as_slice()), ("equidistant", [0.1, 0.01, 0.0, 0.0].as_slice()));
        let e = camera_info(&cam("double-sphere", "xi = -0.2\nalpha = 0.6")).unwrap_err().to_string();
        assert!(e.contains("double-sphere"), "{e}");
        let e = camera_info(&cam("opencv", "dist = [0.1, 0, 0, 0, 0, 0, 0, 0, 0.01, 0, 0, 0]")).unwrap_err().to_string();
        assert!(e.contains("thin-prism"), "{e}");
    }

    #[test]
    fn sixteen_bit_images_are_mono16_little_endian() {
        let img = GreyImage::U16(image::ImageBuffer::from_raw(2, 1, vec![0x0102u16, 0xfffe]).unwrap());
        let raw = raw_image(&img);
        assert_eq!((raw.encoding, raw.step, raw.data.as_slice()), ("mono16", 4, [0x02, 0x01, 0xfe, 0xff].as_slice()));
    }
}
