//! OpenCV's ChArUco board (`cv::aruco::CharucoBoard`) geometry: a chessboard whose white squares
//! hold ArUco markers. Board frame as OpenCV's: origin at the outer top-left corner of the square
//! area, x along the `nx` squares of a row, y down the `ny` rows, z = 0 on the board.
//!
//! - Squares: `(x, y)` holds a marker where `x % 2 != y % 2` (OpenCV >= 4.6); with
//!   `legacy = true` and an even `ny`, where `x % 2 == y % 2` (`setLegacyPattern(true)`: the
//!   layout of OpenCV < 4.6, whose top-left square holds a marker; odd `ny` is the same either
//!   way). Squares without a marker are dark.
//! - Markers: ids `first_id, first_id + 1, ...` over the marker squares row by row (OpenCV's
//!   `getIds()` for consecutive ids), each `marker_m` wide, centred in its square, corners
//!   top-left, top-right, bottom-right, bottom-left (`getObjPoints()`).
//! - Chessboard corners: the `(nx - 1) x (ny - 1)` inner corners row by row, id = index
//!   (`getChessboardCorners()`).
//!
//! Reference: Garrido-Jurado et al., "Automatic generation and detection of highly reliable
//! fiducial markers under occlusion", Pattern Recognition 47(6), 2014; OpenCV
//! `modules/objdetect/src/aruco/aruco_board.cpp` (`CharucoBoardImpl::createCharucoBoard`).
//! Values checked against OpenCV 5.1's `CharucoBoard` in the unit tests.

use nalgebra::Point3;

use super::lattice::CellLattice;
use super::{require_positive, BoardLook, Dictionary, TargetError};

/// A ChArUco board.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Charuco {
    /// Squares per row and per column, `[nx, ny]` (OpenCV's `size`).
    pub squares: [u32; 2],
    /// Square edge, metres.
    pub square_m: f64,
    /// Marker edge, metres (less than `square_m`).
    pub marker_m: f64,
    /// The markers' dictionary.
    pub dictionary: Dictionary,
    /// OpenCV's legacy layout (see the module docs).
    pub legacy: bool,
    /// Id of the first marker.
    pub first_id: u32,
}

/// One marker of a board.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Marker {
    /// Marker id in the dictionary.
    pub id: u32,
    /// The square `(x, y)` it sits in.
    pub square: [u32; 2],
    /// Corners in the board frame, metres: top-left, top-right, bottom-right, bottom-left.
    pub corners_m: [Point3<f64>; 4],
}

impl Charuco {
    /// Checks the fields: at least 2 x 2 squares, positive sizes, the marker inside its square,
    /// and enough markers in the dictionary from `first_id` on.
    ///
    /// # Errors
    /// [`TargetError::InvalidField`] naming the field.
    pub fn validate(&self) -> Result<(), TargetError> {
        let [nx, ny] = self.squares;
        if nx < 2 || ny < 2 || nx > 1000 || ny > 1000 {
            return Err(TargetError::InvalidField { field: "squares", reason: format!("needs 2..=1000 squares per side, got {nx} x {ny}") });
        }
        require_positive("square_m", self.square_m)?;
        require_positive("marker_m", self.marker_m)?;
        if !(self.marker_m < self.square_m) {
            return Err(TargetError::InvalidField {
                field: "marker_m",
                reason: format!("must be less than square_m ({}), got {}", self.square_m, self.marker_m),
            });
        }
        let need = u64::from(self.first_id) + self.marker_squares().count() as u64;
        if need > self.dictionary.len() as u64 {
            return Err(TargetError::InvalidField {
                field: "first_id",
                reason: format!("ids {}..{need} exceed {} ({} markers)", self.first_id, self.dictionary.name(), self.dictionary.len()),
            });
        }
        Ok(())
    }

    /// Whether square `(x, y)` holds a marker.
    pub fn has_marker(&self, x: u32, y: u32) -> bool {
        if self.legacy && self.squares[1].is_multiple_of(2) {
            x % 2 == y % 2
        } else {
            x % 2 != y % 2
        }
    }

