//! Grid growing from a seed quad by local neighbour prediction: each new corner is predicted
//! from its row/column neighbours (quadratic extrapolation from the previous two or three, or the
//! parallelogram rule), so curved rows under strong lens distortion are followed without any
//! global homography. A prediction is accepted at the strongest response peak near it that
//! passes the X-junction polarity test with the expected alternating colour.
//!
//! Reference: A. Geiger et al., "Automatic camera and range sensor calibration using a single
//! shot", ICRA 2012 (structure recovery by growing); OpenCV `findChessboardCorners`.

use std::collections::{HashMap, HashSet};
use std::hash::{BuildHasherDefault, Hasher};

use nalgebra::{Point2, Vector2};

use super::response::{peak_subpixel, Candidate, ResponseMap};
use super::xcorner::xcorner_polarity;

/// Tunables of [`grow_grid`].
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct GrowParams {
    /// Search radius around a prediction, as a fraction of the local grid step.
    pub search_frac: f64,
    /// Minimum response of an accepted corner, as a fraction of the seed's response.
    pub min_response_frac: f32,
    /// Minimum response of an accepted corner, as a fraction of its strongest grid neighbour's.
    pub min_neighbour_frac: f32,
    /// Reject a peak farther than this fraction of the step from the prediction.
    pub max_offset_frac: f64,
    /// Minimum brightness difference between light and dark squares, grey levels.
    pub min_contrast: f32,
    /// Stop growing beyond this many corners per side (guards against runaway growth).
    pub max_extent: i32,
}

impl Default for GrowParams {
    fn default() -> Self {
        Self { search_frac: 0.3, min_response_frac: 0.02, min_neighbour_frac: 0.3, max_offset_frac: 0.4, min_contrast: 8.0, max_extent: 64 }
    }
}

/// Predicted position, local step length, and the step vectors along i and j.
pub(crate) type Prediction = (Point2<f64>, f64, Vector2<f64>, Vector2<f64>);

/// Hasher for grid-cell keys (pairs of small integers): each written word is mixed in by a
/// multiply with the 64-bit golden-ratio constant (Fibonacci hashing, Knuth TAOCP vol. 3, 6.4).
/// Much cheaper than the default SipHash, whose flooding resistance buys nothing here.
#[derive(Debug, Default, Clone, Copy)]
pub struct CellHasher(u64);

impl Hasher for CellHasher {
    fn finish(&self) -> u64 {
        self.0
    }

    fn write(&mut self, bytes: &[u8]) {
        for &b in bytes {
            self.mix(u64::from(b));
        }
    }

    fn write_i32(&mut self, v: i32) {
        self.mix(u64::from(v as u32));
    }
}

impl CellHasher {
    #[inline]
    fn mix(&mut self, v: u64) {
        self.0 = (self.0.rotate_left(29) ^ v).wrapping_mul(0x9E37_79B9_7F4A_7C15);
    }
}

/// Map from grid cell (i, j) to a value.
pub type CellMap<V> = HashMap<(i32, i32), V, BuildHasherDefault<CellHasher>>;

/// A grown grid: integer grid coordinates to corner positions.
#[derive(Debug, Clone, Default)]
pub struct Grid {
    /// Corner position per grid cell (i along the first seed direction, j along the second).
    pub cells: CellMap<Point2<f64>>,
    /// Response strength per grid cell.
    pub strength: CellMap<f32>,
    /// Polarity of the corner at (0, 0); corner (i, j) has polarity `polarity0 * (-1)^(i + j)`.
    pub polarity0: i8,
}

impl Grid {
    /// Inclusive bounds (imin, imax, jmin, jmax); `None` when empty.
    pub fn bounds(&self) -> Option<(i32, i32, i32, i32)> {
        let mut it = self.cells.keys();
        let &(i0, j0) = it.next()?;
        let mut b = (i0, i0, j0, j0);
        for &(i, j) in self.cells.keys() {
            b = (b.0.min(i), b.1.max(i), b.2.min(j), b.3.max(j));
        }
        Some(b)
    }

    /// True when every cell of the bounding box is filled.
    pub fn is_full(&self) -> bool {
        self.bounds().is_some_and(|(a, b, c, d)| ((b - a + 1) * (d - c + 1)) as usize == self.cells.len())
    }

