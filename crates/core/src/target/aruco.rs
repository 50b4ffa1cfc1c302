//! The marker dictionaries of coded boards: every predefined OpenCV dictionary (`cv::aruco`
//! `DICT_4X4_50` ... `DICT_7X7_1000`, `DICT_ARUCO_ORIGINAL`, the AprilTag families 16h5, 25h9,
//! 36h10, 36h11, and `DICT_ARUCO_MIP_36h12`), with their codes and error-correction capacity.
//!
//! The code tables are data, embedded from `assets/aruco/*.bits` (written by
//! `assets/aruco/generate.py` from OpenCV's `predefined_dictionaries.hpp`, Apache-2.0; the
//! AprilTag families there come from the AprilTag library, BSD-2-Clause). Each smaller OpenCV
//! dictionary is a prefix of the largest of its marker size (checked against OpenCV when the
//! tables were written), so one table serves `DICT_4X4_50` ... `DICT_4X4_1000`; only the
//! correction capacity differs ([`Dictionary::max_correction_bits`], OpenCV's
//! `maxCorrectionBits`).
//!
//! A code is the marker's `n x n` inner bits, row-major from the top-left (its image as
//! `cv::aruco::generateImageMarker` draws it, without the black border), `true` = white.

use super::TargetError;

/// One code table: marker size (bits per side), marker count, packed bits.
struct Table {
    bits: usize,
    count: usize,
    data: &'static [u8],
}

const T4X4: Table = Table { bits: 4, count: 1000, data: include_bytes!("../../assets/aruco/DICT_4X4_1000.bits") };
const T5X5: Table = Table { bits: 5, count: 1000, data: include_bytes!("../../assets/aruco/DICT_5X5_1000.bits") };
const T6X6: Table = Table { bits: 6, count: 1000, data: include_bytes!("../../assets/aruco/DICT_6X6_1000.bits") };
const T7X7: Table = Table { bits: 7, count: 1000, data: include_bytes!("../../assets/aruco/DICT_7X7_1000.bits") };
const ORIGINAL: Table = Table { bits: 5, count: 1024, data: include_bytes!("../../assets/aruco/DICT_ARUCO_ORIGINAL.bits") };
const TAG16H5: Table = Table { bits: 4, count: 30, data: include_bytes!("../../assets/aruco/DICT_APRILTAG_16h5.bits") };
const TAG25H9: Table = Table { bits: 5, count: 35, data: include_bytes!("../../assets/aruco/DICT_APRILTAG_25h9.bits") };
const TAG36H10: Table = Table { bits: 6, count: 2320, data: include_bytes!("../../assets/aruco/DICT_APRILTAG_36h10.bits") };
const TAG36H11: Table = Table { bits: 6, count: 587, data: include_bytes!("../../assets/aruco/DICT_APRILTAG_36h11.bits") };
const MIP36H12: Table = Table { bits: 6, count: 250, data: include_bytes!("../../assets/aruco/DICT_ARUCO_MIP_36h12.bits") };

/// A predefined marker dictionary (OpenCV's `cv::aruco::PredefinedDictionaryType`).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
#[allow(non_camel_case_types)] // OpenCV's names, so that users recognise them.
pub enum Dictionary {
    /// `DICT_4X4_50`.
    Dict4x4_50,
    /// `DICT_4X4_100`.
    Dict4x4_100,
    /// `DICT_4X4_250`.
    Dict4x4_250,
    /// `DICT_4X4_1000`.
    Dict4x4_1000,
    /// `DICT_5X5_50`.
    Dict5x5_50,
    /// `DICT_5X5_100`.
    Dict5x5_100,
    /// `DICT_5X5_250`.
    Dict5x5_250,
    /// `DICT_5X5_1000`.
    Dict5x5_1000,
    /// `DICT_6X6_50`.
    Dict6x6_50,
    /// `DICT_6X6_100`.
    Dict6x6_100,
    /// `DICT_6X6_250`.
    Dict6x6_250,
    /// `DICT_6X6_1000`.
    Dict6x6_1000,
    /// `DICT_7X7_50`.
    Dict7x7_50,
    /// `DICT_7X7_100`.
    Dict7x7_100,
    /// `DICT_7X7_250`.
    Dict7x7_250,
    /// `DICT_7X7_1000`.
    Dict7x7_1000,
    /// `DICT_ARUCO_ORIGINAL`.
    ArucoOriginal,
    /// `DICT_APRILTAG_16h5`.
    AprilTag16h5,
    /// `DICT_APRILTAG_25h9`.
    AprilTag25h9,
    /// `DICT_APRILTAG_36h10`.
    AprilTag36h10,
    /// `DICT_APRILTAG_36h11`.
    AprilTag36h11,
    /// `DICT_ARUCO_MIP_36h12`.
    ArucoMip36h12,
}

