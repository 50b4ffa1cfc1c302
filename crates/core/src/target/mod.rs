//! Calibration targets, each defined in its own frame, in metres.
//!
//! - [`Chessboard`]: planar checkerboard, origin at the outer top-left corner of the checker area.
//! - [`DotGrid`]: the course's N x N planar grid of filled discs (course-scenario 1.2, 3.3).
//! - [`SPathDots`]: the course's 101-point S on a sphere (course-scenario 1.4, 3.4), each point a dark
//!   dot (a bead, or a disc painted on the sphere) on a light sphere.
//! - [`CharucoTarget`]: OpenCV's ChArUco board ([`Charuco`]) as printed ([`BoardLook`]), its
//!   features the chessboard corners by id; every edge lies on its [`CellLattice`].
//! - [`AprilGridTarget`]: Kalibr's AprilGrid ([`AprilGrid`]) as printed, its features the tag
//!   corners (id `4 k + c`); its frame's z points towards the viewer.
//! - The marker [`Dictionary`] tables of both.
//!
//! Intensities are grey levels in [0, 255] (linear, before noise and quantisation).
//! The plane colour functions here are the CPU twins of the ones in `shaders/planar.wgsl` and `shaders/coded.wgsl`.

pub mod aprilgrid;
pub mod aruco;
pub mod charuco;
pub mod chessboard;
pub mod dot_grid;
pub mod lattice;
pub mod look;
pub mod s_path;
pub mod s_path_dots;
pub mod warp;

pub use aprilgrid::{AprilGrid, AprilGridTarget};
pub use aruco::Dictionary;
pub use charuco::{Charuco, CharucoTarget};
pub use chessboard::Chessboard;
pub use dot_grid::DotGrid;
pub use lattice::CellLattice;
pub use look::BoardLook;
pub use s_path::{spherical_s, SPath};
pub use s_path_dots::{DotStyle, SPathDots};
pub use warp::{BoardExtent, Warp};

use nalgebra::Point3;

/// Errors raised when a target definition is invalid.
#[derive(Debug, thiserror::Error, Clone, PartialEq)]
#[non_exhaustive]
pub enum TargetError {
    /// A field has a value that makes the target meaningless.
    #[error("target field `{field}` is invalid: {reason}")]
    InvalidField {
        /// Name of the offending field, as in the scene file.
        field: &'static str,
        /// What is wrong with it.
        reason: String,
    },
}

/// Check that `value` is finite and strictly positive, naming `field` otherwise.
pub(crate) fn require_positive(field: &'static str, value: f64) -> Result<(), TargetError> {
    if !value.is_finite() || value <= 0.0 {
        return Err(TargetError::InvalidField { field, reason: format!("must be a finite number > 0, got {value}") });
    }
    Ok(())
}

/// Check that a grey level is finite and within [0, 255].
pub(crate) fn require_grey(field: &'static str, value: f64) -> Result<(), TargetError> {
    if !value.is_finite() || !(0.0..=255.0).contains(&value) {
        return Err(TargetError::InvalidField { field, reason: format!("must be a grey level in [0, 255], got {value}") });
    }
    Ok(())
}

/// Any target synthcam can render.
#[derive(Debug, Clone, PartialEq)]
pub enum Target {
    /// Planar checkerboard.
    Chessboard(Chessboard),
    /// Planar dot grid.
    DotGrid(DotGrid),
    /// The 3-D S-path dot target.
    SPath(SPathDots),
    /// A ChArUco board.
    Charuco(CharucoTarget),
    /// A Kalibr AprilGrid.
    AprilGrid(AprilGridTarget),
}

/// Which kind of feature a target labels.
#[derive(Debug, Clone, Copy, PartialEq, Eq, serde::Serialize, serde::Deserialize)]
#[serde(rename_all = "kebab-case")]
pub enum FeatureKind {
    /// Inner chessboard corner (a saddle point).
    Corner,
    /// Centre of a dot (disc or bead).
    Dot,
}

impl Target {
    /// A chessboard of `cols x rows` squares of `square_m` metres (the default look: a margin of
    /// half a square, dark 20 / light 235 grey levels).
    ///
    /// ```
    /// let board = synthcam_core::target::Target::chessboard(9, 7, 0.04);
    /// assert_eq!(board.feature_points_m().len(), 8 * 6);
    /// ```
    pub fn chessboard(cols: u32, rows: u32, square_m: f64) -> Self {
        Target::Chessboard(Chessboard { squares: [cols, rows], square_m, margin_m: 0.5 * square_m, ..Chessboard::default() })
    }

    /// The S-path dot target: the dots of [`spherical_s`] with their default look.
    pub fn s_path() -> Self {
        Target::SPath(SPathDots::default())
    }

