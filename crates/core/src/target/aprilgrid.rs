//! Kalibr's AprilGrid geometry: `nx x ny` AprilTags (tag36h11 with a 2-bit black border by
//! default) of edge `tag_m`, `spacing x tag_m` apart, with a black square of that gap's size at
//! every gap crossing (Kalibr's `kalibr_create_target_pdf`, `symmCorners`).
//!
//! Frame and order exactly as Kalibr's (`aslam_cameras_april`, `GridCalibrationTargetAprilgrid`):
//! origin at the outer bottom-left corner of tag 0 on the printed page, x to the right, y up the
//! page, z out of it (towards the viewer; a right-handed frame, unlike the chessboard's y-down
//! one). Tag `id = first_id + nx * y + x` sits at `(x, y) (1 + spacing) tag_m`. The target points
//! form a `(2 ny) x (2 nx)` grid, index `r * 2 nx + c`, at
//! `((c / 2) (1 + spacing) tag_m + (c % 2) tag_m, (r / 2) (1 + spacing) tag_m + (r % 2) tag_m)`;
//! tag k's corners are points `b, b + 1, b + 2 nx + 1, b + 2 nx` with
//! `b = (k / nx) 4 nx + (k % nx) 2` (bottom-left, bottom-right, top-right, top-left).
//!
//! Reference: Kalibr (`aslam_cv/aslam_cameras_april/src/GridCalibrationTargetAprilgrid.cpp`,
//! `createGridPoints` and `computeObservation`; `kalibr_create_target_pdf`, `generateAprilBoard`);
//! Olson, "AprilTag: A robust and flexible visual fiducial system", ICRA 2011.

use nalgebra::Point3;

use super::lattice::CellLattice;
use super::{require_positive, BoardLook, Dictionary, TargetError};

/// A Kalibr AprilGrid.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct AprilGrid {
    /// Tags per row and per column, `[nx, ny]` (Kalibr's `tagCols`, `tagRows`).
    pub tags: [u32; 2],
    /// Tag edge, metres, border included (Kalibr's `tagSize`).
    pub tag_m: f64,
    /// Gap between tags as a fraction of `tag_m` (Kalibr's `tagSpacing`), in (0, 1].
    pub spacing: f64,
    /// Tag family (Kalibr: tag36h11).
    pub family: Dictionary,
    /// Black border, bits (Kalibr prints 2; standard AprilTag detectors expect 1).
    pub border_bits: u32,
    /// Id of tag 0.
    pub first_id: u32,
}

impl Default for AprilGrid {
    /// Kalibr's example `aprilgrid.yaml`: 6 x 6 tags of 88 mm, spacing 0.3, tag36h11.
    fn default() -> Self {
        Self { tags: [6, 6], tag_m: 0.088, spacing: 0.3, family: Dictionary::AprilTag36h11, border_bits: 2, first_id: 0 }
    }
}

impl AprilGrid {
    /// Checks the fields (named in the error): at least one tag, sizes positive, spacing in
    /// (0, 1], a border of 1 or 2 bits, and enough codes in the family from `first_id` on.
    ///
    /// # Errors
    /// [`TargetError::InvalidField`].
    pub fn validate(&self) -> Result<(), TargetError> {
        let [nx, ny] = self.tags;
        if nx == 0 || ny == 0 || nx > 200 || ny > 200 {
            return Err(TargetError::InvalidField { field: "tags", reason: format!("needs 1..=200 tags per side, got {nx} x {ny}") });
        }
        require_positive("tag_m", self.tag_m)?;
        if !(self.spacing > 0.0 && self.spacing <= 1.0) {
            return Err(TargetError::InvalidField { field: "spacing", reason: format!("must be in (0, 1] (gap / tag size), got {}", self.spacing) });
        }
        if !(1..=2).contains(&self.border_bits) {
            return Err(TargetError::InvalidField { field: "border_bits", reason: format!("must be 1 or 2, got {}", self.border_bits) });
        }
        let need = u64::from(self.first_id) + u64::from(nx) * u64::from(ny);
        if need > self.family.len() as u64 {
            return Err(TargetError::InvalidField {
                field: "first_id",
                reason: format!("tag ids {}..{need} exceed {} ({} codes)", self.first_id, self.family.name(), self.family.len()),
            });
        }
        Ok(())
    }

