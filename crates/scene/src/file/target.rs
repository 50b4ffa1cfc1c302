//! The `[target]` table of scene files, dataset specs and scenarios (see [`super`]).

use serde::Deserialize;

use synthcam_core::target::{AprilGrid, AprilGridTarget, BoardLook, Charuco, CharucoTarget, Chessboard, Dictionary, DotGrid, DotStyle, SPathDots, Target};

/// `[target]` table. The boards' look fields (`margin_m`, `dark`, `light`, `margin`,
/// `background`) repeat in each variant: serde's `flatten` does not combine with
/// `deny_unknown_fields`, and a typo must stay an error.
#[derive(Debug, Clone, Deserialize)]
#[serde(tag = "kind", rename_all = "kebab-case", deny_unknown_fields)]
pub enum TargetTable {
    /// A chessboard.
    Chessboard {
        /// Squares along x and y.
        squares: [u32; 2],
        /// Square edge, metres.
        square_m: f64,
        /// Border width, metres (default: half a square).
        margin_m: Option<f64>,
        /// Dark grey level.
        dark: Option<f64>,
        /// Light grey level.
        light: Option<f64>,
        /// Margin grey level (default: light).
        margin: Option<f64>,
        /// Background grey level.
        background: Option<f64>,
        /// The board's warp `[kx, ky]`, metres (mrcal's sag at the centre along x and y; default flat).
        warp_m: Option<[f64; 2]>,
    },
    /// The course dot grid.
    DotGrid {
        /// Dots per side.
        n: u32,
        /// Outer dot-centre span, metres (default 0.4).
        edge_m: Option<f64>,
        /// Disc radius, metres (default: pitch / 5).
        dot_radius_m: Option<f64>,
        /// Plate border beyond the outer centres, metres (default: pitch / 2).
        margin_m: Option<f64>,
        /// Dark grey level.
        dark: Option<f64>,
        /// Light grey level.
        light: Option<f64>,
        /// Background grey level.
        background: Option<f64>,
    },
    /// OpenCV's ChArUco board (`cv::aruco::CharucoBoard`).
    Charuco {
        /// Squares along x and y.
        squares: [u32; 2],
        /// Square edge, metres.
        square_m: f64,
        /// Marker edge, metres.
        marker_m: f64,
        /// OpenCV dictionary name, e.g. "DICT_5X5_100".
        dictionary: Dictionary,
        /// OpenCV's legacy layout (`setLegacyPattern(true)`; default false).
        legacy: Option<bool>,
        /// Id of the first marker (default 0).
        first_id: Option<u32>,
        /// Light border around the board, metres (default: half a square).
        margin_m: Option<f64>,
        /// Dark grey level.
        dark: Option<f64>,
        /// Light grey level.
        light: Option<f64>,
        /// Border grey level (default: light).
        margin: Option<f64>,
        /// Background grey level.
        background: Option<f64>,
        /// The board's warp `[kx, ky]`, metres (mrcal's sag at the centre along x and y; default flat).
        warp_m: Option<[f64; 2]>,
    },
    /// Kalibr's AprilGrid.
    Aprilgrid {
        /// Tags along x and y (Kalibr's tagCols, tagRows).
        tags: [u32; 2],
        /// Tag edge, metres (Kalibr's tagSize).
        tag_m: f64,
        /// Gap over tag edge (Kalibr's tagSpacing).
        spacing: f64,
        /// Tag family as an OpenCV dictionary name (default "DICT_APRILTAG_36h11", Kalibr's tag36h11).
        family: Option<Dictionary>,
        /// Black border, bits (default 2, as Kalibr prints).
        border_bits: Option<u32>,
        /// Id of tag 0 (default 0).
        first_id: Option<u32>,
        /// Light border around the grid, metres (default: the gap).
        margin_m: Option<f64>,
        /// Dark grey level.
        dark: Option<f64>,
        /// Light grey level.
        light: Option<f64>,
        /// Border grey level (default: light).
        margin: Option<f64>,
        /// Background grey level.
        background: Option<f64>,
        /// The board's warp `[kx, ky]`, metres (mrcal's sag at the centre along x and y; default flat).
        warp_m: Option<[f64; 2]>,
    },
    /// The S-path dot target.
    SPath {
        /// "bead" (default) or "disc".
        style: Option<DotStyle>,
        /// Dot radius, metres.
        dot_radius_m: Option<f64>,
        /// First dot radius, metres.
        start_dot_radius_m: Option<f64>,
        /// Dark grey level.
        dark: Option<f64>,
        /// Sphere grey level.
        light: Option<f64>,
        /// Background grey level.
        background: Option<f64>,
    },
}

