//! The course's spherical "S" target path (`pS`, RPI Robotics I, MP4/MP5).
//!
//! Specification: `shared/spec/course-scenario.md` §1.4 (how the course made
//! `pS`, with the verified reference numbers), §2 item 5 (the planar data) and
//! §3.4 (the construction in our own words).
//!
//! # Construction
//! 1. Start from the course's planar, hand-drawn "S" `Sls` (2 × 101 points,
//!    unitless, x ∈ [0.935, 2.842], y ∈ [−1.025, 1.072]). It is embedded from
//!    `assets/s_path/planar_s.csv`, transcribed from the MATLAB mini-project-2
//!    script that writes `Sls` out inline with 4 decimals (see
//!    `assets/s_path/README.md`).
//! 2. Centre and half-scale it with the course's fixed constants
//!    ([`PLANAR_CENTER`], the mean of the full-precision `Sls`):
//!    `u = 0.5·(Sx − 1.869430)`, `v = 0.5·(Sy + 0.017589)`.
//! 3. Inverse stereographic projection onto the sphere of centre
//!    `c = (0, 0, 0.5)` m and radius `r = 0.5` m, from the antipode
//!    `(−0.5, 0, 0.5)` through the tangent plane `x = 0.5`:
//!    `t = 1/(1 + u² + v²)`, `P = (0.5·(1 − u² − v²)·t, u·t, 0.5 + v·t)`.
//!    Planar x becomes world y, planar y becomes world z.
//! 4. Resample to [`S_PATH_POINTS`] = 101 points equally spaced in cumulative
//!    chord length `λ` (100 intervals over `l_f ≈ 2.574467` m), interpolating
//!    x, y and z each with a not-a-knot cubic spline in `λ` (MATLAB `spline`).
//!
//! # Frame and units
//! All points are in the world / target frame 0 (the robot base frame of the
//! course), in metres. The sphere centre is expressed in the same frame.

use crate::math::spline::{CubicSpline, SplineError};
use nalgebra::{Point2, Point3, Vector3};

/// Number of points in the course's resampled S path `pS`.
pub const S_PATH_POINTS: usize = 101;

/// Centre of the sphere carrying the S path, frame 0, metres.
pub const SPHERE_CENTER_M: [f64; 3] = [0.0, 0.0, 0.5];

/// Radius of the sphere carrying the S path, metres.
pub const SPHERE_RADIUS_M: f64 = 0.5;

/// Fixed centring constants `(Sx, Sy)` subtracted from the planar S before
/// half-scaling (the course's mean of the full-precision `Sls`, spec §1.4).
pub const PLANAR_CENTER: [f64; 2] = [1.869430, -0.017589];

/// The planar S as embedded at compile time (`x,y` header, one point a row).
pub const PLANAR_S_CSV: &str = include_str!("../../assets/s_path/planar_s.csv");

/// Errors from parsing planar data or building an S path.
#[derive(Debug, thiserror::Error)]
#[non_exhaustive]
pub enum SPathError {
    /// Too few planar input points for the construction.
    #[error("need at least {required} planar points, got {actual}")]
    TooFewPlanarPoints {
        /// Minimum number of planar points.
        required: usize,
        /// Number given.
        actual: usize,
    },
    /// Too few output points requested (at least the two ends are needed).
    #[error("need at least {required} output points, got {actual}")]
    TooFewOutputPoints {
        /// Minimum number of output points.
        required: usize,
        /// Number requested.
        actual: usize,
    },
    /// A planar point is NaN or infinite.
    #[error("planar point {index} is not finite")]
    NonFinite {
        /// Index of the offending planar point.
        index: usize,
    },
    /// Planar point `index` coincides with its predecessor after mapping, so
    /// the chord-length parameter would not be strictly increasing.
    #[error("planar point {index} repeats the previous point (zero chord length)")]
    RepeatedPoint {
        /// Index of the repeated point.
        index: usize,
    },
    /// A CSV line could not be parsed.
    #[error("planar CSV line {line}: {reason}")]
    Parse {
        /// 1-based line number.
        line: usize,
        /// What was wrong.
        reason: String,
    },
    /// The per-coordinate spline could not be built.
    #[error("spline construction failed: {0}")]
    Spline(#[from] SplineError),
}

/// A resampled path on a sphere, in frame 0 (metres).
#[derive(Debug, Clone, PartialEq)]
pub struct SPath {
    /// Path points in order, frame 0, metres.
    pub points_m: Vec<Point3<f64>>,
    /// Centre of the sphere the points lie on, frame 0, metres.
    pub sphere_center_m: Point3<f64>,
    /// Radius of that sphere, metres.
    pub sphere_radius_m: f64,
}

impl SPath {
    /// Outward unit sphere normal `(p_i − c)/|p_i − c|` at point `i` (the
    /// course's end-effector x-axis along the path, spec §1.4).
    ///
    /// Returns the zero vector if `i >= self.len()` or the point coincides
    /// with the centre; use [`Self::try_normal_at`] to detect that.
    pub fn normal_at(&self, i: usize) -> Vector3<f64> {
        self.try_normal_at(i).unwrap_or_else(Vector3::zeros)
    }

    /// Like [`Self::normal_at`], but `None` for an out-of-range index or a
    /// point at the sphere centre.
    pub fn try_normal_at(&self, i: usize) -> Option<Vector3<f64>> {
        let p = self.points_m.get(i)?;
        (p - self.sphere_center_m).try_normalize(f64::EPSILON)
    }

    /// Number of points.
    pub fn len(&self) -> usize {
        self.points_m.len()
    }

