//! How a printed board looks: its plain border and grey levels (shared by the coded boards).

use super::{require_grey, TargetError};

/// Border and grey levels of a printed board.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct BoardLook {
    /// Width of the plain (light) border around the board, metres.
    pub margin_m: f64,
    /// Grey level of dark squares, marker borders and bits.
    pub dark: f64,
    /// Grey level of light squares and bits.
    pub light: f64,
    /// Grey level of the border.
    pub margin: f64,
    /// Grey level of everything that is not the board.
    pub background: f64,
    /// The board's warp, `[kx, ky]` metres ([`super::Warp`]; zero: flat).
    pub warp_m: [f64; 2],
}

impl Default for BoardLook {
    /// The chessboard's look with a border of 2 cm.
    fn default() -> Self {
        Self { margin_m: 0.02, dark: 20.0, light: 235.0, margin: 235.0, background: 110.0, warp_m: [0.0; 2] }
    }
}

impl BoardLook {
    /// Checks the border width and the grey levels.
    ///
    /// # Errors
    /// [`TargetError::InvalidField`] naming the field.
    pub fn validate(&self) -> Result<(), TargetError> {
        if !self.margin_m.is_finite() || self.margin_m < 0.0 {
            return Err(TargetError::InvalidField { field: "margin_m", reason: format!("must be finite and >= 0, got {}", self.margin_m) });
        }
        if !self.warp_m.iter().all(|k| k.is_finite()) {
            return Err(TargetError::InvalidField { field: "warp_m", reason: format!("must be finite, got {:?}", self.warp_m) });
        }
        require_grey("dark", self.dark)?;
        require_grey("light", self.light)?;
        require_grey("margin", self.margin)?;
        require_grey("background", self.background)
    }

    /// Grey level at a board point: `dark` is the board's colouring there (`None` off the board),
    /// the board spanning `[x0, x1) x [y0, y1)`.
    pub fn grey(&self, dark: Option<bool>, x: f64, y: f64, [x0, y0, x1, y1]: [f64; 4]) -> f64 {
        let m = self.margin_m;
        match dark {
            Some(true) => self.dark,
            Some(false) => self.light,
            None if x >= x0 - m && x < x1 + m && y >= y0 - m && y < y1 + m => self.margin,
            None => self.background,
        }
    }
}
