//! The soft-shadow lattice: under an area light, the share `V` of the emitter the objects leave
//! visible from a board point is a smooth function of the point, so it is integrated over the
//! emitter (`shaders/objects.wgsl` `light_share`) on a lattice of image points and the pixels
//! take it bilinearly where the lattice shows that to be within [`V_TOLERANCE`] (their
//! irradiance stays exact: `(A + E V) / (A + E)` per sub-pixel point). Two levels: the corners
//! of the image's 8 x 8 tiles, with their centres; where a tile fails, the corners of its four
//! 4 x 4 quads, with theirs. `V` is computed on the target's plane past the sheet's edge too
//! (it is smooth there), for the tiles near the sheet ([`near_sheet`]). Elsewhere (cells wholly
//! in full light or umbra, where a shadow narrower than a cell could hide; kinks where the
//! penumbra meets full light; contact shadows) every pixel integrates its own.
//!
//! The check is a posteriori, on the computed values: bilinear interpolation over a cell of
//! side `h` errs by at most `h^2 / 8 (|V_xx| + |V_yy|)`; the lattice's second differences along
//! x and y at the cell's corners estimate `h^2 V_xx` and `h^2 V_yy`, and the cell's centre, also
//! computed, must lie within the tolerance of the corners' mean (a saddle's curvatures cancel in
//! a sum, not at the centre; an occluder's shadow narrower than the cell shows there).
//! Reference: interpolation between sparse irradiance samples where their differences say it
//! holds, refined where not, as in irradiance caching (G. Ward, F. Rubinstein, R. Clear, *A ray
//! tracing solution for diffuse interreflection*, SIGGRAPH 1988).

use nalgebra::Vector3;

use super::tiles::TileCornerRays;
use super::uniforms::Params;

/// Largest estimated interpolation error of the visible share in an interpolated cell: at most
/// `V_TOLERANCE E / (A + E)` of a pixel's lit value, 0.5 grey levels on white (255) under a light
/// far brighter than the ambient term, 0.37 on the gripper's board. About the scatter of the
/// per-point integral's rows between neighbouring points, so that cells are not refused for
/// it. Measured against independent references (`tests/e2e/area_light.rs`, see BENCHMARKS.md).
pub(super) const V_TOLERANCE: f32 = 2e-3;

/// The tiles of `tiles` (`i | j << 16`) within their own size of the printed sheet on the
/// target's plane (the plane points of their corner rays `grid` through the homography
/// `params.h0..h2`, their box grown by its extent, against `params.sheet`), or whose corners do
/// not all meet the plane in front: `V` beyond serves no sheet pixel, and the lattice is computed
/// on the plane past the sheet's edge (smooth there) only for these tiles' cells.
pub(super) fn near_sheet(tiles: &[u32], grid: &TileCornerRays, params: &Params) -> Vec<u32> {
    let row = |h: [f32; 4]| Vector3::new(f64::from(h[0]), f64::from(h[1]), f64::from(h[2]));
    let (h0, h1, h2) = (row(params.h0), row(params.h1), row(params.h2));
    let [x0, y0, x1, y1] = params.sheet.map(f64::from);
    let near = |t: &u32| {
        let Some(rays) = grid.tile(t & 0xffff, t >> 16) else { return true };
        let mut lo = [f64::INFINITY; 2];
        let mut hi = [f64::NEG_INFINITY; 2];
        for d in &rays {
            let w = h2.dot(d);
            if !(w > 0.0) {
                return true;
            }
            for (k, h) in [h0, h1].iter().enumerate() {
                lo[k] = lo[k].min(h.dot(d) / w);
                hi[k] = hi[k].max(h.dot(d) / w);
            }
        }
        let grow = (hi[0] - lo[0]).max(hi[1] - lo[1]);
        lo[0] - grow <= x1 && hi[0] + grow >= x0 && lo[1] - grow <= y1 && hi[1] + grow >= y0
    };
    tiles.iter().copied().filter(near).collect()
}

