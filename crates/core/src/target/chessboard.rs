//! Planar chessboard target.
//!
//! Frame: origin at the outer top-left corner of the checker area, x along the `squares[0]` (nx)
//! squares, y along the `squares[1]` (ny) squares, z = 0 on the board (z points into the board, so
//! a camera looking at the printed side sees the board from -z).
//! Square (row i, col j) covers x in [j s, (j+1) s], y in [i s, (i+1) s] and is dark when i + j is
//! even. Inner corner (r, c) = (s (c+1), s (r+1), 0), listed row-major (`nx - 1` per row), which is
//! the order OpenCV's `findChessboardCorners` uses for a board of `(nx-1) x (ny-1)` inner corners.
//! A margin of width `margin_m` surrounds the checker area; outside it is the background.

use nalgebra::Point3;

use super::{require_positive, BoardLook, TargetError};

/// A planar chessboard.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Chessboard {
    /// Number of squares along x and along y (inner corners: `[nx-1, ny-1]`).
    pub squares: [u32; 2],
    /// Edge length of one square, metres (typical 0.02-0.05).
    pub square_m: f64,
    /// Width of the plain border around the checker area, metres.
    pub margin_m: f64,
    /// Grey level of dark squares.
    pub dark: f64,
    /// Grey level of light squares.
    pub light: f64,
    /// Grey level of the margin (default: `light`).
    pub margin: f64,
    /// Grey level of everything that is not the board.
    pub background: f64,
    /// The board's warp, `[kx, ky]` metres ([`super::Warp`]; zero: flat).
    pub warp_m: [f64; 2],
}

impl Default for Chessboard {
    fn default() -> Self {
        Self { squares: [9, 7], square_m: 0.03, margin_m: 0.015, dark: 20.0, light: 235.0, margin: 235.0, background: 110.0, warp_m: [0.0; 2] }
    }
}

impl Chessboard {
    /// Number of inner corners `[cols, rows]`.
    pub fn inner_corner_count(&self) -> [u32; 2] {
        [self.squares[0].saturating_sub(1), self.squares[1].saturating_sub(1)]
    }

    /// Inner corners in the board frame, row-major, `cols` per row.
    pub fn inner_corners_m(&self) -> Vec<Point3<f64>> {
        let [cols, rows] = self.inner_corner_count();
        let mut out = Vec::with_capacity((cols * rows) as usize);
        for r in 0..rows {
            for c in 0..cols {
                out.push(Point3::new(self.square_m * f64::from(c + 1), self.square_m * f64::from(r + 1), 0.0));
            }
        }
        out
    }

    /// Validate every field.
    ///
    /// # Errors
    /// [`TargetError::InvalidField`] naming the first bad field.
    pub fn validate(&self) -> Result<(), TargetError> {
        if self.squares[0] < 2 || self.squares[1] < 2 || self.squares[0] > 4096 || self.squares[1] > 4096 {
            return Err(TargetError::InvalidField { field: "squares", reason: format!("needs 2..=4096 squares per side, got {:?}", self.squares) });
        }
        require_positive("square_m", self.square_m)?;
        BoardLook { margin_m: self.margin_m, dark: self.dark, light: self.light, margin: self.margin, background: self.background, warp_m: self.warp_m }
            .validate()
    }

    /// Grey level at (x, y) on the board plane (board frame, metres).
    pub fn intensity_at(&self, x: f64, y: f64) -> f64 {
        let w = self.square_m * f64::from(self.squares[0]);
        let h = self.square_m * f64::from(self.squares[1]);
        if x >= 0.0 && x < w && y >= 0.0 && y < h {
            let j = (x / self.square_m).floor() as i64;
            let i = (y / self.square_m).floor() as i64;
            if (i + j) % 2 == 0 {
                self.dark
            } else {
                self.light
            }
        } else if x >= -self.margin_m && x < w + self.margin_m && y >= -self.margin_m && y < h + self.margin_m {
            self.margin
        } else {
            self.background
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn corners_are_row_major_and_on_square_junctions() {
        let b = Chessboard { squares: [9, 7], square_m: 0.025, ..Default::default() };
        let c = b.inner_corners_m();
        assert_eq!(c.len(), 8 * 6);
        assert_eq!(c[0], Point3::new(0.025, 0.025, 0.0));
        assert_eq!(c[1], Point3::new(0.05, 0.025, 0.0));
        assert_eq!(c[8], Point3::new(0.025, 0.05, 0.0));
    }

    #[test]
    fn square_00_is_dark_and_margin_background_split() {
        let b = Chessboard::default();
        assert_eq!(b.intensity_at(0.001, 0.001), b.dark);
        assert_eq!(b.intensity_at(0.031, 0.001), b.light);
        assert_eq!(b.intensity_at(-0.001, 0.1), b.margin);
        assert_eq!(b.intensity_at(-0.02, 0.1), b.background);
    }

    #[test]
    fn rejects_bad_fields() {
        let b = Chessboard { square_m: f64::NAN, ..Default::default() };
        assert!(matches!(b.validate(), Err(TargetError::InvalidField { field: "square_m", .. })));
        let b = Chessboard { squares: [1, 5], ..Default::default() };
        assert!(matches!(b.validate(), Err(TargetError::InvalidField { field: "squares", .. })));
    }
}