    /// Validate every field.
    ///
    /// # Errors
    /// [`TargetError::InvalidField`] naming the first bad field.
    pub fn validate(&self) -> Result<(), TargetError> {
        match self {
            Target::Chessboard(b) => b.validate(),
            Target::DotGrid(g) => g.validate(),
            Target::SPath(s) => s.validate(),
            Target::Charuco(c) => c.validate(),
            Target::AprilGrid(g) => g.validate(),
        }?;
        self.validate_warp()
    }

    /// A warp is finite (the looks check that) and at most a tenth of the feature points' smaller
    /// extent: beyond it a board is no longer "nearly flat", the model's domain.
    fn validate_warp(&self) -> Result<(), TargetError> {
        let (Some(k), Some(e)) = (self.warp_m(), BoardExtent::of(self.flat_feature_points_m())) else { return Ok(()) };
        let limit = 0.1 * (e.x.1 - e.x.0).min(e.y.1 - e.y.0);
        if k.iter().any(|k| k.abs() > limit) {
            return Err(TargetError::InvalidField { field: "warp_m", reason: format!("{k:?} exceeds a tenth of the board's feature extent ({limit} m)") });
        }
        Ok(())
    }

    /// The warp's `[kx, ky]` (metres) of a board that has one (`None`: flat, or not a board).
    pub fn warp_m(&self) -> Option<[f64; 2]> {
        let k = match self {
            Target::Chessboard(b) => b.warp_m,
            Target::Charuco(c) => c.look.warp_m,
            Target::AprilGrid(g) => g.look.warp_m,
            Target::DotGrid(_) | Target::SPath(_) => return None,
        };
        (k != [0.0; 2]).then_some(k)
    }

    /// The board's warp over its feature points' extent ([`Warp`]); `None` for a flat target.
    pub fn warp(&self) -> Option<Warp> {
        let k = self.warp_m()?;
        Some(Warp { k, extent: Some(BoardExtent::of(self.flat_feature_points_m())?) })
    }

    /// The labelled feature points in the target frame (metres), in the target's documented order
    /// (on a warped board, off the plane by the warp's sag).
    pub fn feature_points_m(&self) -> Vec<Point3<f64>> {
        let flat = self.flat_feature_points_m();
        // The warp's extent from these same points (Target::warp would list them again).
        let warp = self.warp_m().and_then(|k| Some(Warp { k, extent: Some(BoardExtent::of(flat.iter().copied())?) }));
        match warp {
            Some(w) => flat.iter().map(|p| w.apply(p)).collect(),
            None => flat,
        }
    }

    /// The feature points as printed: in z = 0 for the planar targets, whatever the warp.
    pub fn flat_feature_points_m(&self) -> Vec<Point3<f64>> {
        match self {
            Target::Chessboard(b) => b.inner_corners_m(),
            Target::DotGrid(g) => g.dot_centres_m(),
            Target::SPath(s) => s.path.points_m.clone(),
            Target::Charuco(c) => c.board.chessboard_corners_m(),
            Target::AprilGrid(g) => g.grid.corners_by_id_m(),
        }
    }

    /// The mean of [`Target::feature_points_m`] in the target frame (metres): the point a
    /// `Facing` pose puts on the optical axis.
    pub fn feature_centre_m(&self) -> Point3<f64> {
        let pts = self.feature_points_m();
        Point3::from(pts.iter().map(|p| p.coords).sum::<nalgebra::Vector3<f64>>() / pts.len().max(1) as f64)
    }

    /// The kind of feature the target labels.
    pub fn feature_kind(&self) -> FeatureKind {
        match self {
            Target::Chessboard(_) | Target::Charuco(_) | Target::AprilGrid(_) => FeatureKind::Corner,
            _ => FeatureKind::Dot,
        }
    }

