//! The three ROS 2 messages of synthcam's bags, serialised as CDR, and their `ros2msg` schemas.
//!
//! The CDR encoder is written by hand: the bags hold three fixed message types made of
//! little-endian primitives, strings and sequences, which take ~40 lines here; the `cdr` crate
//! would need serde mirror structs with fixed-array wrappers for the same bytes. The rules (OMG
//! XCDR1 as ROS 2's Fast DDS writes it): a 4-byte encapsulation header `00 01 00 00`
//! (CDR_LE), every primitive aligned to its size counted from the end of that header, strings
//! as a u32 length including the NUL terminator then the bytes and the NUL, sequences as a u32
//! count then the elements, fixed arrays as the bare elements.

use nalgebra::Isometry3;

const SEP: &str = "================================================================================\n";

const HEADER: &str = "MSG: std_msgs/Header\nbuiltin_interfaces/Time stamp\nstring frame_id\n";
const TIME: &str = "MSG: builtin_interfaces/Time\nint32 sec\nuint32 nanosec\n";

/// Schema name of [`image_cdr`].
pub const IMAGE_SCHEMA: &str = "sensor_msgs/msg/Image";
/// Schema name of [`camera_info_cdr`].
pub const CAMERA_INFO_SCHEMA: &str = "sensor_msgs/msg/CameraInfo";
/// Schema name of [`tf_message_cdr`].
pub const TF_SCHEMA: &str = "tf2_msgs/msg/TFMessage";

/// `sensor_msgs/msg/Image`'s definition with its dependencies, as ROS 2 writes it into bags.
pub fn image_definition() -> String {
    format!("std_msgs/Header header\nuint32 height\nuint32 width\nstring encoding\nuint8 is_bigendian\nuint32 step\nuint8[] data\n{SEP}{HEADER}{SEP}{TIME}")
}

/// `sensor_msgs/msg/CameraInfo`'s definition with its dependencies.
pub fn camera_info_definition() -> String {
    let body = "std_msgs/Header header\nuint32 height\nuint32 width\nstring distortion_model\nfloat64[] d\nfloat64[9] k\nfloat64[9] r\nfloat64[12] p\nuint32 binning_x\nuint32 binning_y\nRegionOfInterest roi\n";
    let roi = "MSG: sensor_msgs/RegionOfInterest\nuint32 x_offset\nuint32 y_offset\nuint32 height\nuint32 width\nbool do_rectify\n";
    format!("{body}{SEP}{HEADER}{SEP}{TIME}{SEP}{roi}")
}

/// `tf2_msgs/msg/TFMessage`'s definition with its dependencies.
pub fn tf_message_definition() -> String {
    let stamped = "MSG: geometry_msgs/TransformStamped\nstd_msgs/Header header\nstring child_frame_id\nTransform transform\n";
    let transform = "MSG: geometry_msgs/Transform\nVector3 translation\nQuaternion rotation\n";
    let vector = "MSG: geometry_msgs/Vector3\nfloat64 x\nfloat64 y\nfloat64 z\n";
    let quaternion = "MSG: geometry_msgs/Quaternion\nfloat64 x 0\nfloat64 y 0\nfloat64 z 0\nfloat64 w 1\n";
    format!("geometry_msgs/TransformStamped[] transforms\n{SEP}{stamped}{SEP}{HEADER}{SEP}{TIME}{SEP}{transform}{SEP}{vector}{SEP}{quaternion}")
}

/// A CDR little-endian buffer (see the module docs).
struct Cdr(Vec<u8>);

impl Cdr {
    fn new() -> Self {
        Cdr(vec![0x00, 0x01, 0x00, 0x00])
    }
    fn align(&mut self, n: usize) {
        while !(self.0.len() - 4).is_multiple_of(n) {
            self.0.push(0);
        }
    }
    fn u8(&mut self, v: u8) {
        self.0.push(v);
    }
    fn u32(&mut self, v: u32) {
        self.align(4);
        self.0.extend_from_slice(&v.to_le_bytes());
    }
    fn i32(&mut self, v: i32) {
        self.align(4);
        self.0.extend_from_slice(&v.to_le_bytes());
    }
    fn f64(&mut self, v: f64) {
        self.align(8);
        self.0.extend_from_slice(&v.to_le_bytes());
    }
    fn len(&mut self, n: usize) {
        self.u32(u32::try_from(n).unwrap_or(u32::MAX));
    }
    fn string(&mut self, s: &str) {
        self.len(s.len() + 1);
        self.0.extend_from_slice(s.as_bytes());
        self.0.push(0);
    }
    fn header(&mut self, stamp_ns: u64, frame_id: &str) {
        self.i32(i32::try_from(stamp_ns / 1_000_000_000).unwrap_or(i32::MAX));
        self.u32((stamp_ns % 1_000_000_000) as u32);
        self.string(frame_id);
    }
}