/// Every dictionary, with its OpenCV name, marker count and `maxCorrectionBits` (OpenCV 5.1).
const ALL: [(Dictionary, &str, usize, u32); 22] = [
    (Dictionary::Dict4x4_50, "DICT_4X4_50", 50, 1),
    (Dictionary::Dict4x4_100, "DICT_4X4_100", 100, 1),
    (Dictionary::Dict4x4_250, "DICT_4X4_250", 250, 1),
    (Dictionary::Dict4x4_1000, "DICT_4X4_1000", 1000, 0),
    (Dictionary::Dict5x5_50, "DICT_5X5_50", 50, 3),
    (Dictionary::Dict5x5_100, "DICT_5X5_100", 100, 3),
    (Dictionary::Dict5x5_250, "DICT_5X5_250", 250, 2),
    (Dictionary::Dict5x5_1000, "DICT_5X5_1000", 1000, 2),
    (Dictionary::Dict6x6_50, "DICT_6X6_50", 50, 6),
    (Dictionary::Dict6x6_100, "DICT_6X6_100", 100, 5),
    (Dictionary::Dict6x6_250, "DICT_6X6_250", 250, 5),
    (Dictionary::Dict6x6_1000, "DICT_6X6_1000", 1000, 4),
    (Dictionary::Dict7x7_50, "DICT_7X7_50", 50, 9),
    (Dictionary::Dict7x7_100, "DICT_7X7_100", 100, 8),
    (Dictionary::Dict7x7_250, "DICT_7X7_250", 250, 8),
    (Dictionary::Dict7x7_1000, "DICT_7X7_1000", 1000, 6),
    (Dictionary::ArucoOriginal, "DICT_ARUCO_ORIGINAL", 1024, 1),
    (Dictionary::AprilTag16h5, "DICT_APRILTAG_16h5", 30, 2),
    (Dictionary::AprilTag25h9, "DICT_APRILTAG_25h9", 35, 4),
    (Dictionary::AprilTag36h10, "DICT_APRILTAG_36h10", 2320, 4),
    (Dictionary::AprilTag36h11, "DICT_APRILTAG_36h11", 587, 5),
    (Dictionary::ArucoMip36h12, "DICT_ARUCO_MIP_36h12", 250, 5),
];

impl Dictionary {
    /// Every predefined dictionary.
    pub fn all() -> impl Iterator<Item = Dictionary> {
        ALL.iter().map(|e| e.0)
    }