    /// The marker squares, row by row.
    fn marker_squares(&self) -> impl Iterator<Item = [u32; 2]> + '_ {
        let [nx, ny] = self.squares;
        (0..ny).flat_map(move |y| (0..nx).map(move |x| [x, y])).filter(|&[x, y]| self.has_marker(x, y))
    }

    /// The rank of marker square `(x, y)` among the marker squares, row by row (its id less
    /// `first_id`), counted per row without walking the board: the renderer's lattice asks this
    /// for every cell of every frame.
    fn marker_index(&self, x: u32, y: u32) -> usize {
        let nx = self.squares[0];
        // Marker squares in row r: the x of one parity, `(nx + 1) / 2` even ones or `nx / 2` odd.
        let odd_first = |r: u32| !self.has_marker(0, r);
        let in_row = |r: u32, before: u32| if odd_first(r) { before / 2 } else { before.div_ceil(2) };
        ((0..y).map(|r| in_row(r, nx)).sum::<u32>() + in_row(y, x)) as usize
    }

    /// The markers in id order.
    pub fn markers(&self) -> Vec<Marker> {
        let (s, m) = (self.square_m, self.marker_m);
        let inset = 0.5 * (s - m);
        self.marker_squares()
            .enumerate()
            .map(|(k, [x, y])| {
                let (x0, y0) = (f64::from(x) * s + inset, f64::from(y) * s + inset);
                let corners_m = [Point3::new(x0, y0, 0.0), Point3::new(x0 + m, y0, 0.0), Point3::new(x0 + m, y0 + m, 0.0), Point3::new(x0, y0 + m, 0.0)];
                Marker { id: self.first_id + k as u32, square: [x, y], corners_m }
            })
            .collect()
    }

    /// Whether the board point `(x, y)` (board frame, metres) is dark: a square without a
    /// marker, or a marker's one-bit black border or black bit (`None` off the square area).
    /// The CPU twin of the renderer's board colouring, as `cv::aruco::CharucoBoard::generateImage`
    /// draws it (`borderBits = 1`).
    pub fn is_dark(&self, x: f64, y: f64) -> Option<bool> {
        let [nx, ny] = self.squares;
        let s = self.square_m;
        let (fi, fj) = ((x / s).floor(), (y / s).floor());
        if !(fi >= 0.0 && fj >= 0.0 && fi < f64::from(nx) && fj < f64::from(ny)) {
            return None;
        }
        let (i, j) = (fi as u32, fj as u32);
        if !self.has_marker(i, j) {
            return Some(true);
        }
        let inset = 0.5 * (s - self.marker_m);
        let (u, v) = (x - fi * s - inset, y - fj * s - inset);
        if !(u >= 0.0 && v >= 0.0 && u < self.marker_m && v < self.marker_m) {
            return Some(false);
        }
        let n = self.dictionary.marker_bits();
        let cell = self.marker_m / (n + 2) as f64;
        let (cx, cy) = (((u / cell) as usize).min(n + 1), ((v / cell) as usize).min(n + 1));
        if cx == 0 || cy == 0 || cx == n + 1 || cy == n + 1 {
            return Some(true);
        }
        let k = self.marker_index(i, j);
        let code = self.dictionary.code(self.first_id as usize + k)?;
        Some(!code[(cy - 1) * n + (cx - 1)])
    }

    /// The inner chessboard corners in id order (`getChessboardCorners()`), board frame, metres.
    pub fn chessboard_corners_m(&self) -> Vec<Point3<f64>> {
        let [nx, ny] = self.squares;
        let s = self.square_m;
        (1..ny).flat_map(|y| (1..nx).map(move |x| Point3::new(f64::from(x) * s, f64::from(y) * s, 0.0))).collect()
    }
}

/// A ChArUco board as a scene target: the board and how it is printed.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct CharucoTarget {
    /// The board's geometry and codes.
    pub board: Charuco,
    /// Border and grey levels.
    pub look: BoardLook,
}

impl CharucoTarget {
    /// Checks the board and its look.
    ///
    /// # Errors
    /// [`TargetError::InvalidField`] naming the field.
    pub fn validate(&self) -> Result<(), TargetError> {
        self.board.validate()?;
        self.look.validate()
    }

