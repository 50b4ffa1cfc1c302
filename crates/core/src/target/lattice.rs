//! The cell lattice of a coded board: every edge of a ChArUco board (squares, marker borders,
//! marker bits) lies on a line of one lattice, the same along x and y, so the board is a grid of
//! axis-aligned cells, each wholly dark or wholly light. The renderer shades such a grid exactly
//! (the area of a pixel in each dark cell), and its flat-tile test needs only the lines.
//!
//! Along an axis the lattice repeats with period `period_m` from `origin_m`; a period is cut at
//! `first_m` and then every `cell_m`: sub-interval 0 is `[0, first_m)`, sub-intervals 1 ..
//! `per_period - 1` are cells of `cell_m`, the last one ending at the period's end. Global index
//! `g = period * per_period + sub` numbers the sub-intervals from the origin; the board covers
//! `g = 0 .. cells[axis]` (`[origin_m, end_m[axis])`).

/// A board's cell lattice (see the module docs).
#[derive(Debug, Clone, PartialEq)]
pub struct CellLattice {
    /// Period, metres.
    pub period_m: f64,
    /// Board coordinate where period 0 starts (both axes), metres.
    pub origin_m: f64,
    /// Width of sub-interval 0 of each period, metres.
    pub first_m: f64,
    /// Width of the cells after it, metres.
    pub cell_m: f64,
    /// Sub-intervals per period.
    pub per_period: u32,
    /// Sub-intervals of the board along x and y.
    pub cells: [u32; 2],
    /// Dark cells, one bit each at `gy * cells[0] + gx` (bit `k % 32` of word `k / 32`).
    pub dark_bits: Vec<u32>,
}

impl CellLattice {
    /// The lattice with the colour of each cell taken from `is_dark` at the cell's centre.
    pub fn new(period_m: f64, origin_m: f64, first_m: f64, cell_m: f64, per_period: u32, cells: [u32; 2], is_dark: impl Fn(f64, f64) -> bool) -> Self {
        let mut l = Self { period_m, origin_m, first_m, cell_m, per_period, cells, dark_bits: Vec::new() };
        let n = cells[0] as usize * cells[1] as usize;
        let mut bits = vec![0u32; n.div_ceil(32).max(1)];
        for gy in 0..cells[1] {
            let (y0, y1) = l.bounds(gy);
            for gx in 0..cells[0] {
                let (x0, x1) = l.bounds(gx);
                if is_dark(0.5 * (x0 + x1), 0.5 * (y0 + y1)) {
                    let k = gy as usize * cells[0] as usize + gx as usize;
                    bits[k / 32] |= 1 << (k % 32);
                }
            }
        }
        l.dark_bits = bits;
        l
    }

    /// The extent `[lo, hi)` of sub-interval `g` along an axis, metres.
    pub fn bounds(&self, g: u32) -> (f64, f64) {
        let (period, sub) = (g / self.per_period, g % self.per_period);
        let start = self.origin_m + f64::from(period) * self.period_m;
        let lo = if sub == 0 { 0.0 } else { self.first_m + f64::from(sub - 1) * self.cell_m };
        let hi = if sub + 1 == self.per_period { self.period_m } else { self.first_m + f64::from(sub) * self.cell_m };
        (start + lo, start + hi)
    }

    /// End of the board along `axis` (0: x, 1: y), metres.
    pub fn end_m(&self, axis: usize) -> f64 {
        self.bounds(self.cells[axis].saturating_sub(1)).1
    }

    /// Every line of the lattice on the board along `axis`, ascending, ends included.
    pub fn lines_m(&self, axis: usize) -> Vec<f64> {
        (0..self.cells[axis]).map(|g| self.bounds(g).0).chain([self.end_m(axis)]).collect()
    }

    /// Whether cell `(gx, gy)` is dark (`false` off the board).
    pub fn is_dark(&self, gx: u32, gy: u32) -> bool {
        if gx >= self.cells[0] || gy >= self.cells[1] {
            return false;
        }
        let k = gy as usize * self.cells[0] as usize + gx as usize;
        self.dark_bits.get(k / 32).is_some_and(|w| w >> (k % 32) & 1 == 1)
    }

