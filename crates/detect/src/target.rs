//! One entry point for every target: parse a target description ("chessboard:9x6",
//! "dot-grid:3x3", "s-path") and detect it in an image.

use std::str::FromStr;

use nalgebra::Point2;

use super::aprilgrid::{find_aprilgrid, AprilGridParams};
use super::charuco::{find_charuco, find_charuco_u8, CharucoDetection, CharucoParams};
use super::chessboard::{find_chessboard, find_chessboard_u8, ChessboardCorners, ChessboardParams};
use super::dots::{find_dots, DotParams};
use super::grid_order::order_grid;
use super::s_path_fit::PathResidual;
use super::{DetectError, ImageF32, ImageU8};

mod s_path;
pub use s_path::detect_tracked;
use synthcam_core::camera::CameraModel;
use synthcam_core::target::{AprilGrid, Charuco, Dictionary};

/// What to look for.
#[derive(Debug, Clone, Copy, PartialEq, serde::Serialize)]
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
    /// A ChArUco board; its points are the chessboard corners found, with their ids.
    Charuco {
        /// Squares along x and y (OpenCV's `size`).
        squares: [u32; 2],
        /// The markers' dictionary.
        dictionary: Dictionary,
        /// Marker edge over square edge.
        marker_over_square: f64,
        /// OpenCV's legacy layout.
        legacy: bool,
        /// Id of the board's first marker.
        first_id: u32,
    },
    /// A Kalibr AprilGrid; its points are the tag corners found, id `4 k + c` (corner `c` in
    /// Kalibr's order of tag `k`, counted from `first_id`).
    Aprilgrid {
        /// Tags along x and y.
        tags: [u32; 2],
        /// Tag family.
        family: Dictionary,
        /// Gap over tag edge.
        spacing: f64,
        /// Black border, bits.
        border_bits: u32,
        /// Id of tag 0.
        first_id: u32,
    },
}

impl TargetSpec {
    /// What to look for on `target`: its grid size, or the S-path's point count.
    pub fn for_target(target: &synthcam_core::target::Target) -> Self {
        use synthcam_core::target::Target;
        match target {
            Target::Chessboard(b) => TargetSpec::Chessboard { cols: b.inner_corner_count()[0] as usize, rows: b.inner_corner_count()[1] as usize },
            Target::DotGrid(g) => TargetSpec::DotGrid { n: g.n as usize },
            Target::SPath(s) => TargetSpec::SPath { points: s.path.points_m.len() },
            Target::Charuco(c) => {
                let b = &c.board;
                TargetSpec::Charuco {
                    squares: b.squares,
                    dictionary: b.dictionary,
                    marker_over_square: b.marker_m / b.square_m,
                    legacy: b.legacy,
                    first_id: b.first_id,
                }
            }
            Target::AprilGrid(g) => {
                let g = &g.grid;
                TargetSpec::Aprilgrid { tags: g.tags, family: g.family, spacing: g.spacing, border_bits: g.border_bits, first_id: g.first_id }
            }
        }
    }

    /// The grid of an AprilGrid spec, its tags `tag_m` wide.
    pub fn aprilgrid(&self, tag_m: f64) -> Option<AprilGrid> {
        match *self {
            TargetSpec::Aprilgrid { tags, family, spacing, border_bits, first_id } => Some(AprilGrid { tags, tag_m, spacing, family, border_bits, first_id }),
            _ => None,
        }
    }

    /// The planar board points by point id, on z = 0, for calibration, in the target's frame
    /// (origin at the board's outer corner, as the renderer and the truth place it: see
    /// `calib::views`): a chessboard's inner corners row by row `square_m` apart from
    /// `(square_m, square_m)`, a ChArUco board's corners by OpenCV's id, an
    /// AprilGrid's tag corners by Kalibr's id (`square_m` is then the tag edge). `None` for the dot
    /// targets, which `calib` does not take.
    pub fn board_points_m(&self, square_m: f64) -> Option<Vec<nalgebra::Point3<f64>>> {
        match *self {
            TargetSpec::Chessboard { cols, rows } => {
                Some((0..cols * rows).map(|k| nalgebra::Point3::new((k % cols + 1) as f64 * square_m, (k / cols + 1) as f64 * square_m, 0.0)).collect())
            }
            TargetSpec::Charuco { .. } => self.charuco_board(square_m).map(|b| b.chessboard_corners_m()),
            TargetSpec::Aprilgrid { .. } => self.aprilgrid(square_m).map(|g| g.corners_by_id_m()),
            TargetSpec::DotGrid { .. } | TargetSpec::SPath { .. } => None,
        }
    }

