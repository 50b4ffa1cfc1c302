//! Demosaicing: full RGB from a Bayer raw image, by bilinear interpolation or by the
//! gradient-corrected linear filters of Malvar, He and Cutler.
//!
//! Reference: H. S. Malvar, L. He, R. Cutler, "High-quality linear interpolation for
//! demosaicing of Bayer-patterned color images", ICASSP 2004, Fig. 2 (the 5 x 5 filters, in
//! units of 1/8); ITU-R BT.601 (luma weights).
//!
//! Borders use mirror indexing without repeating the edge pixel (reflect-101: `-1 -> 1`,
//! `W -> W - 2`), which keeps the colour of every mirrored sample, so the filters are defined at
//! every pixel. Images narrower or lower than 2 pixels lack colours; there the mirrored sample is
//! the pixel itself (defined, not meaningful).

use super::{check_len, BayerPattern, SensorError};
use rayon::prelude::*;
use std::str::FromStr;

/// A demosaicing method.
///
/// Measured error `grey_out - grey_in` on grey scenes (equal channels, mosaicked, demosaicked,
/// back to grey by [`rgb_to_grey`]; 96 x 96 pixels; the largest over the four Bayer patterns;
/// `demosaic/tests.rs`), in grey levels:
///
/// | scene | bilinear max / RMS | Malvar-He-Cutler max / RMS |
/// |---|---|---|
/// | constant | 0 (to f32 rounding) | 0 (to f32 rounding) |
/// | step 20 -> 220 (contrast 200), 1 px anti-aliased ramp, slanted 10 deg | 62.1 / 4.09 | 29.3 / 2.17 |
/// | sinusoid 128 + 100 sin, period 16 px, 30 deg | 30.8 / 2.61 | 12.8 / 1.63 |
///
/// **Bounds** (per pixel, on a grey scene): bilinear interpolation is a convex combination of the
/// 3 x 3 neighbourhood, so `|grey_out - grey_in| <=` the neighbourhood's range (max - min).
/// Malvar-He-Cutler's kernels sum to 1 with `sum |w| - w_centre <= 15/8` (R or B at a green
/// pixel; 3/2 for G, 7/4 for R at B), so the error is at most 1.875 times the 5 x 5
/// neighbourhood's range. Checked on a rendered chessboard in `tests/e2e/sensor_effects.rs`
/// (1280 x 1024, contrast 215: bilinear max 93 / RMS 5.1, Malvar max 44 / RMS 2.7 grey levels,
/// no pixel beyond its bound).
///
/// A grey scene is not reproduced exactly at edges: each channel is interpolated from samples at
/// other positions, so the channels disagree (colour fringes) and the luma errs. Pixels whose
/// 5 x 5 neighbourhood is flat are exact for both methods; Malvar-He-Cutler halves the error. Neither method clamps:
/// Malvar's gradient correction over- and undershoots at edges (values outside [0, 255] are
/// possible); callers quantise.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, serde::Serialize, serde::Deserialize)]
#[serde(rename_all = "kebab-case")]
pub enum Demosaic {
    /// 3 x 3 bilinear interpolation of each channel from its own samples.
    #[default]
    Bilinear,
    /// The 5 x 5 gradient-corrected linear filters of Malvar, He and Cutler (2004).
    MalvarHeCutler,
}

impl Demosaic {
    /// The name used in configuration files: `"bilinear"` or `"malvar-he-cutler"`.
    pub fn name(self) -> &'static str {
        match self {
            Demosaic::Bilinear => "bilinear",
            Demosaic::MalvarHeCutler => "malvar-he-cutler",
        }
    }
}

impl FromStr for Demosaic {
    type Err = SensorError;

    /// Parses `"bilinear"`, `"malvar"` or `"malvar-he-cutler"`, case-insensitive; the error
    /// names the field `output.demosaic`.
    fn from_str(s: &str) -> Result<Self, Self::Err> {
        match s.trim().to_ascii_lowercase().as_str() {
            "bilinear" => Ok(Demosaic::Bilinear),
            "malvar" | "malvar-he-cutler" => Ok(Demosaic::MalvarHeCutler),
            _ => Err(SensorError::InvalidField {
                field: "output.demosaic",
                reason: format!("unknown demosaicing method `{s}`: expected one of bilinear, malvar, malvar-he-cutler"),
            }),
        }
    }
}

/// A filter tap: column offset, row offset, weight.
type Tap = (isize, isize, f32);

/// Bilinear: green at a red / blue pixel.
const BI_CROSS: &[Tap] = &[(0, -1, 0.25), (-1, 0, 0.25), (1, 0, 0.25), (0, 1, 0.25)];
/// Bilinear: the colour of the left and right neighbours at a green pixel.
const BI_HORIZONTAL: &[Tap] = &[(-1, 0, 0.5), (1, 0, 0.5)];
/// Bilinear: the colour of the upper and lower neighbours at a green pixel.
const BI_VERTICAL: &[Tap] = &[(0, -1, 0.5), (0, 1, 0.5)];
/// Bilinear: red at blue / blue at red.
const BI_DIAGONAL: &[Tap] = &[(-1, -1, 0.25), (1, -1, 0.25), (-1, 1, 0.25), (1, 1, 0.25)];

