//! The documented ordering rule of a found grid (module doc of [`chessboard`](super)).

use nalgebra::Point2;

use super::super::grid::Grid;

/// Apply the documented ordering rule (module doc).
pub(super) fn orient(mut g: Vec<Vec<Point2<f64>>>, cols: usize, rows: usize) -> Vec<Vec<Point2<f64>>> {
    let rowdir = g[0][cols - 1] - g[0][0] + (g[rows - 1][cols - 1] - g[rows - 1][0]);
    let coldir = g[rows - 1][0] - g[0][0] + (g[rows - 1][cols - 1] - g[0][cols - 1]);
    if rowdir.x * coldir.y - rowdir.y * coldir.x < 0.0 {
        for row in &mut g {
            row.reverse();
        }
    }
    let mut options = vec![g.clone(), rot180(&g)];
    if cols == rows {
        let r90 = rot90(&g);
        options.push(rot180(&r90));
        options.push(r90);
    }
    let key = |o: &Vec<Vec<Point2<f64>>>| o[0][0].coords.norm_squared();
    options.into_iter().min_by(|a, b| key(a).total_cmp(&key(b))).unwrap_or(g)
}

fn rot180(g: &[Vec<Point2<f64>>]) -> Vec<Vec<Point2<f64>>> {
    g.iter().rev().map(|r| r.iter().rev().copied().collect()).collect()
}

/// Rotate a square grid by 90 degrees keeping handedness.
fn rot90(g: &[Vec<Point2<f64>>]) -> Vec<Vec<Point2<f64>>> {
    let n = g.len();
    (0..n).map(|r| (0..n).map(|c| g[n - 1 - c][r]).collect()).collect()
}

/// A full grid of exactly cols x rows (either orientation) as rows of `cols` points.
pub(super) fn to_rows(g: &Grid, cols: usize, rows: usize) -> Option<Vec<Vec<Point2<f64>>>> {
    if !g.is_full() {
        return None;
    }
    let (i0, i1, j0, j1) = g.bounds()?;
    let (ni, nj) = ((i1 - i0 + 1) as usize, (j1 - j0 + 1) as usize);
    let along_i = if (ni, nj) == (cols, rows) {
        true
    } else if (ni, nj) == (rows, cols) {
        false
    } else {
        return None;
    };
    let mut out = Vec::with_capacity(rows);
    for r in 0..rows as i32 {
        let mut row = Vec::with_capacity(cols);
        for c in 0..cols as i32 {
            let key = if along_i { (i0 + c, j0 + r) } else { (i0 + r, j0 + c) };
            row.push(*g.cells.get(&key)?);
        }
        out.push(row);
    }
    Some(out)
}

/// Area of the quadrilateral of the four outer corners, px^2.
pub(super) fn polygon_area(g: &[Vec<Point2<f64>>]) -> f64 {
    let (Some(first), Some(last)) = (g.first(), g.last()) else { return 0.0 };
    let (Some(a), Some(b), Some(c), Some(d)) = (first.first(), first.last(), last.last(), last.first()) else { return 0.0 };
    let q = [a, b, c, d];
    let mut s = 0.0;
    for k in 0..4 {
        let (p, n) = (q[k], q[(k + 1) % 4]);
        s += p.x * n.y - n.x * p.y;
    }
    0.5 * s.abs()
}
