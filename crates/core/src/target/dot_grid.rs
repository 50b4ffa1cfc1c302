//! The course's planar N x N dot grid (course-scenario 1.2 and 3.3) as filled dark discs on a light plate.
//!
//! Frame: centred on the grid, z = 0 on the plate. Dot centres at x, y in
//! `linspace(-edge/2, edge/2, n)`. Order as in the course: x is the slow index, y the fast one,
//! i.e. index = ix * n + iy.

use nalgebra::Point3;

use super::{require_grey, require_positive, TargetError};

/// A planar grid of filled discs.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct DotGrid {
    /// Dots per side (course: 3, alternative 5).
    pub n: u32,
    /// Distance between the first and last dot centre along a side, metres (course: 0.4).
    pub edge_m: f64,
    /// Disc radius, metres.
    pub dot_radius_m: f64,
    /// Width of the plate beyond the outer dot centres, metres.
    pub margin_m: f64,
    /// Grey level of the discs.
    pub dark: f64,
    /// Grey level of the plate.
    pub light: f64,
    /// Grey level of everything that is not the plate.
    pub background: f64,
}

impl Default for DotGrid {
    fn default() -> Self {
        Self { n: 3, edge_m: 0.4, dot_radius_m: 0.04, margin_m: 0.1, dark: 20.0, light: 235.0, background: 110.0 }
    }
}

impl DotGrid {
    /// Distance between neighbouring dot centres, metres.
    pub fn pitch_m(&self) -> f64 {
        if self.n < 2 {
            0.0
        } else {
            self.edge_m / f64::from(self.n - 1)
        }
    }

    /// Dot centres in the target frame, x slow and y fast.
    pub fn dot_centres_m(&self) -> Vec<Point3<f64>> {
        let p = self.pitch_m();
        let h = 0.5 * self.edge_m;
        let mut out = Vec::with_capacity((self.n * self.n) as usize);
        for ix in 0..self.n {
            for iy in 0..self.n {
                out.push(Point3::new(-h + p * f64::from(ix), -h + p * f64::from(iy), 0.0));
            }
        }
        out
    }

    /// Validate every field.
    ///
    /// # Errors
    /// [`TargetError::InvalidField`] naming the first bad field.
    pub fn validate(&self) -> Result<(), TargetError> {
        if self.n < 2 || self.n > 1024 {
            return Err(TargetError::InvalidField { field: "n", reason: format!("needs 2..=1024 dots per side, got {}", self.n) });
        }
        require_positive("edge_m", self.edge_m)?;
        require_positive("dot_radius_m", self.dot_radius_m)?;
        if self.dot_radius_m >= 0.5 * self.pitch_m() {
            return Err(TargetError::InvalidField {
                field: "dot_radius_m",
                reason: format!("dots of radius {} m touch at pitch {} m", self.dot_radius_m, self.pitch_m()),
            });
        }
        if !self.margin_m.is_finite() || self.margin_m < self.dot_radius_m {
            return Err(TargetError::InvalidField { field: "margin_m", reason: format!("must be >= dot_radius_m, got {}", self.margin_m) });
        }
        require_grey("dark", self.dark)?;
        require_grey("light", self.light)?;
        require_grey("background", self.background)
    }

    /// Grey level at (x, y) on the plate plane (target frame, metres).
    pub fn intensity_at(&self, x: f64, y: f64) -> f64 {
        let h = 0.5 * self.edge_m;
        let outer = h + self.margin_m;
        if x < -outer || x >= outer || y < -outer || y >= outer {
            return self.background;
        }
        let p = self.pitch_m();
        let last = f64::from(self.n - 1);
        let ix = ((x + h) / p).round().clamp(0.0, last);
        let iy = ((y + h) / p).round().clamp(0.0, last);
        let dx = x - (-h + p * ix);
        let dy = y - (-h + p * iy);
        if dx * dx + dy * dy < self.dot_radius_m * self.dot_radius_m {
            self.dark
        } else {
            self.light
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn grid_order_x_slow_y_fast() {
        let g = DotGrid::default();
        let c = g.dot_centres_m();
        assert_eq!(c.len(), 9);
        assert_eq!(c[0], Point3::new(-0.2, -0.2, 0.0));
        assert_eq!(c[1], Point3::new(-0.2, 0.0, 0.0));
        assert_eq!(c[3], Point3::new(0.0, -0.2, 0.0));
    }

    #[test]
    fn intensity_inside_and_outside_discs() {
        let g = DotGrid::default();
        assert_eq!(g.intensity_at(0.0, 0.0), g.dark);
        assert_eq!(g.intensity_at(0.1, 0.1), g.light);
        assert_eq!(g.intensity_at(0.5, 0.0), g.background);
    }

    #[test]
    fn touching_dots_rejected() {
        let g = DotGrid { dot_radius_m: 0.11, ..Default::default() };
        assert!(matches!(g.validate(), Err(TargetError::InvalidField { field: "dot_radius_m", .. })));
    }
}