    fn entry(self) -> &'static (Dictionary, &'static str, usize, u32) {
        // ALL lists every variant once (unit test), so the search always succeeds; the first
        // entry is only a formal fallback.
        ALL.iter().find(|e| e.0 == self).unwrap_or(&ALL[0])
    }

    fn table(self) -> &'static Table {
        use Dictionary::*;
        match self {
            Dict4x4_50 | Dict4x4_100 | Dict4x4_250 | Dict4x4_1000 => &T4X4,
            Dict5x5_50 | Dict5x5_100 | Dict5x5_250 | Dict5x5_1000 => &T5X5,
            Dict6x6_50 | Dict6x6_100 | Dict6x6_250 | Dict6x6_1000 => &T6X6,
            Dict7x7_50 | Dict7x7_100 | Dict7x7_250 | Dict7x7_1000 => &T7X7,
            ArucoOriginal => &ORIGINAL,
            AprilTag16h5 => &TAG16H5,
            AprilTag25h9 => &TAG25H9,
            AprilTag36h10 => &TAG36H10,
            AprilTag36h11 => &TAG36H11,
            ArucoMip36h12 => &MIP36H12,
        }
    }

    /// OpenCV's name, e.g. `"DICT_5X5_100"`.
    pub fn name(self) -> &'static str {
        self.entry().1
    }

    /// The dictionary of an OpenCV name (case-insensitive, `DICT_` prefix optional).
    ///
    /// # Errors
    /// [`TargetError::InvalidField`] (`dictionary`) naming the choices.
    pub fn from_name(name: &str) -> Result<Self, TargetError> {
        let want = name.trim().to_ascii_uppercase();
        let want = if want.starts_with("DICT_") { want } else { format!("DICT_{want}") };
        ALL.iter().find(|e| e.1.to_ascii_uppercase() == want).map(|e| e.0).ok_or_else(|| TargetError::InvalidField {
            field: "dictionary",
            reason: format!("unknown dictionary {name:?}; one of {}", ALL.iter().map(|e| e.1).collect::<Vec<_>>().join(", ")),
        })
    }

    /// Bits per marker side (4 for `DICT_4X4_*`).
    pub fn marker_bits(self) -> usize {
        self.table().bits
    }

    /// Number of markers.
    pub fn len(self) -> usize {
        self.entry().2
    }

    /// Always false: every dictionary has markers (for clippy's `len` convention).
    pub fn is_empty(self) -> bool {
        false
    }

    /// How many wrong bits a detector may correct (OpenCV's `maxCorrectionBits`).
    pub fn max_correction_bits(self) -> u32 {
        self.entry().3
    }

    /// Marker `id`'s code: `marker_bits()^2` bits row-major, `true` = white; `None` past the
    /// dictionary's end.
    pub fn code(self, id: usize) -> Option<Vec<bool>> {
        let t = self.table();
        if id >= self.len() || id >= t.count {
            return None;
        }
        let n = t.bits * t.bits;
        let per = n.div_ceil(8);
        let bytes = t.data.get(id * per..(id + 1) * per)?;
        Some((0..n).map(|k| bytes[k / 8] & (0x80 >> (k % 8)) != 0).collect())
    }
}

/// Scene files name a dictionary as OpenCV does (`"DICT_5X5_100"`, see [`Dictionary::from_name`]).
impl<'de> serde::Deserialize<'de> for Dictionary {
    fn deserialize<D: serde::Deserializer<'de>>(d: D) -> Result<Self, D::Error> {
        let name = String::deserialize(d)?;
        Dictionary::from_name(&name).map_err(serde::de::Error::custom)
    }
}

impl serde::Serialize for Dictionary {
    fn serialize<S: serde::Serializer>(&self, s: S) -> Result<S::Ok, S::Error> {
        s.serialize_str(self.name())
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn bits(s: &str) -> Vec<bool> {
        s.bytes().map(|b| b == b'1').collect()
    }

    #[test]
    fn codes_match_opencv_generate_image_marker() {
        // cv2.aruco.generateImageMarker(dict, id, n + 2)[1:-1, 1:-1] > 127, OpenCV 5.1.0.
        let cases = [
            (Dictionary::Dict4x4_50, 0, "1011010100110010"),
            (Dictionary::Dict6x6_250, 249, "011100000011110100111000101001100000"),
            (Dictionary::AprilTag36h11, 586, "110011101101001001111101110000010111"),
            (Dictionary::ArucoOriginal, 1023, "0111001110011100111001110"),
            (Dictionary::Dict7x7_1000, 999, "1110011111100110100101101110001000000110100111111"),
            (Dictionary::AprilTag16h5, 29, "0111010011110101"),
        ];
        for (d, id, expect) in cases {
            assert_eq!(d.code(id), Some(bits(expect)), "{} id {id}", d.name());
        }
        assert_eq!(Dictionary::Dict4x4_50.code(50), None);
        assert_eq!(Dictionary::AprilTag36h11.code(587), None);
    }

    #[test]
    fn every_table_holds_its_markers_and_names_round_trip() {
        assert_eq!(Dictionary::all().count(), 22);
        for d in Dictionary::all() {
            let t = d.table();
            assert_eq!(t.data.len(), t.count * (t.bits * t.bits).div_ceil(8), "{}", d.name());
            assert!(d.len() <= t.count);
            assert!(d.code(d.len() - 1).is_some());
            assert_eq!(Dictionary::from_name(d.name()), Ok(d));
            assert_eq!(d.entry().0, d);
        }
        assert_eq!(Dictionary::from_name("5x5_100"), Ok(Dictionary::Dict5x5_100));
        assert_eq!(Dictionary::from_name("dict_apriltag_36H11"), Ok(Dictionary::AprilTag36h11));
        let e = Dictionary::from_name("DICT_9X9_1").unwrap_err().to_string();
        assert!(e.contains("dictionary") && e.contains("DICT_APRILTAG_36h11"), "{e}");
    }
}