    /// Short name used in scene files ("chessboard", "dot-grid", "s-path", "charuco", "aprilgrid").
    pub fn kind_name(&self) -> &'static str {
        match self {
            Target::Chessboard(_) => "chessboard",
            Target::DotGrid(_) => "dot-grid",
            Target::SPath(_) => "s-path",
            Target::Charuco(_) => "charuco",
            Target::AprilGrid(_) => "aprilgrid",
        }
    }

    /// Whether the target is planar (lies in z = 0 of its frame).
    pub fn is_planar(&self) -> bool {
        !matches!(self, Target::SPath(_))
    }

    /// The same target with its grey levels replaced: `[dark, light, margin, background]` (a
    /// dot grid's plate and an S-path's sphere take `light`; they have no separate margin). A
    /// colour target renders once per channel with that channel's albedo.
    pub fn with_greys(&self, [dark, light, margin, background]: [f64; 4]) -> Target {
        let mut t = self.clone();
        match &mut t {
            Target::Chessboard(b) => (b.dark, b.light, b.margin, b.background) = (dark, light, margin, background),
            Target::DotGrid(g) => (g.dark, g.light, g.background) = (dark, light, background),
            Target::SPath(s) => (s.dark, s.light, s.background) = (dark, light, background),
            Target::Charuco(c) => (c.look.dark, c.look.light, c.look.margin, c.look.background) = (dark, light, margin, background),
            Target::AprilGrid(g) => (g.look.dark, g.look.light, g.look.margin, g.look.background) = (dark, light, margin, background),
        }
        t
    }

    /// The grey levels `[dark, light, margin, background]`, as [`Target::with_greys`] takes them
    /// (a dot grid's plate and an S-path's sphere give `light` as the margin).
    pub fn greys(&self) -> [f64; 4] {
        match self {
            Target::Chessboard(b) => [b.dark, b.light, b.margin, b.background],
            Target::DotGrid(g) => [g.dark, g.light, g.light, g.background],
            Target::SPath(s) => [s.dark, s.light, s.light, s.background],
            Target::Charuco(c) => [c.look.dark, c.look.light, c.look.margin, c.look.background],
            Target::AprilGrid(g) => [g.look.dark, g.look.light, g.look.margin, g.look.background],
        }
    }

    /// Grey level of the empty background (what rays that miss the target see).
    pub fn background(&self) -> f64 {
        match self {
            Target::Chessboard(b) => b.background,
            Target::DotGrid(g) => g.background,
            Target::SPath(s) => s.background,
            Target::Charuco(c) => c.look.background,
            Target::AprilGrid(g) => g.look.background,
        }
    }

    /// Grey level at a point (x, y) of the plane z = 0 for planar targets; `None` for the S-path.
    pub fn plane_intensity(&self, x: f64, y: f64) -> Option<f64> {
        match self {
            Target::Chessboard(b) => Some(b.intensity_at(x, y)),
            Target::DotGrid(g) => Some(g.intensity_at(x, y)),
            Target::SPath(_) => None,
            Target::Charuco(c) => Some(c.intensity_at(x, y)),
            Target::AprilGrid(g) => Some(g.intensity_at(x, y)),
        }
    }

    /// The rotation that turns the target's frame so that its printed side faces a camera
    /// looking along its +z (the identity for targets whose z points into the board; a half turn
    /// about x for the AprilGrid, whose z points out of the page, as Kalibr's): a pose sampler
    /// that aims +z away from the camera composes it on the right.
    pub fn front_from_target(&self) -> nalgebra::UnitQuaternion<f64> {
        match self {
            Target::AprilGrid(_) => nalgebra::UnitQuaternion::from_axis_angle(&nalgebra::Vector3::x_axis(), std::f64::consts::PI),
            _ => nalgebra::UnitQuaternion::identity(),
        }
    }

    /// A coded board's cell lattice (ChArUco, AprilGrid): every edge of the board lies on it.
    pub fn lattice(&self) -> Option<CellLattice> {
        match self {
            Target::Charuco(c) => Some(c.lattice()),
            Target::AprilGrid(g) => Some(g.lattice()),
            _ => None,
        }
    }

    /// The printed sheet of a planar target, margin included, `[x0, y0, x1, y1]` metres in its
    /// plane: where [`Target::plane_intensity`] is not the background (`None` for the S-path).
    /// Objects in front of or behind the target are compared with it there.
    pub fn extent_m(&self) -> Option<[f64; 4]> {
        let grow = |[x0, y0, x1, y1]: [f64; 4], m: f64| Some([x0 - m, y0 - m, x1 + m, y1 + m]);
        match self {
            Target::Chessboard(b) => grow([0.0, 0.0, b.square_m * f64::from(b.squares[0]), b.square_m * f64::from(b.squares[1])], b.margin_m),
            Target::DotGrid(g) => grow([-0.5 * g.edge_m, -0.5 * g.edge_m, 0.5 * g.edge_m, 0.5 * g.edge_m], g.margin_m),
            Target::Charuco(_) | Target::AprilGrid(_) => self.coded_look().and_then(|(look, e)| grow(e, look.margin_m)),
            Target::SPath(_) => None,
        }
    }

    /// Whether the target-plane point (x, y), metres, lies on the printed sheet
    /// ([`Target::extent_m`]; never for the S-path).
    pub fn on_sheet(&self, x: f64, y: f64) -> bool {
        self.extent_m().is_some_and(|[x0, y0, x1, y1]| x >= x0 && x < x1 && y >= y0 && y < y1)
    }

    /// A coded board's look and extent `[x0, y0, x1, y1]` (border excluded), metres.
    pub fn coded_look(&self) -> Option<(BoardLook, [f64; 4])> {
        match self {
            Target::Charuco(c) => Some((c.look, c.extent_m())),
            Target::AprilGrid(g) => Some((g.look, g.grid.extent_m())),
            _ => None,
        }
    }
}