    /// Trim weak or incomplete border lines until the bounding box is `ni` x `nj` and full.
    /// A border line is removed only when it is incomplete or its mean response is below half
    /// the grid's median, so a complete, uniformly strong larger board is never cut down.
    pub fn trim_to(&mut self, ni: i32, nj: i32) -> bool {
        let mut all: Vec<f32> = self.strength.values().copied().collect();
        all.sort_by(f32::total_cmp);
        let med = all.get(all.len() / 2).copied().unwrap_or(0.0);
        loop {
            let Some((i0, i1, j0, j1)) = self.bounds() else { return false };
            let (wi, wj) = (i1 - i0 + 1, j1 - j0 + 1);
            if wi < ni || wj < nj {
                return false;
            }
            if wi == ni && wj == nj {
                return self.is_full();
            }
            // candidate lines: (is_i_line, index, fill, mean strength)
            let mut lines = Vec::new();
            if wi > ni {
                lines.push((true, i0));
                lines.push((true, i1));
            }
            if wj > nj {
                lines.push((false, j0));
                lines.push((false, j1));
            }
            let score = |g: &Self, is_i: bool, k: i32| {
                let (mut n, mut sum) = (0usize, 0.0f32);
                let len = if is_i { wj } else { wi };
                for t in 0..len {
                    let key = if is_i { (k, j0 + t) } else { (i0 + t, k) };
                    if let Some(s) = g.strength.get(&key) {
                        n += 1;
                        sum += *s;
                    }
                }
                (n as f64 / len as f64, if n > 0 { sum / n as f32 } else { 0.0 })
            };
            let mut best: Option<(bool, i32, f64, f32)> = None;
            for (is_i, k) in lines {
                let (fill, mean) = score(self, is_i, k);
                if best.is_none_or(|b| (fill, mean) < (b.2, b.3)) {
                    best = Some((is_i, k, fill, mean));
                }
            }
            let Some((is_i, k, fill, mean)) = best else { return false };
            if fill >= 1.0 && mean >= 0.5 * med {
                return false;
            }
            self.cells.retain(|key, _| if is_i { key.0 != k } else { key.1 != k });
            self.strength.retain(|key, _| if is_i { key.0 != k } else { key.1 != k });
        }
    }

    fn get(&self, i: i32, j: i32) -> Option<Vector2<f64>> {
        self.cells.get(&(i, j)).map(|p| p.coords)
    }

    /// Prediction of cell (i, j) from filled neighbours, with the local step length and the two
    /// local grid step vectors (along i, along j).
    pub(crate) fn predict(&self, i: i32, j: i32) -> Option<Prediction> {
        let mut sum = Vector2::zeros();
        let mut n = 0.0;
        let mut step_i: Option<Vector2<f64>> = None;
        let mut step_j: Option<Vector2<f64>> = None;
        for (di, dj) in [(1, 0), (-1, 0), (0, 1), (0, -1)] {
            let (Some(p1), Some(p2)) = (self.get(i - di, j - dj), self.get(i - 2 * di, j - 2 * dj)) else { continue };
            let pred = if let Some(p3) = self.get(i - 3 * di, j - 3 * dj) { 3.0 * p1 - 3.0 * p2 + p3 } else { 2.0 * p1 - p2 };
            sum += pred;
            n += 1.0;
            let s = (p1 - p2) * f64::from(di + dj);
            if di != 0 {
                step_i.get_or_insert(s);
            } else {
                step_j.get_or_insert(s);
            }
        }
        // parallelogram rule from an L of three neighbours
        for (di, dj) in [(1, 1), (1, -1), (-1, 1), (-1, -1)] {
            let (Some(a), Some(b), Some(c)) = (self.get(i - di, j), self.get(i, j - dj), self.get(i - di, j - dj)) else { continue };
            sum += a + b - c;
            n += 1.0;
            step_i.get_or_insert((b - c) * f64::from(di));
            step_j.get_or_insert((a - c) * f64::from(dj));
        }
        if n == 0.0 {
            return None;
        }
        let si = match step_i {
            Some(s) => s,
            None => self.neighbour_step(i, j, true)?,
        };
        let sj = match step_j {
            Some(s) => s,
            None => self.neighbour_step(i, j, false)?,
        };
        let step = si.norm().min(sj.norm());
        Some((Point2::from(sum / n), step, si, sj))
    }

