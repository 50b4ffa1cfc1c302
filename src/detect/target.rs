//! One entry point for every target: parse a target description ("chessboard:9x6",
//! "dot-grid:3x3", "s-path") and detect it in an image.

use std::str::FromStr;

use nalgebra::Point2;

use super::chessboard::{find_chessboard, find_chessboard_u8, ChessboardCorners, ChessboardParams};
use super::dots::{find_dots, DotParams};
use super::grid_order::order_grid;
use super::s_path_fit::{index_s_path, path_residuals, unmeasured, PathResidual, SPathFitParams};
use super::{DetectError, ImageF32, ImageU8};
use crate::target::s_path::{build_s_path, course_planar_s};
use crate::target::{course_s_path, SPath};

/// What to look for.
#[derive(Debug, Clone, Copy, PartialEq, Eq, serde::Serialize)]
#[serde(tag = "kind", rename_all = "kebab-case")]
pub enum TargetSpec {
    /// A chessboard of `cols x rows` inner corners.
    Chessboard {
        /// Inner corners per row.
        cols: usize,
        /// Rows of inner corners.
        rows: usize,
    },
    /// An `n x n` dot grid.
    DotGrid {
        /// Dots per side.
        n: usize,
    },
    /// The S-path dots.
    SPath {
        /// Points on the path.
        points: usize,
    },
}

impl TargetSpec {
    /// What to look for on `target`: its grid size, or the S-path's point count.
    pub fn for_target(target: &crate::target::Target) -> Self {
        use crate::target::Target;
        match target {
            Target::Chessboard(b) => TargetSpec::Chessboard { cols: b.inner_corner_count()[0] as usize, rows: b.inner_corner_count()[1] as usize },
            Target::DotGrid(g) => TargetSpec::DotGrid { n: g.n as usize },
            Target::SPath(s) => TargetSpec::SPath { points: s.path.points_m.len() },
        }
    }
}

impl FromStr for TargetSpec {
    type Err = String;

    fn from_str(s: &str) -> Result<Self, Self::Err> {
        let dims = |d: &str| -> Result<(usize, usize), String> {
            let (a, b) = d.split_once(['x', 'X']).ok_or_else(|| format!("expected AxB, got `{d}`"))?;
            let a: usize = a.trim().parse().map_err(|_| format!("`{a}` is not a count"))?;
            let b: usize = b.trim().parse().map_err(|_| format!("`{b}` is not a count"))?;
            if a < 2 || b < 2 || a > 1000 || b > 1000 {
                return Err(format!("{a}x{b}: each count must be in 2..=1000"));
            }
            Ok((a, b))
        };
        match s.split_once(':') {
            Some(("chessboard", d)) => dims(d).map(|(cols, rows)| TargetSpec::Chessboard { cols, rows }),
            Some(("dot-grid", d)) => match dims(d)? {
                (a, b) if a == b => Ok(TargetSpec::DotGrid { n: a }),
                (a, b) => Err(format!("dot-grid must be square, got {a}x{b}")),
            },
            None if s == "s-path" => Ok(TargetSpec::SPath { points: 101 }),
            _ => Err(format!("unknown target `{s}` (chessboard:COLSxROWS, dot-grid:NxN, s-path)")),
        }
    }
}

/// What was found.
#[derive(Debug, Clone, PartialEq, Default)]
pub struct Detection {
    /// Whether the target was found.
    pub found: bool,
    /// Points in the target's order (for the S-path: the visible dots, see `indices`).
    pub points_px: Vec<Point2<f64>>,
    /// S-path: the path index of each point.
    pub indices: Option<Vec<usize>>,
    /// S-path: each point's residual against the fit of the whole nominal path
    /// ([`super::s_path_fit::path_residuals`]).
    pub path_residuals: Option<Vec<PathResidual>>,
    /// S-path: the path indices of dots that helped to order the rest but are not reported,
    /// their centres not being measurements (`Dot::touching`: two slivers meeting end to end; two caps seen as one blob).
    pub unmeasured: Option<Vec<usize>>,
    /// Why it was not found, when it was not.
    pub note: Option<String>,
}