    /// The sub-interval holding `v` along an axis (below 0 before the board; `cells` and beyond
    /// past it); the CPU twin of the shader's `lat_index`.
    pub fn index(&self, v: f64) -> i64 {
        let per = i64::from(self.per_period);
        let t = ((v - self.origin_m) / self.period_m).floor();
        let u = v - self.origin_m - t * self.period_m;
        let sub = if u < self.first_m { 0 } else { (1 + ((u - self.first_m) / self.cell_m).floor() as i64).min(per - 1) };
        t as i64 * per + sub
    }

    /// Whether every cell meeting the box `[x0, y0, x1, y1]` (metres) has one colour: `true`
    /// for a box wholly off the board, `false` for one that straddles its outline.
    pub fn uniform_over(&self, [x0, y0, x1, y1]: [f64; 4]) -> bool {
        let (gx0, gx1, gy0, gy1) = (self.index(x0), self.index(x1), self.index(y0), self.index(y1));
        let (nx, ny) = (i64::from(self.cells[0]), i64::from(self.cells[1]));
        if gx1 < 0 || gy1 < 0 || gx0 >= nx || gy0 >= ny {
            return true;
        }
        if gx0 < 0 || gy0 < 0 || gx1 >= nx || gy1 >= ny {
            return false;
        }
        let first = self.is_dark(gx0 as u32, gy0 as u32);
        (gy0..=gy1).all(|gy| (gx0..=gx1).all(|gx| self.is_dark(gx as u32, gy as u32) == first))
    }

    /// The narrowest sub-interval, metres.
    pub fn min_cell_m(&self) -> f64 {
        let last = self.period_m - self.first_m - f64::from(self.per_period.saturating_sub(2)) * self.cell_m;
        self.first_m.min(self.cell_m).min(last)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn bounds_tile_each_period_without_gaps() {
        // ChArUco-like: square 0.04, marker 0.03 with 5 x 5 bits: inset 0.005, cells of 0.03 / 7.
        let l = CellLattice::new(0.04, 0.0, 0.005, 0.03 / 7.0, 9, [18, 9], |x, _| x < 0.02);
        assert_eq!(l.bounds(0), (0.0, 0.005));
        let (lo, hi) = l.bounds(8);
        assert!((lo - 0.035).abs() < 1e-15 && hi == 0.04, "{lo} {hi}");
        assert_eq!(l.bounds(9), (0.04, 0.045));
        for g in 0..17 {
            assert!((l.bounds(g).1 - l.bounds(g + 1).0).abs() < 1e-15, "gap after {g}");
        }
        assert_eq!(l.lines_m(0).len(), 19);
        assert!((l.end_m(0) - 0.08).abs() < 1e-15);
        assert!(l.is_dark(0, 0) && !l.is_dark(9, 0) && !l.is_dark(18, 0));
        assert!((l.min_cell_m() - 0.03 / 7.0).abs() < 1e-15);
        // index inverts bounds; the dark half (x < 0.02: cells 0..=4) is uniform.
        for g in 0..18 {
            let (lo, hi) = l.bounds(g);
            assert_eq!(l.index(0.5 * (lo + hi)), i64::from(g));
        }
        assert_eq!(l.index(-0.001), -1);
        assert!(l.uniform_over([0.001, 0.001, 0.015, 0.035]) && !l.uniform_over([0.001, 0.001, 0.025, 0.01]));
        assert!(!l.uniform_over([0.001, 0.001, 0.015, 0.3]), "a box that leaves the board");
        assert!(!l.uniform_over([-0.001, 0.001, 0.002, 0.002]));
        assert!(l.uniform_over([-0.01, 0.001, -0.002, 0.002]) && l.uniform_over([0.001, 0.5, 0.002, 0.6]));
    }
}