    /// The board of a ChArUco spec, its squares `square_m` wide.
    pub fn charuco_board(&self, square_m: f64) -> Option<Charuco> {
        match *self {
            TargetSpec::Charuco { squares, dictionary, marker_over_square, legacy, first_id } => {
                Some(Charuco { squares, square_m, marker_m: marker_over_square * square_m, dictionary, legacy, first_id })
            }
            _ => None,
        }
    }
}

/// `NXxNY` as two counts.
fn pair(dims: &str) -> Result<[u32; 2], String> {
    let (nx, ny) = dims.split_once(['x', 'X']).ok_or_else(|| format!("expected NXxNY, got `{dims}`"))?;
    Ok([count(nx)?, count(ny)?])
}

fn count(v: &str) -> Result<u32, String> {
    v.trim().parse::<u32>().map_err(|_| format!("`{v}` is not a count"))
}

/// `aprilgrid:NXxNY:FAMILY:SPACING[:border_bits=N][:first_id=N]` after its `aprilgrid:`.
fn parse_aprilgrid(rest: &str) -> Result<TargetSpec, String> {
    let usage = "aprilgrid:NXxNY:tag36h11:SPACING[:border_bits=N][:first_id=N], e.g. aprilgrid:6x6:tag36h11:0.3";
    let mut parts = rest.split(':');
    let (Some(dims), Some(fam), Some(spacing)) = (parts.next(), parts.next(), parts.next()) else {
        return Err(format!("expected {usage}"));
    };
    // Kalibr's family names (tag36h11) or OpenCV's (DICT_APRILTAG_36h11).
    let family = Dictionary::from_name(&fam.replacen("tag", "APRILTAG_", 1)).or_else(|_| Dictionary::from_name(fam)).map_err(|e| e.to_string())?;
    let spacing: f64 = spacing.parse().map_err(|_| format!("`{spacing}` is not a number (gap / tag edge)"))?;
    let (mut border_bits, mut first_id) = (2, 0);
    for p in parts {
        match p.split_once('=') {
            Some(("border_bits", v)) => border_bits = count(v)?,
            Some(("first_id", v)) => first_id = count(v)?,
            _ => return Err(format!("unknown option `{p}` (border_bits=N, first_id=N)")),
        }
    }
    let spec = TargetSpec::Aprilgrid { tags: pair(dims)?, family, spacing, border_bits, first_id };
    spec.aprilgrid(1.0).map(|g| g.validate()).transpose().map_err(|e| e.to_string())?;
    Ok(spec)
}

/// `charuco:NXxNY:DICT:MARKER_OVER_SQUARE[:legacy][:first_id=N]` after its `charuco:`.
fn parse_charuco(rest: &str) -> Result<TargetSpec, String> {
    let usage = "charuco:NXxNY:DICT:MARKER_OVER_SQUARE[:legacy][:first_id=N], e.g. charuco:11x8:DICT_5X5_100:0.733";
    let mut parts = rest.split(':');
    let (Some(dims), Some(dict), Some(ratio)) = (parts.next(), parts.next(), parts.next()) else {
        return Err(format!("expected {usage}"));
    };
    let squares = pair(dims)?;
    let dictionary = Dictionary::from_name(dict).map_err(|e| e.to_string())?;
    let marker_over_square: f64 = ratio.parse().map_err(|_| format!("`{ratio}` is not a number (marker edge / square edge)"))?;
    let (mut legacy, mut first_id) = (false, 0);
    for p in parts {
        match p.split_once('=') {
            None if p == "legacy" => legacy = true,
            Some(("first_id", v)) => first_id = count(v)?,
            _ => return Err(format!("unknown option `{p}` (legacy, first_id=N)")),
        }
    }
    let spec = TargetSpec::Charuco { squares, dictionary, marker_over_square, legacy, first_id };
    spec.charuco_board(1.0).map(|b| b.validate()).transpose().map_err(|e| e.to_string())?;
    Ok(spec)
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
            Some(("charuco", rest)) => parse_charuco(rest),
            Some(("aprilgrid", rest)) => parse_aprilgrid(rest),
            _ => Err(format!(
                "unknown target `{s}` (chessboard:COLSxROWS, dot-grid:NxN, s-path, charuco:NXxNY:DICT:MARKER_OVER_SQUARE, aprilgrid:NXxNY:tag36h11:SPACING)"
            )),
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
    /// Coded boards: the id of each point (ChArUco: OpenCV's chessboard-corner id).
    pub ids: Option<Vec<u32>>,
    /// Chessboards: the standard deviation of each point's position from its own sub-pixel fit,
    /// pixels (infinite where the fit failed).
    pub position_sigma_px: Option<Vec<f64>>,
    /// Chessboards: indices of the points the refinement cannot place within
    /// [`TRUSTED_CORNER_PX`](super::chessboard::TRUSTED_CORNER_PX) (reported, but to be left out
    /// of a calibration).
    pub untrusted: Vec<usize>,
    /// Why it was not found, when it was not.
    pub note: Option<String>,
}

