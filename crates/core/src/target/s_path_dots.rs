//! The S-path dot target: the course's 101 path points (see [`super::s_path`]) drawn as dark dots on a
//! light sphere (centre (0, 0, 0.5) m, radius 0.5 m in the world/target frame 0).
//!
//! Two dot styles:
//! - [`DotStyle::Bead`] (default): a small dark ball centred on each path point. Half of it sticks out
//!   of the sphere; it images as a near-circle from any view, so it stays detectable where the sphere
//!   is seen obliquely (the S lies where the surface normals are 3-67 degrees from +x; from the course's
//!   desired pose flat discs are seen up to ~84 degrees from their normal and shrink to slivers).
//! - [`DotStyle::Disc`]: a dark spherical cap painted on the sphere: the points of the sphere within
//!   chord distance `dot_radius_m` of the path point.
//!
//! The first dot is larger (`start_dot_radius_m`) so that a detector can find the start of the path
//! and order the dots.

use super::{require_grey, require_positive, SPath, TargetError};

/// How each path point is drawn.
#[derive(Debug, Clone, Copy, PartialEq, Eq, serde::Serialize, serde::Deserialize, Default)]
#[serde(rename_all = "kebab-case")]
pub enum DotStyle {
    /// A dark ball centred on the path point.
    #[default]
    Bead,
    /// A dark cap painted on the sphere surface.
    Disc,
}

/// The S-path target.
#[derive(Debug, Clone, PartialEq)]
pub struct SPathDots {
    /// The path points and the sphere they lie on.
    pub path: SPath,
    /// Dot style.
    pub style: DotStyle,
    /// Radius of every dot but the first, metres (default 6 mm; path spacing is 25.7 mm).
    pub dot_radius_m: f64,
    /// Radius of the first dot, metres (default 10 mm).
    pub start_dot_radius_m: f64,
    /// Grey level of the dots.
    pub dark: f64,
    /// Grey level of the sphere.
    pub light: f64,
    /// Grey level of the background.
    pub background: f64,
}

impl Default for SPathDots {
    fn default() -> Self {
        Self { path: super::spherical_s(), style: DotStyle::Bead, dot_radius_m: 0.006, start_dot_radius_m: 0.010, dark: 20.0, light: 225.0, background: 90.0 }
    }
}

impl SPathDots {
    /// Radius of dot `i`, metres.
    pub fn dot_radius(&self, i: usize) -> f64 {
        if i == 0 {
            self.start_dot_radius_m
        } else {
            self.dot_radius_m
        }
    }

    /// Validate every field.
    ///
    /// # Errors
    /// [`TargetError::InvalidField`] naming the first bad field.
    pub fn validate(&self) -> Result<(), TargetError> {
        require_positive("dot_radius_m", self.dot_radius_m)?;
        require_positive("start_dot_radius_m", self.start_dot_radius_m)?;
        let max_r = 0.25 * self.path.sphere_radius_m;
        for (field, r) in [("dot_radius_m", self.dot_radius_m), ("start_dot_radius_m", self.start_dot_radius_m)] {
            if r > max_r {
                return Err(TargetError::InvalidField { field, reason: format!("{r} m is more than a quarter of the sphere radius") });
            }
        }
        require_grey("dark", self.dark)?;
        require_grey("light", self.light)?;
        require_grey("background", self.background)
    }
}