    /// The board's extent `[x0, y0, x1, y1]` (without the border), metres.
    pub fn extent_m(&self) -> [f64; 4] {
        let s = self.board.square_m;
        [0.0, 0.0, s * f64::from(self.board.squares[0]), s * f64::from(self.board.squares[1])]
    }

    /// Grey level at a point of the board plane (board frame, metres).
    pub fn intensity_at(&self, x: f64, y: f64) -> f64 {
        self.look.grey(self.board.is_dark(x, y), x, y, self.extent_m())
    }

    /// The board's cell lattice: per square the white inset, the marker's `n + 2` cells (border
    /// and bits), the inset again.
    pub fn lattice(&self) -> CellLattice {
        let b = &self.board;
        let n = b.dictionary.marker_bits() as u32 + 2;
        let inset = 0.5 * (b.square_m - b.marker_m);
        let per = n + 2;
        CellLattice::new(b.square_m, 0.0, inset, b.marker_m / f64::from(n), per, [b.squares[0] * per, b.squares[1] * per], |x, y| b.is_dark(x, y) == Some(true))
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn board(legacy: bool) -> Charuco {
        Charuco { squares: [5, 4], square_m: 0.04, marker_m: 0.03, dictionary: Dictionary::Dict5x5_100, legacy, first_id: 0 }
    }

    /// Top-left marker corners of `cv2.aruco.CharucoBoard((5, 4), 0.04, 0.03, DICT_5X5_100)`
    /// (`getObjPoints()[k][0]`), OpenCV 5.1.0, without and with `setLegacyPattern(True)`.
    const OPENCV_TOP_LEFT: [[[f64; 2]; 10]; 2] = [
        [
            [0.045, 0.005],
            [0.125, 0.005],
            [0.005, 0.045],
            [0.085, 0.045],
            [0.165, 0.045],
            [0.045, 0.085],
            [0.125, 0.085],
            [0.005, 0.125],
            [0.085, 0.125],
            [0.165, 0.125],
        ],
        [
            [0.005, 0.005],
            [0.085, 0.005],
            [0.165, 0.005],
            [0.045, 0.045],
            [0.125, 0.045],
            [0.005, 0.085],
            [0.085, 0.085],
            [0.165, 0.085],
            [0.045, 0.125],
            [0.125, 0.125],
        ],
    ];

    #[test]
    fn layout_matches_opencv_charuco_board() {
        for (legacy, expect) in [(false, OPENCV_TOP_LEFT[0]), (true, OPENCV_TOP_LEFT[1])] {
            let b = board(legacy);
            assert_eq!(b.validate(), Ok(()));
            let m = b.markers();
            assert_eq!(m.len(), 10);
            for (k, (mk, e)) in m.iter().zip(expect).enumerate() {
                assert_eq!(mk.id, k as u32);
                assert!(
                    (mk.corners_m[0].x - e[0]).abs() < 1e-7 && (mk.corners_m[0].y - e[1]).abs() < 1e-7,
                    "legacy {legacy} marker {k}: {:?} vs {e:?}",
                    mk.corners_m[0]
                );
            }
        }
        // Marker 0's corners (OpenCV: (0.045, 0.005) (0.075, 0.005) (0.075, 0.035) (0.045, 0.035)).
        let c = board(false).markers()[0].corners_m;
        let expect = [[0.045, 0.005], [0.075, 0.005], [0.075, 0.035], [0.045, 0.035]];
        for (p, e) in c.iter().zip(expect) {
            assert!((p.x - e[0]).abs() < 1e-7 && (p.y - e[1]).abs() < 1e-7 && p.z == 0.0, "{p} vs {e:?}");
        }
        // Odd ny: the legacy flag changes nothing (OpenCV applies it to even row counts only).
        let odd = |legacy| Charuco { squares: [5, 5], ..board(legacy) }.markers();
        assert_eq!(odd(false), odd(true));
    }

    #[test]
    fn chessboard_corners_and_ids_match_opencv() {
        // getChessboardCorners(): (0.04, 0.04), (0.08, 0.04), ... row by row, 4 x 3.
        let c = board(false).chessboard_corners_m();
        assert_eq!(c.len(), 12);
        assert!((c[0] - Point3::new(0.04, 0.04, 0.0)).norm() < 1e-12);
        assert!((c[3] - Point3::new(0.16, 0.04, 0.0)).norm() < 1e-12);
        assert!((c[4] - Point3::new(0.04, 0.08, 0.0)).norm() < 1e-12);
        assert!((c[11] - Point3::new(0.16, 0.12, 0.0)).norm() < 1e-12);
        // CharucoBoard(..., ids = 7..16).getIds() = 7..16.
        let ids: Vec<u32> = Charuco { first_id: 7, ..board(false) }.markers().iter().map(|m| m.id).collect();
        assert_eq!(ids, (7..17).collect::<Vec<_>>());
    }

    /// `cv2.aruco.CharucoBoard((3, 3), 0.06, 0.042, DICT_4X4_50).generateImage((1800, 1800),
    /// marginSize=0, borderBits=1)` sampled at (0.0025 + 0.005 i, 0.0025 + 0.005 j) m (OpenCV
    /// 5.1.0): `#` dark.
    const OPENCV_IMAGE: [&str; 36] = [
        "############............############",
        "############............############",
        "############..########..############",
        "############..#..#...#..############",
        "############..#..#...#..############",
        "############..###.#..#..############",
        "############..####...#..############",
        "############..####.###..############",
        "############..####.###..############",
        "############..########..############",
        "############............############",
        "############............############",
        "............############............",
        "............############............",
        "..########..############..########..",
        "..########..############..####...#..",
        "..########..############..####...#..",
        "..#......#..############..####...#..",
        "..#..##..#..############..####.###..",
        "..#..#.###..############..#...#..#..",
        "..#..#.###..############..#...#..#..",
        "..########..############..########..",
        "............############............",
        "............############............",
        "############............############",
        "############............############",
        "############..########..############",
        "############..#..##..#..############",
        "############..#..##..#..############",
        "############..#..##..#..############",
        "############..###.####..############",
        "############..###..###..############",
        "############..###..###..############",
        "############..########..############",
        "############............############",
        "############............############",
    ];

    #[test]
    fn board_colouring_matches_opencv_generate_image() {
        let b = Charuco { squares: [3, 3], square_m: 0.06, marker_m: 0.042, dictionary: Dictionary::Dict4x4_50, legacy: false, first_id: 0 };
        for (j, row) in OPENCV_IMAGE.iter().enumerate() {
            for (i, c) in row.bytes().enumerate() {
                let (x, y) = (0.0025 + 0.005 * i as f64, 0.0025 + 0.005 * j as f64);
                assert_eq!(b.is_dark(x, y), Some(c == b'#'), "({x:.4}, {y:.4})");
            }
        }
        assert_eq!(b.is_dark(-0.001, 0.01), None);
        assert_eq!(b.is_dark(0.01, 0.18), None);
    }

    #[test]
    fn marker_index_counts_the_marker_squares_before() {
        for (squares, legacy) in [([5, 4], false), ([5, 4], true), ([4, 5], false), ([6, 6], true), ([7, 3], false)] {
            let b = Charuco { squares, ..board(legacy) };
            for (k, m) in b.markers().iter().enumerate() {
                assert_eq!(b.marker_index(m.square[0], m.square[1]), k, "{squares:?} legacy {legacy}");
            }
        }
    }

    #[test]
    fn bad_boards_name_the_field() {
        let field = |b: Charuco| match b.validate() {
            Err(TargetError::InvalidField { field, .. }) => field,
            other => panic!("{other:?}"),
        };
        assert_eq!(field(Charuco { squares: [1, 4], ..board(false) }), "squares");
        assert_eq!(field(Charuco { marker_m: 0.04, ..board(false) }), "marker_m");
        assert_eq!(field(Charuco { square_m: f64::NAN, ..board(false) }), "square_m");
        assert_eq!(field(Charuco { first_id: 91, ..board(false) }), "first_id");
        assert!(Charuco { first_id: 90, ..board(false) }.validate().is_ok());
        assert_eq!(field(Charuco { squares: [20, 20], dictionary: Dictionary::AprilTag16h5, ..board(false) }), "first_id");
    }
}