/// A raw image as `sensor_msgs/msg/Image` carries it.
#[derive(Debug, Clone, PartialEq)]
pub struct RawImage {
    /// ROS encoding: `mono8`, `mono16`, `rgb8` or `rgb16`.
    pub encoding: &'static str,
    /// Width, pixels.
    pub width: u32,
    /// Height, pixels.
    pub height: u32,
    /// Bytes per row.
    pub step: u32,
    /// Row-major samples, 16-bit ones little-endian (`is_bigendian` 0).
    pub data: Vec<u8>,
}

/// `sensor_msgs/msg/Image` CDR bytes.
pub fn image_cdr(stamp_ns: u64, frame_id: &str, img: &RawImage) -> Vec<u8> {
    let mut c = Cdr::new();
    c.header(stamp_ns, frame_id);
    c.u32(img.height);
    c.u32(img.width);
    c.string(img.encoding);
    c.u8(0);
    c.u32(img.step);
    c.len(img.data.len());
    c.0.extend_from_slice(&img.data);
    c.0
}

/// The fields of `sensor_msgs/msg/CameraInfo` that synthcam fills.
#[derive(Debug, Clone, PartialEq)]
pub struct CameraInfo {
    /// Width, pixels.
    pub width: u32,
    /// Height, pixels.
    pub height: u32,
    /// `plumb_bob`, `rational_polynomial` or `equidistant`.
    pub distortion_model: &'static str,
    /// Distortion coefficients in that model's order.
    pub d: Vec<f64>,
    /// Intrinsic matrix, row-major, pixels.
    pub k: [f64; 9],
    /// Rectification rotation (identity: a single camera).
    pub r: [f64; 9],
    /// Projection matrix, row-major: `[K | 0]`.
    pub p: [f64; 12],
}

/// `sensor_msgs/msg/CameraInfo` CDR bytes (binning 0, an empty ROI).
pub fn camera_info_cdr(stamp_ns: u64, frame_id: &str, info: &CameraInfo) -> Vec<u8> {
    let mut c = Cdr::new();
    c.header(stamp_ns, frame_id);
    c.u32(info.height);
    c.u32(info.width);
    c.string(info.distortion_model);
    c.len(info.d.len());
    for v in info.d.iter().chain(&info.k).chain(&info.r).chain(&info.p) {
        c.f64(*v);
    }
    for v in [0, 0, 0, 0, 0, 0] {
        c.u32(v);
    }
    c.u8(0);
    c.0
}

/// One transform of a `/tf` message: the pose of `child` in `parent` (`parent_from_child`).
#[derive(Debug, Clone, PartialEq)]
pub struct FrameTransform {
    /// Parent frame id.
    pub parent: String,
    /// Child frame id.
    pub child: String,
    /// `parent_from_child`, metres.
    pub parent_from_child: Isometry3<f64>,
}

/// `tf2_msgs/msg/TFMessage` CDR bytes, every transform stamped `stamp_ns`.
pub fn tf_message_cdr(stamp_ns: u64, transforms: &[FrameTransform]) -> Vec<u8> {
    let mut c = Cdr::new();
    c.len(transforms.len());
    for t in transforms {
        c.header(stamp_ns, &t.parent);
        c.string(&t.child);
        let v = t.parent_from_child.translation.vector;
        let q = t.parent_from_child.rotation;
        for x in [v.x, v.y, v.z, q.i, q.j, q.k, q.w] {
            c.f64(x);
        }
    }
    c.0
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn strings_and_doubles_are_aligned_after_the_encapsulation_header() {
        let mut c = Cdr::new();
        c.u8(1);
        c.f64(2.0);
        c.string("ab");
        assert_eq!(&c.0[..4], &[0, 1, 0, 0]);
        // u8 at 4, padding to 8 + 4 = 12, f64 12..20, u32 length 3 at 20, "ab\0".
        assert_eq!(c.0.len(), 4 + 8 + 8 + 4 + 3);
        assert_eq!(f64::from_le_bytes(c.0[12..20].try_into().unwrap()), 2.0);
        assert_eq!(&c.0[20..], &[3, 0, 0, 0, b'a', b'b', 0]);
    }

    #[test]
    fn definitions_name_every_dependency_once() {
        let tf = tf_message_definition();
        for dep in ["geometry_msgs/TransformStamped", "std_msgs/Header", "builtin_interfaces/Time", "geometry_msgs/Vector3", "geometry_msgs/Quaternion"] {
            assert_eq!(tf.matches(&format!("MSG: {dep}\n")).count(), 1, "{dep}");
        }
        assert!(camera_info_definition().contains("MSG: sensor_msgs/RegionOfInterest\n"));
    }
}