/// Work items of the lattice pass: a lattice point `a | b << 16` (image point `(4 a - 0.5,
/// 4 b - 0.5)`), with this bit the centre of quad `(a, b)`.
const CENTRE: u32 = 1 << 31;

/// How a quad's pixels take `V` (`shaders/objects.wgsl` `lattice_mode`).
const PER_PIXEL: f32 = 0.0;
const FROM_QUAD: f32 = 1.0;
const FROM_TILE: f32 = 2.0;

/// The lattice of an image of `tiles_x` x `tiles_y` tiles: points `(a, b)`, `a <= 2 tiles_x`,
/// `b <= 2 tiles_y`; tile `(i, j)`'s corners are the points `(2 i, 2 j)` ... `(2 i + 2, 2 j + 2)`,
/// its centre `(2 i + 1, 2 j + 1)`.
#[derive(Debug, Clone, PartialEq)]
pub(super) struct Lattice {
    tiles_x: u32,
    tiles_y: u32,
    /// `V` per point; NaN where not computed, negative where the ray misses the target's plane.
    points: Vec<f32>,
    /// `V` at the quads' centres (NaN where not computed).
    centres: Vec<f32>,
    /// Per quad, how its pixels take `V`.
    modes: Vec<f32>,
}

impl Lattice {
    pub(super) fn new(tiles_x: u32, tiles_y: u32) -> Self {
        let (w, h) = (2 * tiles_x as usize + 1, 2 * tiles_y as usize + 1);
        let quads = 4 * tiles_x as usize * tiles_y as usize;
        Self { tiles_x, tiles_y, points: vec![f32::NAN; w * h], centres: vec![f32::NAN; quads], modes: vec![PER_PIXEL; quads] }
    }

    /// Rows of 4 f32 the lattice takes in the objects' buffer: the points, then a mode per quad.
    pub(super) fn rows(tiles_x: u32, tiles_y: u32) -> usize {
        ((2 * tiles_x as usize + 1) * (2 * tiles_y as usize + 1) + 4 * tiles_x as usize * tiles_y as usize).div_ceil(4)
    }

    fn point(&self, a: u32, b: u32) -> usize {
        b as usize * (2 * self.tiles_x as usize + 1) + a as usize
    }

    fn quad(&self, a: u32, b: u32) -> usize {
        b as usize * 2 * self.tiles_x as usize + a as usize
    }

    /// `V` at point `(a, b)` where computed and on the target's plane.
    fn at(&self, a: i64, b: i64) -> Option<f32> {
        let inside = (0..=2 * i64::from(self.tiles_x)).contains(&a) && (0..=2 * i64::from(self.tiles_y)).contains(&b);
        inside.then(|| self.points[self.point(a as u32, b as u32)]).filter(|v| *v >= 0.0)
    }

    /// The first pass's points: the corners of `tiles` (`i | j << 16`) and of the tiles around
    /// them (second differences), and the tiles' centres.
    pub(super) fn tile_work(&self, tiles: &[u32]) -> Vec<u32> {
        let mut items = Vec::new();
        let mut seen = vec![false; self.points.len()];
        for t in tiles {
            let (i, j) = (t & 0xffff, t >> 16);
            for b in (j.saturating_sub(1)..=(j + 2).min(self.tiles_y)).map(|j| 2 * j) {
                for a in (i.saturating_sub(1)..=(i + 2).min(self.tiles_x)).map(|i| 2 * i) {
                    self.add(&mut items, &mut seen, a, b);
                }
            }
        }
        items.extend(tiles.iter().map(|t| (2 * (t & 0xffff) + 1) | ((2 * (t >> 16) + 1) << 16)));
        items
    }

    fn add(&self, items: &mut Vec<u32>, seen: &mut [bool], a: u32, b: u32) {
        let k = self.point(a, b);
        if !seen[k] && self.points[k].is_nan() {
            seen[k] = true;
            items.push(a | (b << 16));
        }
    }