/// Detect `spec` in `img`.
///
/// # Errors
/// Bad image buffers; "not found" is `Ok` with `found: false`.
pub fn detect(img: &ImageF32, spec: &TargetSpec) -> Result<Detection, DetectError> {
    detect_with_camera(img, spec, None)
}

/// A camera of another image size than `img` is refused.
pub(super) fn check_camera(img: &ImageF32, camera: Option<&CameraModel>) -> Result<(), DetectError> {
    match camera {
        Some(c) if (c.size.width as usize, c.size.height as usize) != (img.width, img.height) => {
            Err(DetectError::BadParams { reason: "the camera's image size is not the image's" })
        }
        _ => Ok(()),
    }
}

/// Detect `spec` in `img` taken by `camera`, where it is known (calibrated). Only the S-path uses
/// it: its dots are then placed by the camera's pose behind its intrinsics and lens (6 degrees of
/// freedom) instead of a projective camera (11), which tells apart placements of the path shifted
/// along itself that a projective camera fits equally where the dots stray from their nominal
/// points ([`SPathFitParams::camera`](super::s_path_fit::SPathFitParams::camera)).
///
/// # Errors
/// As [`detect`]; [`DetectError::BadParams`] for a camera of another image size than `img`.
pub fn detect_with_camera(img: &ImageF32, spec: &TargetSpec, camera: Option<&CameraModel>) -> Result<Detection, DetectError> {
    check_camera(img, camera)?;
    match *spec {
        TargetSpec::Chessboard { cols, rows } => Ok(board_detection(find_chessboard(img, &ChessboardParams::new(cols, rows))?)),
        TargetSpec::DotGrid { n } => {
            let dots = find_dots(img, &DotParams::default())?;
            Ok(match order_grid(&dots, n) {
                Some(p) => Detection { found: true, points_px: p, ..Default::default() },
                None => Detection { note: Some(format!("{} dots found, no {n}x{n} grid among them", dots.len())), ..Default::default() },
            })
        }
        TargetSpec::SPath { points } => s_path::detect_s_path(img, points, camera, None),
        TargetSpec::Charuco { .. } => Ok(charuco_detection(find_charuco(img, &charuco_board(spec)?, &CharucoParams::default())?)),
        TargetSpec::Aprilgrid { .. } => {
            let Some(grid) = spec.aprilgrid(1.0) else { return Err(DetectError::BadParams { reason: "not an AprilGrid target" }) };
            let found = find_aprilgrid(img, &grid, &AprilGridParams::default())?;
            let note = found.ids.is_empty().then(|| format!("{} tags decoded, no AprilGrid corner", found.tags.len()));
            Ok(Detection { found: !found.ids.is_empty(), points_px: found.corners_px, ids: Some(found.ids), note, ..Default::default() })
        }
    }
}

/// [`detect`] on 8-bit samples, with identical results: the chessboard detector works on them
/// directly ([`find_chessboard_u8`]), the ChArUco detector halves them for its marker search
/// ([`find_charuco_u8`]), the other detectors work on the image converted to f32.
///
/// # Errors
/// As [`detect`].
pub fn detect_u8(img: &ImageU8, spec: &TargetSpec) -> Result<Detection, DetectError> {
    detect_u8_with_camera(img, spec, None)
}

/// [`detect_with_camera`] on an 8-bit image (the chessboard's and ChArUco's fast paths as
/// [`detect_u8`]).
///
/// # Errors
/// As [`detect_with_camera`].
pub fn detect_u8_with_camera(img: &ImageU8, spec: &TargetSpec, camera: Option<&CameraModel>) -> Result<Detection, DetectError> {
    match *spec {
        TargetSpec::Chessboard { cols, rows } => Ok(board_detection(find_chessboard_u8(img, &ChessboardParams::new(cols, rows))?)),
        TargetSpec::Charuco { .. } => Ok(charuco_detection(find_charuco_u8(img, &charuco_board(spec)?, &CharucoParams::default())?)),
        _ => detect_with_camera(&img.to_f32(), spec, camera),
    }
}

