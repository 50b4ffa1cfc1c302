//! A board that is not flat: mrcal's two-parameter warp. A printed board held in a frame or
//! glued to a plate sags or bulges; mrcal models it as a paraboloid over the board: the point
//! `(x, y, 0)` of the flat board is at `(x, y, kx (1 - u^2) + ky (1 - v^2))`, with `u`, `v` the
//! point's coordinates normalised to [-1, 1] over the extent of the board's feature points
//! ([`BoardExtent`]). The pattern keeps its `(x, y)` (the model moves points along z only; on
//! a 3 mm sag over 30 cm the arc length differs from the chord by 0.03 mm).
//!
//! Reference: D. Kogan, mrcal, "Board deformation" (<https://mrcal.secretsauce.net/formulation.html#board-deformation>).

use nalgebra::Point3;

/// The board's extent in its own frame (metres or board units), over which mrcal's warp model
/// normalises the board coordinates to [-1, 1].
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct BoardExtent {
    /// Smallest and largest x of the board's points.
    pub x: (f64, f64),
    /// Smallest and largest y of the board's points.
    pub y: (f64, f64),
}

impl BoardExtent {
    /// The extent of a set of board points; `None` when it is degenerate in x or y.
    pub fn of(points: impl IntoIterator<Item = Point3<f64>>) -> Option<Self> {
        let mut e = Self { x: (f64::INFINITY, f64::NEG_INFINITY), y: (f64::INFINITY, f64::NEG_INFINITY) };
        for p in points {
            e.x = (e.x.0.min(p.x), e.x.1.max(p.x));
            e.y = (e.y.0.min(p.y), e.y.1.max(p.y));
        }
        (e.x.1 - e.x.0 > 0.0 && e.y.1 - e.y.0 > 0.0 && (e.x.1 - e.x.0 + e.y.1 - e.y.0).is_finite()).then_some(e)
    }

    /// `(1 - u^2, 1 - v^2)` at the board point `x`, with `u`, `v` its coordinates normalised to
    /// [-1, 1] over the extent: the sag's derivatives with respect to the two warp parameters.
    pub fn warp_basis(&self, x: &Point3<f64>) -> (f64, f64) {
        let u = 2.0 * (x.x - self.x.0) / (self.x.1 - self.x.0) - 1.0;
        let v = 2.0 * (x.y - self.y.0) / (self.y.1 - self.y.0) - 1.0;
        (1.0 - u * u, 1.0 - v * v)
    }
}

/// A board that is not flat (mrcal's model): the point `(x, y, 0)` of the flat board is at
/// `(x, y, kx (1 - u^2) + ky (1 - v^2))`, `u`, `v` normalised over the [`BoardExtent`]; `kx`,
/// `ky` are the sags at the board's centre along its x and y, in the board's units (+z is the
/// board frame's z).
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct Warp {
    /// `[kx, ky]`.
    pub k: [f64; 2],
    /// The extent; `None`: a flat board (the warp is not modelled).
    pub extent: Option<BoardExtent>,
}

impl Warp {
    /// The smallest and largest sag over the rectangle `[x0, y0, x1, y1]` of the board plane (each
    /// axis's term is a parabola: its extremes are at the ends and, inside, at the vertex).
    pub fn z_range(&self, [x0, y0, x1, y1]: [f64; 4]) -> [f64; 2] {
        let Some(e) = self.extent else { return [0.0; 2] };
        let range = |k: f64, lo: f64, hi: f64, (a, b): (f64, f64)| {
            let c = 0.5 * (a + b);
            let term = |x: f64| {
                let u = 2.0 * (x - a) / (b - a) - 1.0;
                k * (1.0 - u * u)
            };
            let mut v = [term(lo), term(hi)].to_vec();
            if lo < c && c < hi {
                v.push(k);
            }
            (v.iter().copied().fold(f64::INFINITY, f64::min), v.iter().copied().fold(f64::NEG_INFINITY, f64::max))
        };
        let (ax, bx) = range(self.k[0], x0, x1, e.x);
        let (ay, by) = range(self.k[1], y0, y1, e.y);
        [ax + ay, bx + by]
    }