    /// True if the path has no points.
    pub fn is_empty(&self) -> bool {
        self.points_m.is_empty()
    }

    /// Polyline (sum of chord) length of the points, metres.
    pub fn path_length_m(&self) -> f64 {
        polyline_length_m(&self.points_m)
    }
}

/// The course's `pS`: 101 points on the sphere `c = (0, 0, 0.5)`, `r = 0.5`,
/// built from the embedded planar S by [`build_s_path`].
#[allow(clippy::expect_used)] // fixed compile-time data, see comment below
pub fn spherical_s() -> SPath {
    // The input is compile-time data, and the unit test
    // `embedded_data_parses_and_builds` proves this cannot fail; a failure
    // here would be a build defect, not a runtime condition.
    let points_m = planar_s().and_then(|planar| build_s_path(&planar, S_PATH_POINTS)).expect("embedded planar S data is valid (checked by unit test)");
    SPath { points_m, sphere_center_m: Point3::from(SPHERE_CENTER_M), sphere_radius_m: SPHERE_RADIUS_M }
}

/// The embedded planar S (`Sls`, 101 points, unitless) parsed from
/// [`PLANAR_S_CSV`].
pub fn planar_s() -> Result<Vec<Point2<f64>>, SPathError> {
    parse_planar_csv(PLANAR_S_CSV)
}

/// Parses `x,y` CSV text: an optional first header line `x,y`, then one
/// point per line; blank lines are skipped.
pub fn parse_planar_csv(text: &str) -> Result<Vec<Point2<f64>>, SPathError> {
    let mut out = Vec::new();
    for (k, raw) in text.lines().enumerate() {
        let line = raw.trim();
        if line.is_empty() || (k == 0 && line.eq_ignore_ascii_case("x,y")) {
            continue;
        }
        let err = |reason: String| SPathError::Parse { line: k + 1, reason };
        let mut fields = line.split(',');
        let (Some(xs), Some(ys), None) = (fields.next(), fields.next(), fields.next()) else {
            return Err(err(format!("expected 2 fields, got {line:?}")));
        };
        let x: f64 = xs.trim().parse().map_err(|e| err(format!("x {xs:?}: {e}")))?;
        let y: f64 = ys.trim().parse().map_err(|e| err(format!("y {ys:?}: {e}")))?;
        out.push(Point2::new(x, y));
    }
    Ok(out)
}

/// Maps one planar S point onto the course sphere (spec §3.4 steps 2–3):
/// centring by [`PLANAR_CENTER`], half-scaling, inverse stereographic
/// projection. Result in frame 0, metres.
pub fn planar_to_sphere(p: &Point2<f64>) -> Point3<f64> {
    let u = 0.5 * (p.x - PLANAR_CENTER[0]);
    let v = 0.5 * (p.y - PLANAR_CENTER[1]);
    let q = u * u + v * v;
    let t = 1.0 / (1.0 + q);
    Point3::new(0.5 * (1.0 - q) * t, u * t, 0.5 + v * t)
}

/// Sum of chord lengths of a polyline (0 for fewer than 2 points).
pub fn polyline_length_m(points: &[Point3<f64>]) -> f64 {
    points.windows(2).map(|w| (w[1] - w[0]).norm()).sum()
}

/// Builds an S path (spec §3.4): maps every planar point onto the sphere with
/// [`planar_to_sphere`], then resamples to `n_out` points equally spaced in
/// cumulative chord length, with a not-a-knot cubic spline per coordinate.
///
/// Needs at least 2 planar points, no two consecutive ones equal, all finite,
/// and `n_out >= 2`. The first and last output points equal the mapped first
/// and last planar points.
pub fn build_s_path(planar: &[Point2<f64>], n_out: usize) -> Result<Vec<Point3<f64>>, SPathError> {
    if planar.len() < 2 {
        return Err(SPathError::TooFewPlanarPoints { required: 2, actual: planar.len() });
    }
    if n_out < 2 {
        return Err(SPathError::TooFewOutputPoints { required: 2, actual: n_out });
    }
    if let Some(index) = planar.iter().position(|p| !(p.x.is_finite() && p.y.is_finite())) {
        return Err(SPathError::NonFinite { index });
    }
    let mapped: Vec<Point3<f64>> = planar.iter().map(planar_to_sphere).collect();

    // Cumulative chord length λ (MATLAB: l = [0 cumsum(vecnorm(diff(p_S')'))]).
    let mut lambda = Vec::with_capacity(mapped.len());
    lambda.push(0.0);
    for (k, w) in mapped.windows(2).enumerate() {
        let d = (w[1] - w[0]).norm();
        if d <= 0.0 {
            return Err(SPathError::RepeatedPoint { index: k + 1 });
        }
        lambda.push(lambda[k] + d);
    }
    let l_f = lambda[lambda.len() - 1];

    let coord = |j: usize| mapped.iter().map(|p| p[j]).collect::<Vec<f64>>();
    let sx = CubicSpline::not_a_knot(&lambda, &coord(0))?;
    let sy = CubicSpline::not_a_knot(&lambda, &coord(1))?;
    let sz = CubicSpline::not_a_knot(&lambda, &coord(2))?;

    let n_int = (n_out - 1) as f64;
    Ok((0..n_out)
        .map(|k| {
            // MATLAB: l_k = (0:N)*l_f/N.
            let l = k as f64 * l_f / n_int;
            Point3::new(sx.eval(l), sy.eval(l), sz.eval(l))
        })
        .collect())
}

#[cfg(test)]
#[allow(clippy::expect_used)] // tests: a failed expect is a test failure
mod tests;