    /// Pitch of the tag grid, metres.
    fn pitch_m(&self) -> f64 {
        (1.0 + self.spacing) * self.tag_m
    }

    /// Every target point in Kalibr's index order (`r * 2 nx + c`), metres.
    pub fn points_m(&self) -> Vec<Point3<f64>> {
        let [nx, ny] = self.tags;
        let (p, s) = (self.pitch_m(), self.tag_m);
        let at = |k: u32| f64::from(k / 2) * p + f64::from(k % 2) * s;
        (0..2 * ny).flat_map(|r| (0..2 * nx).map(move |c| Point3::new(at(c), at(r), 0.0))).collect()
    }

    /// The point indices of tag `k` (0-based, before `first_id`): bottom-left, bottom-right,
    /// top-right, top-left (Kalibr's `pIdx`).
    pub fn tag_point_ids(&self, k: u32) -> [u32; 4] {
        let nx = self.tags[0];
        let b = (k / nx) * 4 * nx + (k % nx) * 2;
        [b, b + 1, b + 2 * nx + 1, b + 2 * nx]
    }

    /// Corners of tag `k` in [`Self::tag_point_ids`] order, metres.
    pub fn tag_corners_m(&self, k: u32) -> [Point3<f64>; 4] {
        let nx = self.tags[0];
        let (x0, y0) = (f64::from(k % nx) * self.pitch_m(), f64::from(k / nx) * self.pitch_m());
        let s = self.tag_m;
        [Point3::new(x0, y0, 0.0), Point3::new(x0 + s, y0, 0.0), Point3::new(x0 + s, y0 + s, 0.0), Point3::new(x0, y0 + s, 0.0)]
    }

    /// Edge of one bit cell (tag edge over bits plus both borders), metres.
    pub fn cell_m(&self) -> f64 {
        self.tag_m / (self.family.marker_bits() as f64 + 2.0 * f64::from(self.border_bits))
    }

    /// The grid's extent `[x0, y0, x1, y1]`, corner squares included, metres.
    pub fn extent_m(&self) -> [f64; 4] {
        let g = self.spacing * self.tag_m;
        [-g, -g, f64::from(self.tags[0]) * self.pitch_m(), f64::from(self.tags[1]) * self.pitch_m()]
    }

    /// Whether the grid point `(x, y)` (grid frame, metres, y up the page) is dark: a corner
    /// square, a tag's border or black bit (`None` off the grid). Kalibr prints tag `k`'s code
    /// (`kalibr_create_target_pdf`, `generateAprilTag`: black where bit `n i + j` of Kaess's code
    /// is 0, then `rot90(.., 2)`, row `i` from the top of the page), which is OpenCV's marker image
    /// of the same id (`generateImageMarker`, the same AprilTag 2 codes) turned 180 degrees on the
    /// page: the cell `cx` from the left, `cy` from the bottom of the bits is black where
    /// OpenCV's code has a 0 at row `cy`, column `n - 1 - cx` (checked against Kalibr's drawing
    /// of tags 0-10 in the unit tests).
    pub fn is_dark(&self, x: f64, y: f64) -> Option<bool> {
        let [x0, y0, x1, y1] = self.extent_m();
        if !(x >= x0 && y >= y0 && x < x1 && y < y1) {
            return None;
        }
        let (p, g) = (self.pitch_m(), self.spacing * self.tag_m);
        // Period along each axis (the gap before a tag, then the tag) and the offset from the
        // tag's start (negative in the gap).
        let split = |v: f64| {
            let i = ((v + g) / p).floor().max(0.0);
            (i as u32, v - i * p)
        };
        let ((i, u), (j, v)) = (split(x), split(y));
        match (u < 0.0 || i >= self.tags[0], v < 0.0 || j >= self.tags[1]) {
            (true, true) => return Some(true),
            (true, false) | (false, true) => return Some(false),
            (false, false) => {}
        }
        let (n, b) = (self.family.marker_bits(), self.border_bits as usize);
        let last = n + 2 * b - 1;
        let (cx, cy) = (((u / self.cell_m()) as usize).min(last), ((v / self.cell_m()) as usize).min(last));
        if cx < b || cy < b || cx > last - b || cy > last - b {
            return Some(true);
        }
        let code = self.family.code((self.first_id + self.tags[0] * j + i) as usize)?;
        Some(!code[(cy - b) * n + (n - 1 + b - cx)])
    }

