//! Bayer colour filter arrays: which colour each pixel of a sensor sees, and the mosaic of an
//! RGB image through the filter.
//!
//! Reference: B. E. Bayer, "Color imaging array", US patent 3,971,065 (1976); pattern names
//! after the 2 x 2 tile read row by row from the top-left pixel (OpenCV / GenICam `BayerRG` =
//! `rggb`).

use super::{check_len, SensorError};
use std::str::FromStr;

/// A Bayer tile, named by its 2 x 2 colours read row by row from pixel (0, 0).
#[derive(Debug, Clone, Copy, PartialEq, Eq, serde::Serialize, serde::Deserialize)]
pub enum BayerPattern {
    /// `R G / G B`.
    Rggb,
    /// `B G / G R`.
    Bggr,
    /// `G R / B G`.
    Grbg,
    /// `G B / R G`.
    Gbrg,
}

/// Channel indices of [`BayerPattern::channel_at`].
const R: usize = 0;
const G: usize = 1;
const B: usize = 2;

impl BayerPattern {
    /// All patterns.
    pub const ALL: [BayerPattern; 4] = [BayerPattern::Rggb, BayerPattern::Bggr, BayerPattern::Grbg, BayerPattern::Gbrg];

    /// The 2 x 2 tile, `[row][column]`.
    fn tile(self) -> [[usize; 2]; 2] {
        match self {
            BayerPattern::Rggb => [[R, G], [G, B]],
            BayerPattern::Bggr => [[B, G], [G, R]],
            BayerPattern::Grbg => [[G, R], [B, G]],
            BayerPattern::Gbrg => [[G, B], [R, G]],
        }
    }

    /// The colour channel the pixel at column `x`, row `y` sees: 0 red, 1 green, 2 blue.
    pub fn channel_at(self, x: usize, y: usize) -> usize {
        self.tile()[y & 1][x & 1]
    }

    /// The name used in configuration files, e.g. `"bayer-rggb"`.
    pub fn name(self) -> &'static str {
        match self {
            BayerPattern::Rggb => "bayer-rggb",
            BayerPattern::Bggr => "bayer-bggr",
            BayerPattern::Grbg => "bayer-grbg",
            BayerPattern::Gbrg => "bayer-gbrg",
        }
    }
}

impl std::fmt::Display for BayerPattern {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str(self.name())
    }
}

impl FromStr for BayerPattern {
    type Err = SensorError;

    /// Parses `"bayer-rggb"` or `"rggb"` (and the other three), case-insensitive; the error
    /// names the field `output.format`.
    fn from_str(s: &str) -> Result<Self, Self::Err> {
        let lower = s.trim().to_ascii_lowercase();
        let key = lower.strip_prefix("bayer-").unwrap_or(&lower);
        BayerPattern::ALL.into_iter().find(|p| &p.name()["bayer-".len()..] == key).ok_or_else(|| SensorError::InvalidField {
            field: "output.format",
            reason: format!("unknown Bayer pattern `{s}`: expected one of bayer-rggb, bayer-bggr, bayer-grbg, bayer-gbrg"),
        })
    }
}

/// The raw image a Bayer sensor records of a row-major `width x height` RGB image: per pixel
/// the channel [`BayerPattern::channel_at`] picks. Errors when `rgb` does not hold
/// `width * height` pixels.
pub fn mosaic(rgb: &[[f32; 3]], width: usize, height: usize, pattern: BayerPattern) -> Result<Vec<f32>, SensorError> {
    check_len(rgb.len(), width, height)?;
    Ok(rgb.iter().enumerate().map(|(i, px)| px[pattern.channel_at(i % width, i / width)]).collect())
}

/// A grey image as RGB with equal channels: a grey target has the same albedo in each channel.
pub fn grey_to_rgb(grey: &[f32]) -> Vec<[f32; 3]> {
    grey.iter().map(|&g| [g, g, g]).collect()
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Pixel (x, y) of the 3 x 2 test image has R = 10 + i, G = 20 + i, B = 30 + i, i = y*3 + x.
    fn rgb_3x2() -> Vec<[f32; 3]> {
        (0..6).map(|i| [10.0 + i as f32, 20.0 + i as f32, 30.0 + i as f32]).collect()
    }

    #[test]
    fn mosaic_picks_the_pattern_channel() {
        let rgb = rgb_3x2();
        // Hand-written: row 0 is pixels 0, 1, 2; row 1 is 3, 4, 5.
        let cases = [
            (BayerPattern::Rggb, [10.0, 21.0, 12.0, 23.0, 34.0, 25.0]),
            (BayerPattern::Bggr, [30.0, 21.0, 32.0, 23.0, 14.0, 25.0]),
            (BayerPattern::Grbg, [20.0, 11.0, 22.0, 33.0, 24.0, 35.0]),
            (BayerPattern::Gbrg, [20.0, 31.0, 22.0, 13.0, 24.0, 15.0]),
        ];
        for (p, want) in cases {
            assert_eq!(mosaic(&rgb, 3, 2, p).unwrap(), want.to_vec(), "{p}");
        }
        assert!(matches!(mosaic(&rgb, 2, 2, BayerPattern::Rggb), Err(SensorError::Size { got: 6, width: 2, height: 2 })));
        assert!(mosaic(&rgb, usize::MAX, 2, BayerPattern::Rggb).is_err());
    }

    #[test]
    fn channel_at_and_names() {
        assert_eq!([0, 1, 2].map(|x| BayerPattern::Gbrg.channel_at(x, 3)), [R, G, R]);
        assert_eq!(BayerPattern::Grbg.channel_at(1, 0), R);
        for p in BayerPattern::ALL {
            assert_eq!(p.name().parse::<BayerPattern>(), Ok(p));
            assert_eq!(p.name()[6..].to_uppercase().parse::<BayerPattern>(), Ok(p));
            let greens = (0..4).filter(|i| p.channel_at(i % 2, i / 2) == G).count();
            assert_eq!(greens, 2);
        }
        assert_eq!(grey_to_rgb(&[3.0]), vec![[3.0, 3.0, 3.0]]);
    }

    #[test]
    fn from_str_error_names_the_field() {
        let err = "xyz".parse::<BayerPattern>().unwrap_err();
        assert!(matches!(&err, SensorError::InvalidField { field: "output.format", .. }));
        let msg = err.to_string();
        assert!(msg.contains("unknown Bayer pattern `xyz`") && msg.contains("bayer-gbrg"), "{msg}");
        assert!("bayer-".parse::<BayerPattern>().is_err());
        assert!("bayer-rggbx".parse::<BayerPattern>().is_err());
    }
}