    /// The parameter `t` at which the ray `o + t d` (board frame) meets the warped board: the root
    /// of `A t^2 + B t + C = 0` next to the flat plane's (`-o.z / d.z`), in the form that stays
    /// exact as the warp goes to zero (`shaders/planar.wgsl` `warp_view` is the GPU's twin);
    /// `None` where the ray misses the paraboloid or runs parallel to a flat board.
    pub fn intersect(&self, o: &nalgebra::Vector3<f64>, d: &nalgebra::Vector3<f64>) -> Option<f64> {
        let Some(e) = self.extent else { return (d.z != 0.0).then(|| -o.z / d.z) };
        let (sx, sy) = (2.0 / (e.x.1 - e.x.0), 2.0 / (e.y.1 - e.y.0));
        let (ax, bx) = ((o.x - 0.5 * (e.x.0 + e.x.1)) * sx, d.x * sx);
        let (ay, by) = ((o.y - 0.5 * (e.y.0 + e.y.1)) * sy, d.y * sy);
        let [kx, ky] = self.k;
        let qa = kx * bx * bx + ky * by * by;
        let qb = d.z + 2.0 * (kx * ax * bx + ky * ay * by);
        let qc = o.z - kx - ky + kx * ax * ax + ky * ay * ay;
        let disc = qb * qb - 4.0 * qa * qc;
        if disc < 0.0 {
            return None;
        }
        let t = -2.0 * qc / (qb + qb.signum() * disc.sqrt());
        t.is_finite().then_some(t)
    }

    /// The board point `x` (z = 0) on the warped board.
    pub fn apply(&self, x: &Point3<f64>) -> Point3<f64> {
        match self.extent {
            Some(e) => {
                let (bx, by) = e.warp_basis(x);
                Point3::new(x.x, x.y, x.z + self.k[0] * bx + self.k[1] * by)
            }
            None => *x,
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_sag_is_k_at_the_centre_zero_at_the_extent_and_ranged_over_a_sheet() {
        let w = Warp { k: [0.002, -0.001], extent: Some(BoardExtent { x: (0.0, 0.2), y: (0.0, 0.1) }) };
        assert!((w.apply(&Point3::new(0.1, 0.05, 0.0)).z - 0.001).abs() < 1e-15);
        assert!(w.apply(&Point3::new(0.2, 0.0, 0.0)).z.abs() < 1e-15);
        assert!((w.apply(&Point3::new(0.0, 0.05, 0.0)).z + 0.001).abs() < 1e-15);
        // Over a sheet 0.05 beyond the extent: x term 0.002 (1 - 1.5^2) = -0.0025 .. 0.002,
        // y term -0.001 (1 - 2^2) = 0.003 .. -0.001.
        let [lo, hi] = w.z_range([-0.05, -0.05, 0.25, 0.15]);
        assert!((lo - (-0.0025 - 0.001)).abs() < 1e-12 && (hi - (0.002 + 0.003)).abs() < 1e-12, "{lo} {hi}");
        assert_eq!(Warp::default().z_range([0.0, 0.0, 1.0, 1.0]), [0.0; 2]);
    }

    #[test]
    fn rays_meet_the_warped_board_where_its_points_are() {
        let w = Warp { k: [0.003, 0.0015], extent: Some(BoardExtent { x: (0.0, 0.2), y: (0.0, 0.1) }) };
        let o = nalgebra::Vector3::new(0.05, -0.02, -0.5);
        for p in [Point3::new(0.1, 0.05, 0.0), Point3::new(0.01, 0.09, 0.0), Point3::new(0.23, -0.03, 0.0)] {
            let target = w.apply(&p).coords;
            let d = (target - o) * 1.7;
            let t = w.intersect(&o, &d).expect("hit");
            assert!((o + t * d - target).norm() < 1e-15, "{p}");
        }
        // Flat: the plane's root.
        let flat = Warp::default();
        assert_eq!(flat.intersect(&o, &nalgebra::Vector3::new(0.0, 0.0, 2.0)), Some(0.25));
    }
}