    /// The tag corners by id `4 k + c`: corner `c` (Kalibr's order: bottom-left, bottom-right,
    /// top-right, top-left) of tag `k` (counted from `first_id`), metres. Kalibr's own point
    /// index of each is [`Self::tag_point_ids`].
    pub fn corners_by_id_m(&self) -> Vec<Point3<f64>> {
        (0..self.tags[0] * self.tags[1]).flat_map(|k| self.tag_corners_m(k)).collect()
    }

    /// The black squares at the gap crossings: lower-left corner and edge (`spacing x tag_m`),
    /// metres, `(nx + 1) x (ny + 1)` of them, row by row from the bottom.
    pub fn corner_squares_m(&self) -> Vec<([f64; 2], f64)> {
        let [nx, ny] = self.tags;
        let (p, g) = (self.pitch_m(), self.spacing * self.tag_m);
        (0..=ny).flat_map(|j| (0..=nx).map(move |i| ([f64::from(i) * p - g, f64::from(j) * p - g], g))).collect()
    }
}

/// An AprilGrid as a scene target: the grid and how it is printed (its frame's z points out of
/// the page, towards the viewer: [`super::Target::front_from_target`]).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct AprilGridTarget {
    /// The grid's geometry and codes.
    pub grid: AprilGrid,
    /// Border and grey levels.
    pub look: BoardLook,
}

impl AprilGridTarget {
    /// Checks the grid and its look.
    ///
    /// # Errors
    /// [`TargetError::InvalidField`] naming the field.
    pub fn validate(&self) -> Result<(), TargetError> {
        self.grid.validate()?;
        self.look.validate()
    }

    /// Grey level at a point of the grid's plane (grid frame, metres).
    pub fn intensity_at(&self, x: f64, y: f64) -> f64 {
        self.look.grey(self.grid.is_dark(x, y), x, y, self.grid.extent_m())
    }