    /// Each single prediction of cell (i, j) that [`Grid::predict`] averages, and the linear
    /// extrapolations beside the quadratic ones: alternatives to try where the average misses
    /// (a quadratic extrapolation overshoots where the distortion changes fast).
    pub(crate) fn predictions(&self, i: i32, j: i32) -> Vec<Point2<f64>> {
        let mut out = Vec::new();
        for (di, dj) in [(1, 0), (-1, 0), (0, 1), (0, -1)] {
            let (Some(p1), Some(p2)) = (self.get(i - di, j - dj), self.get(i - 2 * di, j - 2 * dj)) else { continue };
            out.push(Point2::from(2.0 * p1 - p2));
            if let Some(p3) = self.get(i - 3 * di, j - 3 * dj) {
                out.push(Point2::from(3.0 * p1 - 3.0 * p2 + p3));
            }
        }
        for (di, dj) in [(1, 1), (1, -1), (-1, 1), (-1, -1)] {
            if let (Some(a), Some(b), Some(c)) = (self.get(i - di, j), self.get(i, j - dj), self.get(i - di, j - dj)) {
                out.push(Point2::from(a + b - c));
            }
        }
        out
    }

    /// A step vector along i (`along_i`) or j taken from any filled 4-neighbour pair near (i, j).
    fn neighbour_step(&self, i: i32, j: i32, along_i: bool) -> Option<Vector2<f64>> {
        for (ci, cj) in [(i - 1, j), (i + 1, j), (i, j - 1), (i, j + 1)] {
            let Some(c) = self.get(ci, cj) else { continue };
            let (a, b) = if along_i { ((ci + 1, cj), (ci - 1, cj)) } else { ((ci, cj + 1), (ci, cj - 1)) };
            if let Some(n) = self.get(a.0, a.1) {
                return Some(n - c);
            }
            if let Some(n) = self.get(b.0, b.1) {
                return Some(c - n);
            }
        }
        None
    }
}

/// Strongest response pixel within `radius` of `p` (at least `min_r`), sub-pixel.
fn best_peak(resp: &ResponseMap, p: Point2<f64>, radius: f64, min_r: f32) -> Option<(Point2<f64>, f32)> {
    let r = &resp.response;
    let (w, h) = (r.width as i64, r.height as i64);
    if !p.x.is_finite() || !p.y.is_finite() {
        return None;
    }
    let rad = radius.max(1.0);
    // the search disk clipped to the response's interior (corners near the image border are
    // searched where they can be: refusing the whole disk would lose every corner within a
    // search radius of the border)
    let (x0, x1) = (((p.x - rad).floor() as i64).max(1), ((p.x + rad).ceil() as i64).min(w - 2));
    let (y0, y1) = (((p.y - rad).floor() as i64).max(1), ((p.y + rad).ceil() as i64).min(h - 2));
    if x0 > x1 || y0 > y1 {
        return None;
    }
    let mut best: Option<(usize, usize, f32)> = None;
    for y in y0..=y1 {
        for x in x0..=x1 {
            let d2 = (x as f64 - p.x).powi(2) + (y as f64 - p.y).powi(2);
            if d2 > rad * rad {
                continue;
            }
            let v = r.data[y as usize * r.width + x as usize];
            if v >= min_r && best.is_none_or(|b| v > b.2) {
                best = Some((x as usize, y as usize, v));
            }
        }
    }
    let (mut x, mut y, mut v) = best?;
    // hill-climb to the local maximum (the disk may cut a slope towards a stronger peak)
    for _ in 0..64 {
        if x < 1 || y < 1 || x + 1 >= r.width || y + 1 >= r.height {
            break;
        }
        let mut moved = false;
        for (dx, dy) in [(-1i64, -1i64), (0, -1), (1, -1), (-1, 0), (1, 0), (-1, 1), (0, 1), (1, 1)] {
            let (xx, yy) = ((x as i64 + dx) as usize, (y as i64 + dy) as usize);
            let u = r.data[yy * r.width + xx];
            if u > v {
                (x, y, v, moved) = (xx, yy, u, true);
            }
        }
        if !moved {
            break;
        }
    }
    let q = peak_subpixel(r, x, y);
    ((q - p).norm() <= 1.5 * rad).then_some((q, v))
}