/// Detect `spec` in `img`.
///
/// # Errors
/// Bad image buffers; "not found" is `Ok` with `found: false`.
pub fn detect(img: &ImageF32, spec: &TargetSpec) -> Result<Detection, DetectError> {
    match *spec {
        TargetSpec::Chessboard { cols, rows } => Ok(board_detection(find_chessboard(img, &ChessboardParams::new(cols, rows))?)),
        TargetSpec::DotGrid { n } => {
            let dots = find_dots(img, &DotParams::default())?;
            Ok(match order_grid(&dots, n) {
                Some(p) => Detection { found: true, points_px: p, ..Default::default() },
                None => Detection { note: Some(format!("{} dots found, no {n}x{n} grid among them", dots.len())), ..Default::default() },
            })
        }
        TargetSpec::SPath { points } => {
            let dots = find_dots(img, &DotParams::default())?;
            let Some(path) = course_path(points) else {
                return Err(DetectError::BadParams { reason: "the S-path needs at least 2 points" });
            };
            match index_s_path(&dots, &path, &SPathFitParams::default()) {
                Ok(ordered) => {
                    let (ordered, unmeasured) = unmeasured(ordered, &dots);
                    Ok(Detection {
                        found: true,
                        points_px: ordered.iter().map(|d| d.centre_px).collect(),
                        indices: Some(ordered.iter().map(|d| d.index).collect()),
                        path_residuals: path_residuals(&ordered, &path),
                        unmeasured: Some(unmeasured),
                        note: None,
                    })
                }
                Err(DetectError::NotFound { reason }) => Ok(Detection { note: Some(reason), ..Default::default() }),
                Err(e) => Err(e),
            }
        }
    }
}

/// The course's S on its sphere, resampled to `points` points (cached for the course's 101).
fn course_path(points: usize) -> Option<std::borrow::Cow<'static, SPath>> {
    static COURSE: std::sync::OnceLock<SPath> = std::sync::OnceLock::new();
    let course = COURSE.get_or_init(course_s_path);
    if points == course.len() {
        return Some(std::borrow::Cow::Borrowed(course));
    }
    let planar = course_planar_s().ok()?;
    let points_m = build_s_path(&planar, points).ok()?;
    Some(std::borrow::Cow::Owned(SPath { points_m, ..course.clone() }))
}

/// [`detect`] on 8-bit samples, with identical results: the chessboard detector works on them
/// directly ([`find_chessboard_u8`]), the dot detectors on the image converted to f32.
///
/// # Errors
/// As [`detect`].
pub fn detect_u8(img: &ImageU8, spec: &TargetSpec) -> Result<Detection, DetectError> {
    match *spec {
        TargetSpec::Chessboard { cols, rows } => Ok(board_detection(find_chessboard_u8(img, &ChessboardParams::new(cols, rows))?)),
        _ => detect(&img.to_f32(), spec),
    }
}

fn board_detection(found: Option<ChessboardCorners>) -> Detection {
    match found {
        Some(c) => Detection { found: true, points_px: c.points_px, ..Default::default() },
        None => Detection { note: Some("no complete board of that size".into()), ..Default::default() },
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn parses_target_strings() {
        assert_eq!("chessboard:9x6".parse(), Ok(TargetSpec::Chessboard { cols: 9, rows: 6 }));
        assert_eq!("dot-grid:3x3".parse(), Ok(TargetSpec::DotGrid { n: 3 }));
        assert_eq!("s-path".parse(), Ok(TargetSpec::SPath { points: 101 }));
        assert!("chessboard:9".parse::<TargetSpec>().is_err());
        assert!("dot-grid:3x4".parse::<TargetSpec>().is_err());
        assert!("hex:3x3".parse::<TargetSpec>().is_err());
        assert!("chessboard:1x6".parse::<TargetSpec>().is_err());
    }
}