impl TargetTable {
    /// The target this table describes (not yet validated).
    pub fn to_target(&self) -> Target {
        match *self {
            TargetTable::Chessboard { squares, square_m, margin_m, dark, light, margin, background, warp_m } => {
                let d = Chessboard::default();
                let light = light.unwrap_or(d.light);
                Target::Chessboard(Chessboard {
                    squares,
                    square_m,
                    margin_m: margin_m.unwrap_or(0.5 * square_m),
                    dark: dark.unwrap_or(d.dark),
                    light,
                    margin: margin.unwrap_or(light),
                    background: background.unwrap_or(d.background),
                    warp_m: warp_m.unwrap_or_default(),
                })
            }
            TargetTable::DotGrid { n, edge_m, dot_radius_m, margin_m, dark, light, background } => {
                let d = DotGrid::default();
                let edge_m = edge_m.unwrap_or(d.edge_m);
                let pitch = if n >= 2 { edge_m / f64::from(n - 1) } else { edge_m };
                Target::DotGrid(DotGrid {
                    n,
                    edge_m,
                    dot_radius_m: dot_radius_m.unwrap_or(0.2 * pitch),
                    margin_m: margin_m.unwrap_or(0.5 * pitch),
                    dark: dark.unwrap_or(d.dark),
                    light: light.unwrap_or(d.light),
                    background: background.unwrap_or(d.background),
                })
            }
            TargetTable::Charuco { squares, square_m, marker_m, dictionary, legacy, first_id, margin_m, dark, light, margin, background, warp_m } => {
                let board = Charuco { squares, square_m, marker_m, dictionary, legacy: legacy.unwrap_or(false), first_id: first_id.unwrap_or(0) };
                let look = look(margin_m.unwrap_or(0.5 * square_m), [dark, light, margin, background], warp_m);
                Target::Charuco(CharucoTarget { board, look })
            }
            TargetTable::Aprilgrid { tags, tag_m, spacing, family, border_bits, first_id, margin_m, dark, light, margin, background, warp_m } => {
                let d = AprilGrid::default();
                let grid = AprilGrid {
                    tags,
                    tag_m,
                    spacing,
                    family: family.unwrap_or(d.family),
                    border_bits: border_bits.unwrap_or(d.border_bits),
                    first_id: first_id.unwrap_or(0),
                };
                let look = look(margin_m.unwrap_or(spacing * tag_m), [dark, light, margin, background], warp_m);
                Target::AprilGrid(AprilGridTarget { grid, look })
            }
            TargetTable::SPath { style, dot_radius_m, start_dot_radius_m, dark, light, background } => {
                let d = SPathDots::default();
                Target::SPath(SPathDots {
                    style: style.unwrap_or(d.style),
                    dot_radius_m: dot_radius_m.unwrap_or(d.dot_radius_m),
                    start_dot_radius_m: start_dot_radius_m.unwrap_or(d.start_dot_radius_m),
                    dark: dark.unwrap_or(d.dark),
                    light: light.unwrap_or(d.light),
                    background: background.unwrap_or(d.background),
                    ..d
                })
            }
        }
    }
}

/// A coded board's look from its optional grey levels `[dark, light, margin, background]` (the
/// margin defaults to `light`) and warp.
fn look(margin_m: f64, [dark, light, margin, background]: [Option<f64>; 4], warp_m: Option<[f64; 2]>) -> BoardLook {
    let d = BoardLook::default();
    let light = light.unwrap_or(d.light);
    BoardLook {
        margin_m,
        dark: dark.unwrap_or(d.dark),
        light,
        margin: margin.unwrap_or(light),
        background: background.unwrap_or(d.background),
        warp_m: warp_m.unwrap_or_default(),
    }
}