    /// Record a pass's `values` of its `work` items.
    pub(super) fn record(&mut self, work: &[u32], values: &[f32]) {
        for (item, v) in work.iter().zip(values) {
            let (a, b) = (item & 0xffff, (item >> 16) & 0x7fff);
            if item & CENTRE != 0 {
                let q = self.quad(a, b);
                self.centres[q] = *v;
            } else {
                let k = self.point(a, b);
                self.points[k] = *v;
            }
        }
    }

    /// Decide the tiles of the first pass; the tiles that failed but lie in a penumbra (some
    /// point strictly between 0 and 1, all on the target's plane), for the second.
    pub(super) fn decide_tiles(&mut self, tiles: &[u32]) -> Vec<u32> {
        let mut failed = Vec::new();
        for t in tiles {
            let (a, b) = (2 * (t & 0xffff), 2 * (t >> 16));
            let centre = self.at(i64::from(a) + 1, i64::from(b) + 1);
            if self.smooth(a, b, 2, centre) {
                for q in [(a, b), (a + 1, b), (a, b + 1), (a + 1, b + 1)] {
                    let k = self.quad(q.0, q.1);
                    self.modes[k] = FROM_TILE;
                }
                continue;
            }
            let block = [(0, 0), (2, 0), (0, 2), (2, 2), (1, 1)].map(|(da, db)| self.at(i64::from(a + da), i64::from(b + db)));
            let on_plane = block.iter().all(Option::is_some);
            if on_plane && block.iter().flatten().any(|v| *v > 0.0 && *v < 1.0) {
                failed.push(*t);
            }
        }
        failed
    }

    /// The second pass's points: around each tile of `failed`, the points of its quads and one
    /// quad beyond, and its quads' centres.
    pub(super) fn quad_work(&self, failed: &[u32]) -> Vec<u32> {
        let mut items = Vec::new();
        let mut seen = vec![false; self.points.len()];
        let (w, h) = (2 * self.tiles_x, 2 * self.tiles_y);
        for t in failed {
            let (a, b) = (2 * (t & 0xffff), 2 * (t >> 16));
            for pb in b.saturating_sub(1)..=(b + 3).min(h) {
                for pa in a.saturating_sub(1)..=(a + 3).min(w) {
                    self.add(&mut items, &mut seen, pa, pb);
                }
            }
            items.extend([(a, b), (a + 1, b), (a, b + 1), (a + 1, b + 1)].map(|(qa, qb)| qa | (qb << 16) | CENTRE));
        }
        items
    }

    /// Decide the quads of the tiles `failed` after the second pass.
    pub(super) fn decide_quads(&mut self, failed: &[u32]) {
        for t in failed {
            let (a, b) = (2 * (t & 0xffff), 2 * (t >> 16));
            for (qa, qb) in [(a, b), (a + 1, b), (a, b + 1), (a + 1, b + 1)] {
                let k = self.quad(qa, qb);
                let centre = Some(self.centres[k]).filter(|v| *v >= 0.0);
                if self.smooth(qa, qb, 1, centre) {
                    self.modes[k] = FROM_QUAD;
                }
            }
        }
    }

    /// Whether the cell of side `step` points from point `(a, b)` may take `V` bilinearly from
    /// its corners, `centre` the value at its centre.
    fn smooth(&self, a: u32, b: u32, step: u32, centre: Option<f32>) -> bool {
        let (a, b, s) = (i64::from(a), i64::from(b), i64::from(step));
        // Every value on the sheet's plane (in [0, 1]) and one strictly inside: a cell wholly in
        // full light or in the umbra keeps its pixels' own test (a shadow narrower than the
        // cell could pass between its points); a kink where the penumbra meets either shows in
        // the second differences below.
        let corners = [(a, b), (a + s, b), (a, b + s), (a + s, b + s)];
        let values: Vec<Option<f32>> = corners.iter().map(|&(x, y)| self.at(x, y)).chain([centre]).collect();
        if values.iter().any(Option::is_none) || !values.iter().flatten().any(|v| *v > 0.0 && *v < 1.0) {
            return false;
        }
        let mean = corners.iter().filter_map(|&(x, y)| self.at(x, y)).sum::<f32>() / 4.0;
        // Second differences along x and y at each corner; a neighbour beyond the image, off the
        // plane or not computed leaves the cell to its pixels.
        let bent = |x: i64, y: i64, dx: i64, dy: i64| match (self.at(x - dx, y - dy), self.at(x, y), self.at(x + dx, y + dy)) {
            (Some(p), Some(c), Some(n)) => (p - 2.0 * c + n).abs() / 8.0,
            _ => f32::INFINITY,
        };
        let curvature = corners.iter().map(|&(x, y)| bent(x, y, s, 0) + bent(x, y, 0, s)).fold(0.0f32, f32::max);
        centre.is_some_and(|c| (c - mean).abs() <= V_TOLERANCE) && curvature <= V_TOLERANCE
    }