/// The board of a ChArUco spec (unit squares).
fn charuco_board(spec: &TargetSpec) -> Result<Charuco, DetectError> {
    spec.charuco_board(1.0).ok_or(DetectError::BadParams { reason: "not a ChArUco target" })
}

/// The [`Detection`] of a ChArUco board's corners.
fn charuco_detection(found: CharucoDetection) -> Detection {
    let note = found.ids.is_empty().then(|| format!("{} markers decoded, no ChArUco corner", found.markers.len()));
    Detection { found: !found.ids.is_empty(), points_px: found.corners_px, ids: Some(found.ids), note, ..Default::default() }
}

fn board_detection(found: Option<ChessboardCorners>) -> Detection {
    match found {
        Some(c) => {
            let untrusted = c.untrusted(super::chessboard::TRUSTED_CORNER_PX);
            Detection { found: true, points_px: c.points_px, position_sigma_px: Some(c.position_sigma_px), untrusted, ..Default::default() }
        }
        None => Detection { note: Some("no complete board of that size".into()), ..Default::default() },
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn board_points_row_by_row() {
        let pts = TargetSpec::Chessboard { cols: 3, rows: 2 }.board_points_m(0.1).unwrap_or_default();
        assert_eq!(pts.len(), 6);
        assert!((pts[4] - nalgebra::Point3::new(0.2, 0.2, 0.0)).norm() < 1e-15);
        // the frame the renderer draws the board in (its truth's `point_target_m`)
        assert_eq!(pts, synthcam_core::target::Target::chessboard(4, 3, 0.1).feature_points_m());
        assert!(TargetSpec::DotGrid { n: 3 }.board_points_m(0.1).is_none());
    }

    #[test]
    fn parses_target_strings() {
        assert_eq!("chessboard:9x6".parse(), Ok(TargetSpec::Chessboard { cols: 9, rows: 6 }));
        assert_eq!("dot-grid:3x3".parse(), Ok(TargetSpec::DotGrid { n: 3 }));
        assert_eq!("s-path".parse(), Ok(TargetSpec::SPath { points: 101 }));
        assert!("chessboard:9".parse::<TargetSpec>().is_err());
        assert!("dot-grid:3x4".parse::<TargetSpec>().is_err());
        assert!("hex:3x3".parse::<TargetSpec>().is_err());
        assert!("chessboard:1x6".parse::<TargetSpec>().is_err());
        let c = "charuco:11x8:DICT_5X5_100:0.733".parse::<TargetSpec>();
        assert_eq!(c, Ok(TargetSpec::Charuco { squares: [11, 8], dictionary: Dictionary::Dict5x5_100, marker_over_square: 0.733, legacy: false, first_id: 0 }));
        let c = "charuco:5x4:4X4_50:0.7:legacy:first_id=10".parse::<TargetSpec>();
        assert_eq!(c, Ok(TargetSpec::Charuco { squares: [5, 4], dictionary: Dictionary::Dict4x4_50, marker_over_square: 0.7, legacy: true, first_id: 10 }));
        let g = "aprilgrid:6x6:tag36h11:0.3".parse::<TargetSpec>();
        assert_eq!(g, Ok(TargetSpec::Aprilgrid { tags: [6, 6], family: Dictionary::AprilTag36h11, spacing: 0.3, border_bits: 2, first_id: 0 }));
        let g = "aprilgrid:3x2:DICT_APRILTAG_36h11:0.25:border_bits=1:first_id=6".parse::<TargetSpec>();
        assert_eq!(g, Ok(TargetSpec::Aprilgrid { tags: [3, 2], family: Dictionary::AprilTag36h11, spacing: 0.25, border_bits: 1, first_id: 6 }));
        for bad in [
            "aprilgrid:6x6:tag36h11",
            "aprilgrid:6x6:tag36h11:1.5",
            "aprilgrid:6x6:tag99h1:0.3",
            "aprilgrid:25x24:tag36h11:0.3",
            "aprilgrid:6x6:tag36h11:0.3:border_bits=3",
        ] {
            assert!(bad.parse::<TargetSpec>().is_err(), "{bad}");
        }
        for bad in [
            "charuco:11x8:DICT_5X5_100",
            "charuco:11x8:DICT_9X9:0.7",
            "charuco:11x8:DICT_5X5_100:1.2",
            "charuco:12x10:DICT_4X4_50:0.7",
            "charuco:1x8:DICT_5X5_100:0.7",
            "charuco:5x5:DICT_5X5_100:0.7:mirror",
        ] {
            assert!(bad.parse::<TargetSpec>().is_err(), "{bad}");
        }
    }
}