    /// The grid's cell lattice: per period the gap, then the tag's bit cells (borders included).
    pub fn lattice(&self) -> CellLattice {
        let g = &self.grid;
        let gap = g.spacing * g.tag_m;
        let per = g.family.marker_bits() as u32 + 2 * g.border_bits + 1;
        CellLattice::new(g.pitch_m(), -gap, gap, g.cell_m(), per, [g.tags[0] * per + 1, g.tags[1] * per + 1], |x, y| g.is_dark(x, y) == Some(true))
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn two_by_two() -> AprilGrid {
        AprilGrid { tags: [2, 2], ..Default::default() }
    }

    #[test]
    fn points_and_tag_corners_follow_kalibrs_order() {
        // Kalibr's diagram for a 2 x 2 grid (GridCalibrationTargetAprilgrid.cpp):
        //   12-13 14-15 / 8-9 10-11 (tags 2, 3) over 4-5 6-7 / 0-1 2-3 (tags 0, 1), y up.
        let g = two_by_two();
        assert_eq!(g.validate(), Ok(()));
        let p = g.points_m();
        assert_eq!(p.len(), 16);
        // tagSize 0.088, tagSpacing 0.3: the second tag column starts at 1.3 x 0.088 = 0.1144.
        let expect = [(0, 0.0, 0.0), (1, 0.088, 0.0), (2, 0.1144, 0.0), (3, 0.2024, 0.0), (4, 0.0, 0.088), (8, 0.0, 0.1144), (15, 0.2024, 0.2024)];
        for (i, x, y) in expect {
            assert!((p[i].x - x).abs() < 1e-12 && (p[i].y - y).abs() < 1e-12 && p[i].z == 0.0, "point {i}: {}", p[i]);
        }
        assert_eq!(g.tag_point_ids(0), [0, 1, 5, 4]);
        assert_eq!(g.tag_point_ids(1), [2, 3, 7, 6]);
        assert_eq!(g.tag_point_ids(3), [10, 11, 15, 14]);
        for k in 0..4 {
            for (id, c) in g.tag_point_ids(k).iter().zip(g.tag_corners_m(k)) {
                assert!((p[*id as usize] - c).norm() < 1e-12, "tag {k} point {id}");
            }
        }
    }

    #[test]
    fn gap_squares_sit_at_every_crossing() {
        let g = two_by_two();
        let sq = g.corner_squares_m();
        assert_eq!(sq.len(), 9);
        // Kalibr draws one at each tag corner, outside it: tag 0's bottom-left square spans
        // [-0.0264, 0] and tag 0's top-right one [0.088, 0.1144], shared with tag 3's bottom-left.
        let gap = 0.3 * 0.088;
        assert!((sq[0].0[0] + gap).abs() < 1e-12 && (sq[0].0[1] + gap).abs() < 1e-12 && (sq[0].1 - gap).abs() < 1e-12);
        assert!((sq[4].0[0] - 0.088).abs() < 1e-12 && (sq[4].0[1] - 0.088).abs() < 1e-12);
    }

    /// Kalibr's drawing of tag `k` (`generateAprilTag`, its code list from Kaess's AprilTags C++
    /// library): the 6 x 6 bits read from the top of the page, `true` black.
    fn kalibr_bits(code: u64) -> [[bool; 6]; 6] {
        let m: [[bool; 6]; 6] = std::array::from_fn(|i| std::array::from_fn(|j| code & (1 << (6 * i + j)) == 0));
        // np.rot90(m, 2), then row i drawn at height (border - 1 + 6 - i) bits: row 0 on top.
        std::array::from_fn(|i| std::array::from_fn(|j| m[5 - i][5 - j]))
    }

    #[test]
    fn tags_are_coloured_as_kalibr_prints_them() {
        // Kalibr's t36h11 codes 0..=10 (kalibr_create_target_pdf, AprilTagCodes.t36h11).
        let codes: [u64; 11] =
            [0xd5d628584, 0xd97f18b49, 0xdd280910e, 0xe479e9c98, 0xebcbca822, 0xf31dab3ac, 0x056a5d085, 0x10652e1d4, 0x22b1dfead, 0x265ad0472, 0x34fe91b86];
        let g = AprilGrid { tags: [4, 3], ..Default::default() };
        let (p, cell) = (g.pitch_m(), g.cell_m());
        for (k, code) in codes.iter().enumerate() {
            let (tx, ty) = (k as u32 % 4, k as u32 / 4);
            let bits = kalibr_bits(*code);
            for (r, row) in bits.iter().enumerate() {
                for (c, black) in row.iter().enumerate() {
                    // Cell (c, r) of the bits, r from the top: 2 border bits, y up the page.
                    let x = f64::from(tx) * p + (2.5 + c as f64) * cell;
                    let y = f64::from(ty) * p + (2.5 + (5 - r) as f64) * cell;
                    assert_eq!(g.is_dark(x, y), Some(*black), "tag {k} bit row {r} col {c}");
                }
            }
            // The two-bit border and the gap around it.
            assert_eq!(g.is_dark(f64::from(tx) * p + 1.5 * cell, f64::from(ty) * p + 5.0 * cell), Some(true));
            assert_eq!(g.is_dark(f64::from(tx) * p - 0.5 * g.spacing * g.tag_m, f64::from(ty) * p + 5.0 * cell), Some(false));
        }
        // Corner squares at the gap crossings, nothing beyond the grid.
        let gap = g.spacing * g.tag_m;
        assert_eq!(g.is_dark(-0.5 * gap, -0.5 * gap), Some(true));
        assert_eq!(g.is_dark(4.0 * p - 0.5 * gap, 3.0 * p - 0.5 * gap), Some(true));
        assert_eq!(g.is_dark(-1.5 * gap, 0.01), None);
        assert_eq!(g.is_dark(0.01, 3.0 * p + 0.001), None);
    }

    #[test]
    fn bad_grids_name_the_field() {
        let field = |g: AprilGrid| match g.validate() {
            Err(TargetError::InvalidField { field, .. }) => field,
            other => panic!("{other:?}"),
        };
        assert_eq!(field(AprilGrid { tags: [0, 3], ..two_by_two() }), "tags");
        assert_eq!(field(AprilGrid { spacing: 0.0, ..two_by_two() }), "spacing");
        assert_eq!(field(AprilGrid { spacing: f64::NAN, ..two_by_two() }), "spacing");
        assert_eq!(field(AprilGrid { tag_m: -1.0, ..two_by_two() }), "tag_m");
        assert_eq!(field(AprilGrid { border_bits: 3, ..two_by_two() }), "border_bits");
        assert_eq!(field(AprilGrid { tags: [25, 24], ..two_by_two() }), "first_id");
        assert!(AprilGrid { first_id: 583, ..two_by_two() }.validate().is_ok());
    }
}