    /// Quads whose pixels take `V` from the tile's corners and from their own.
    pub(super) fn counts(&self) -> (usize, usize) {
        (self.modes.iter().filter(|m| **m == FROM_TILE).count(), self.modes.iter().filter(|m| **m == FROM_QUAD).count())
    }

    /// The lattice for the shader: the points (-1 where not computed), then the quads' modes.
    pub(super) fn values(&self) -> Vec<f32> {
        let mut out: Vec<f32> = self.points.iter().map(|v| if v.is_nan() { -1.0 } else { *v }).chain(self.modes.iter().copied()).collect();
        out.resize(Self::rows(self.tiles_x, self.tiles_y) * 4, 0.0);
        out
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Both passes over all tiles of a 6 x 6 tile lattice with `v(x, y)` (pixel coordinates) at
    /// every point computed; the modes of the quads, row-major (12 per row).
    fn modes(v: impl Fn(f32, f32) -> f32) -> Vec<f32> {
        let mut l = Lattice::new(6, 6);
        let tiles: Vec<u32> = (0..6).flat_map(|j| (0..6).map(move |i| i | (j << 16))).collect();
        let eval = |work: &[u32]| -> Vec<f32> {
            let at = |c: u32, centre: bool| (c * 4) as f32 - 0.5 + if centre { 2.0 } else { 0.0 };
            work.iter().map(|w| v(at(w & 0xffff, w & CENTRE != 0), at((w >> 16) & 0x7fff, w & CENTRE != 0))).collect()
        };
        let work = l.tile_work(&tiles);
        l.record(&work, &eval(&work));
        let failed = l.decide_tiles(&tiles);
        let work = l.quad_work(&failed);
        l.record(&work, &eval(&work));
        l.decide_quads(&failed);
        l.modes
    }

    fn count(m: &[f32], mode: f32) -> usize {
        m.iter().filter(|x| **x == mode).count()
    }

    #[test]
    fn near_sheet_keeps_the_tiles_within_their_size_of_the_sheet() {
        // f = 100 px on a 64 x 64 image: tile i spans x = (8 i - 32) / 100 .. (8 i - 24) / 100 on
        // the plane z = 1 (the homography the identity), 0.08 wide; the sheet |x|, |y| <= 0.1.
        let grid = TileCornerRays::new(&synthcam_core::camera::CameraModel::pinhole(64, 64, 100.0));
        let mut params =
            Params { h0: [1.0, 0.0, 0.0, 0.0], h1: [0.0, 1.0, 0.0, 0.0], h2: [0.0, 0.0, 1.0, 0.0], sheet: [-0.1, -0.1, 0.1, 0.1], ..Params::default() };
        let tiles: Vec<u32> = (0..8).flat_map(|j| (0..8).map(move |i| i | (j << 16))).collect();
        let near = near_sheet(&tiles, &grid, &params);
        // Tiles 1..=6 on each axis: tile 1 ends at -0.16, within 0.08 of the sheet's -0.1;
        // tile 0 ends at -0.24.
        assert_eq!(near.len(), 36);
        assert!(near.contains(&(1 | (6 << 16))) && !near.contains(&(3 << 16)) && !near.contains(&7));
        // The plane behind the camera (W < 0 at every corner): every tile, as nothing is known.
        params.h2 = [0.0, 0.0, -1.0, 0.0];
        assert_eq!(near_sheet(&tiles, &grid, &params).len(), 64);
    }

    #[test]
    fn the_first_pass_holds_each_needed_corner_once_and_the_centres() {
        let l = Lattice::new(3, 2);
        let work = l.tile_work(&[1, 2]);
        // Tiles (1, 0) and (2, 0) need the corners x 0..=3, y 0..=2 (the ring, clamped) and their centres.
        assert_eq!(work.len(), 4 * 3 + 2);
        assert_eq!(&work[12..], &[3 | (1 << 16), 5 | (1 << 16)]);
        assert_eq!(Lattice::rows(3, 2), (7 * 5 + 24usize).div_ceil(4));
    }

    #[test]
    fn a_linear_penumbra_is_interpolated_from_the_tiles_inside_and_the_quads_at_the_border() {
        let m = modes(|x, y| 0.1 + 0.01 * x + 0.005 * y);
        // Tile corners 1..=5 have both neighbours on each axis: tiles 1..=4 of each row and
        // column, 16 tiles of 4 quads (quads 2..=9); of the border tiles' quads, those not on
        // the image's edge (quads 1..=10, 100 - 64).
        assert_eq!(count(&m, FROM_TILE), 64);
        assert_eq!(count(&m, FROM_QUAD), 36);
    }

    #[test]
    fn curvature_beyond_the_tolerance_goes_to_the_quads_then_to_the_pixels() {
        // V = 0.3 + c (x - 24)^2: second differences 2 c h^2, estimated error c h^2 / 4 (the
        // centre's departure from the corners' mean too) against the tolerance 2e-3: c = 2e-5
        // passes at h = 8 (3.2e-4); c = 2.5e-4 fails there (4e-3) and passes at h = 4 (1e-3);
        // c = 1e-3 fails both (4e-3 at h = 4).
        assert_eq!(count(&modes(|x, _| 0.3 + 2e-5 * (x - 24.0).powi(2)), FROM_TILE), 64);
        let m = modes(|x, _| 0.3 + 2.5e-4 * (x - 24.0).powi(2));
        assert_eq!((count(&m, FROM_TILE), count(&m, FROM_QUAD) > 64), (0, true));
        let m = modes(|x, _| (0.3 + 1e-3 * (x - 24.0).powi(2)).min(0.9));
        assert_eq!((count(&m, FROM_TILE), count(&m, FROM_QUAD)), (0, 0));
    }

    #[test]
    fn kinks_thin_shadows_and_the_sheets_edge_are_left_to_the_pixels() {
        // Full light (V = 1) beyond x = 30: the quads of tile column 3 on are not interpolated.
        let m = modes(|x, y| if x > 30.0 { 1.0 } else { 0.1 + 0.01 * x + 0.001 * y });
        assert!((0..12).all(|b| m[b * 12 + 7] == PER_PIXEL) && m[2 * 12 + 2] == FROM_TILE);
        // A narrow shadow at tile (2, 2)'s centre only: its corners agree, its centre does not;
        // its quads' centres do not see it, but their corners do.
        let m = modes(|x, y| if (x - 19.5).abs() < 1.0 && (y - 19.5).abs() < 1.0 { 0.2 } else { 0.6 });
        assert!([(4, 4), (5, 4), (4, 5), (5, 5)].iter().all(|(a, b)| m[b * 12 + a] == PER_PIXEL));
        assert_eq!(m[7 * 12 + 7], FROM_TILE);
        // Points off the sheet (-1) left of x = 0 and above y = 8: tile (1, 1) fails (its
        // corner (2, 2)'s neighbour (0, 2) is off), its quad (2, 2) does not; quad (1, 1) does.
        let m = modes(|x, y| if x < 0.0 && y < 8.0 { -1.0 } else { 0.5 });
        assert_eq!((m[12 + 1], m[2 * 12 + 2], m[4 * 12 + 4]), (PER_PIXEL, FROM_QUAD, FROM_TILE));
    }
}