/// Malvar-He-Cutler "G at R locations" (also G at B): `[4 centre, 2 at distance 1, -1 at
/// distance 2 along rows and columns] / 8`.
#[rustfmt::skip]
const MHC_CROSS: &[Tap] = &[
    (0, 0, 0.5),
    (0, -1, 0.25), (-1, 0, 0.25), (1, 0, 0.25), (0, 1, 0.25),
    (0, -2, -0.125), (-2, 0, -0.125), (2, 0, -0.125), (0, 2, -0.125),
];
/// Malvar-He-Cutler "R at green in R row, B column" (the wanted colour left and right):
/// `[5 centre, 4 left/right, -1 at +-2 columns, 1/2 at +-2 rows, -1 diagonal] / 8`.
#[rustfmt::skip]
const MHC_HORIZONTAL: &[Tap] = &[
    (0, 0, 0.625),
    (-1, 0, 0.5), (1, 0, 0.5), (-2, 0, -0.125), (2, 0, -0.125),
    (0, -2, 0.0625), (0, 2, 0.0625),
    (-1, -1, -0.125), (1, -1, -0.125), (-1, 1, -0.125), (1, 1, -0.125),
];
/// Malvar-He-Cutler "R at green in B row, R column" (the wanted colour above and below): the
/// transpose of [`MHC_HORIZONTAL`].
#[rustfmt::skip]
const MHC_VERTICAL: &[Tap] = &[
    (0, 0, 0.625),
    (0, -1, 0.5), (0, 1, 0.5), (0, -2, -0.125), (0, 2, -0.125),
    (-2, 0, 0.0625), (2, 0, 0.0625),
    (-1, -1, -0.125), (1, -1, -0.125), (-1, 1, -0.125), (1, 1, -0.125),
];
/// Malvar-He-Cutler "R at blue in B row, B column" (also B at R): `[6 centre, 2 diagonal,
/// -3/2 at distance 2 along rows and columns] / 8`.
#[rustfmt::skip]
const MHC_DIAGONAL: &[Tap] = &[
    (0, 0, 0.75),
    (-1, -1, 0.25), (1, -1, 0.25), (-1, 1, 0.25), (1, 1, 0.25),
    (0, -2, -0.1875), (-2, 0, -0.1875), (2, 0, -0.1875), (0, 2, -0.1875),
];

/// Mirror index without repeating the edge (reflect-101); any `i` maps into `0..n` (`n >= 1`).
fn reflect(i: isize, n: usize) -> usize {
    if n <= 1 {
        return 0;
    }
    let n = n as isize;
    let period = 2 * (n - 1);
    let m = i.rem_euclid(period);
    (if m >= n { period - m } else { m }) as usize
}

/// The filter that estimates channel `want` at pixel (x, y), whose own channel is `own`.
fn filter(method: Demosaic, pattern: BayerPattern, x: usize, y: usize, own: usize, want: usize) -> &'static [Tap] {
    let bi = method == Demosaic::Bilinear;
    if want == 1 {
        if bi {
            BI_CROSS
        } else {
            MHC_CROSS
        }
    } else if own != 1 {
        if bi {
            BI_DIAGONAL
        } else {
            MHC_DIAGONAL
        }
    } else if pattern.channel_at(x + 1, y) == want {
        if bi {
            BI_HORIZONTAL
        } else {
            MHC_HORIZONTAL
        }
    } else if bi {
        BI_VERTICAL
    } else {
        MHC_VERTICAL
    }
}

/// Full RGB from a row-major `width x height` Bayer raw image: each pixel keeps its own sample
/// and interpolates the two missing channels with `method`'s filters (mirror borders). Values
/// are not clamped. Errors when `raw` does not hold `width * height` values.
pub fn demosaic(raw: &[f32], width: usize, height: usize, pattern: BayerPattern, method: Demosaic) -> Result<Vec<[f32; 3]>, SensorError> {
    let n = check_len(raw.len(), width, height)?;
    let mut out = vec![[0.0f32; 3]; n];
    if n == 0 {
        return Ok(out);
    }
    out.par_chunks_mut(width).enumerate().for_each(|(y, row)| {
        for (x, px) in row.iter_mut().enumerate() {
            let own = pattern.channel_at(x, y);
            for (c, v) in px.iter_mut().enumerate() {
                *v = if c == own {
                    raw[y * width + x]
                } else {
                    filter(method, pattern, x, y, own, c)
                        .iter()
                        .map(|&(dx, dy, w)| w * raw[reflect(y as isize + dy, height) * width + reflect(x as isize + dx, width)])
                        .sum()
                };
            }
        }
    });
    Ok(out)
}

/// The ITU-R BT.601 luma weights of R, G and B.
pub const LUMA_BT601: [f64; 3] = [0.299, 0.587, 0.114];

/// The BT.601 luma of one RGB value, in its own units.
pub fn luma(rgb: [f64; 3]) -> f64 {
    LUMA_BT601[0] * rgb[0] + LUMA_BT601[1] * rgb[1] + LUMA_BT601[2] * rgb[2]
}

/// Grey from RGB by the ITU-R BT.601 luma weights: `0.299 R + 0.587 G + 0.114 B` (equal
/// channels give the same grey, to f32 rounding).
pub fn rgb_to_grey(rgb: &[[f32; 3]]) -> Vec<f32> {
    rgb.iter().map(|p| luma(p.map(f64::from)) as f32).collect()
}

#[cfg(test)]
mod tests;