/// Try to start a grid at candidate `seed` with neighbouring candidates `near` (nearest first).
/// Returns the grown grid or `None` when no valid seed quad exists.
pub fn grow_grid(resp: &ResponseMap, seed: &Candidate, near: &[Candidate], params: &GrowParams) -> Option<Grid> {
    let c = seed.point;
    let min_r = seed.strength * params.min_response_frac;
    let k = near.len().min(6);
    for a_idx in 0..k {
        for b_idx in (a_idx + 1)..k {
            if near[a_idx].strength < params.min_neighbour_frac * seed.strength || near[b_idx].strength < params.min_neighbour_frac * seed.strength {
                continue;
            }
            let (u, v) = (near[a_idx].point - c, near[b_idx].point - c);
            let (lu, lv) = (u.norm(), v.norm());
            if lu < 3.0 || lv < 3.0 || lu > 2.5 * lv || lv > 2.5 * lu {
                continue;
            }
            let cosang = u.dot(&v) / (lu * lv);
            if cosang.abs() > 0.8 {
                continue;
            }
            let Some(pol) = xcorner_polarity(&resp.smooth, c, u, v, params.min_contrast) else { continue };
            let mut g = Grid { cells: CellMap::default(), strength: CellMap::default(), polarity0: pol };
            g.strength.insert((0, 0), seed.strength);
            g.strength.insert((1, 0), near[a_idx].strength);
            g.strength.insert((0, 1), near[b_idx].strength);
            g.cells.insert((0, 0), c);
            g.cells.insert((1, 0), near[a_idx].point);
            g.cells.insert((0, 1), near[b_idx].point);
            // corners (1,0) and (0,1) must have the opposite polarity
            let ok = [(1, 0, near[a_idx].point), (0, 1, near[b_idx].point)]
                .iter()
                .all(|&(_, _, p)| xcorner_polarity(&resp.smooth, p, u, v, params.min_contrast) == Some(-pol));
            if !ok {
                continue;
            }
            if !try_add(&mut g, resp, 1, 1, min_r, params) {
                continue;
            }
            grow(&mut g, resp, min_r, params);
            return Some(g);
        }
    }
    None
}

/// Predict, search and validate cell (i, j); insert on success.
fn try_add(g: &mut Grid, resp: &ResponseMap, i: i32, j: i32, min_r: f32, params: &GrowParams) -> bool {
    let Some((pred, step, si, sj)) = g.predict(i, j) else { return false };
    if !(step > 2.0) {
        return false;
    }
    let nb_strength = [(1, 0), (-1, 0), (0, 1), (0, -1)].iter().filter_map(|(di, dj)| g.strength.get(&(i + di, j + dj)).copied()).fold(0.0f32, f32::max);
    let min_r = min_r.max(nb_strength * params.min_neighbour_frac);
    let reject = |why: &str| log::trace!("cell ({i}, {j}) at ({:.1}, {:.1}), step {step:.1}: {why}", pred.x, pred.y);
    let Some((p, strength)) = best_peak(resp, pred, params.search_frac * step, min_r) else {
        reject("no peak strong enough");
        return false;
    };
    let expect = if (i + j).rem_euclid(2) == 0 { g.polarity0 } else { -g.polarity0 };
    if (p - pred).norm() > params.max_offset_frac * step || xcorner_polarity(&resp.smooth, p, si, sj, params.min_contrast) != Some(expect) {
        reject("peak too far, or not an X-junction of the expected polarity");
        return false;
    }
    // no duplicate of an existing neighbour (diagonal ones too)
    for (di, dj) in [(1, 0), (-1, 0), (0, 1), (0, -1), (1, 1), (1, -1), (-1, 1), (-1, -1)] {
        if g.get(i + di, j + dj).is_some_and(|q| (q - p.coords).norm() < 0.5 * step) {
            return false;
        }
    }
    g.cells.insert((i, j), p);
    g.strength.insert((i, j), strength);
    true
}

/// Grow until no empty 4-neighbour of the grid can be added.
fn grow(g: &mut Grid, resp: &ResponseMap, min_r: f32, params: &GrowParams) {
    let mut tried_fail: HashSet<(i32, i32), BuildHasherDefault<CellHasher>> = HashSet::default();
    loop {
        let mut frontier: Vec<(i32, i32)> = Vec::new();
        for &(i, j) in g.cells.keys() {
            for (di, dj) in [(1, 0), (-1, 0), (0, 1), (0, -1)] {
                let c = (i + di, j + dj);
                if !g.cells.contains_key(&c) && !tried_fail.contains(&c) && c.0.abs() <= params.max_extent && c.1.abs() <= params.max_extent {
                    frontier.push(c);
                }
            }
        }
        frontier.sort_unstable();
        frontier.dedup();
        if frontier.is_empty() {
            return;
        }
        let mut added = false;
        for (i, j) in frontier {
            if try_add(g, resp, i, j, min_r, params) {
                added = true;
                // a new cell may enable predictions at failed neighbours
                for (di, dj) in [(1, 0), (-1, 0), (0, 1), (0, -1), (1, 1), (1, -1), (-1, 1), (-1, -1)] {
                    tried_fail.remove(&(i + di, j + dj));
                }
            } else {
                tried_fail.insert((i, j));
            }
        }
        if !added {
            return;
        }
    }
}
