//! Runs of pixels (a row's consecutive set pixels) and their 8- or 4-connected components by
//! union-find over the runs of adjacent rows (one pass, no label image). With 4-connectivity
//! dark shapes that only touch diagonally stay apart (as AprilTag 3 connects dark pixels 4-wise).
//! The markers' threshold and the dot finder's cores give their pixels as runs.
//!
//! Written here rather than with `imageproc::region_labelling::connected_components`, which
//! labels a whole image (a u32 per pixel, one more pass over it: 15 ms of the dot finder's 38 on
//! a 1280 x 1024 S-path render): joining runs touches only the set pixels.
//!
//! Reference: K. Wu, E. Otoo, K. Suzuki, "Optimizing two-pass connected-component labeling
//! algorithms", Pattern Analysis and Applications 12(2), 2009 (run-based union-find).

/// A horizontal run of set pixels: row `y`, columns `x0..x1`.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub(crate) struct Run {
    /// Row.
    pub y: u32,
    /// First column.
    pub x0: u32,
    /// One past the last column.
    pub x1: u32,
}

/// The runs of the pixels of a `width x height` image where `set(x, y)` holds, row by row.
pub(crate) fn runs_where(width: usize, height: usize, set: impl Fn(usize, usize) -> bool) -> Vec<Run> {
    let mut runs = Vec::new();
    for y in 0..height {
        let mut start = None;
        for x in 0..=width {
            match (x < width && set(x, y), start) {
                (true, None) => start = Some(x),
                (false, Some(x0)) => {
                    runs.push(Run { y: y as u32, x0: x0 as u32, x1: x as u32 });
                    start = None;
                }
                _ => {}
            }
        }
    }
    runs
}

/// The pixels of `runs` (row order), shifted by `origin`.
pub(crate) fn run_pixels(runs: &[Run], origin: (usize, usize)) -> Vec<(usize, usize)> {
    runs.iter().flat_map(|r| (r.x0..r.x1).map(move |x| (x as usize + origin.0, r.y as usize + origin.1))).collect()
}

/// Bounding box and size of a component, pixels of the search image.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub(crate) struct Blob {
    /// Leftmost column.
    pub x0: u32,
    /// Top row.
    pub y0: u32,
    /// One past the rightmost column.
    pub x1: u32,
    /// One past the bottom row.
    pub y1: u32,
}

/// Root of run `i` (path halving).
fn find(parent: &mut [u32], mut i: usize) -> usize {
    while parent[i] as usize != i {
        let g = parent[parent[i] as usize];
        parent[i] = g;
        i = g as usize;
    }
    i
}

/// Merge the components of runs `a` and `b` (the smaller root index wins).
fn union(parent: &mut [u32], a: usize, b: usize) {
    let (ra, rb) = (find(parent, a), find(parent, b));
    if ra != rb {
        let (lo, hi) = (ra.min(rb), ra.max(rb));
        parent[hi] = lo as u32;
    }
}

/// Union-find forest over `runs` (in row order): runs of consecutive rows that overlap in a
/// column (or, with `diagonal`, touch diagonally) share a root.
fn link(runs: &[Run], diagonal: bool) -> Vec<u32> {
    let reach = u32::from(diagonal);
    let mut parent: Vec<u32> = (0..runs.len() as u32).collect();
    // runs of the previous row not yet passed (`j..prev_end`), start of the current row
    let (mut j, mut prev_end, mut row_start) = (0, 0, 0);
    for i in 0..runs.len() {
        if i == 0 || runs[i].y != runs[i - 1].y {
            let touching = i > 0 && runs[i - 1].y + 1 == runs[i].y;
            (j, prev_end) = if touching { (row_start, i) } else { (i, i) };
            row_start = i;
        }
        let r = runs[i];
        // runs ending left of this one end left of every later one in the row too
        while j < prev_end && runs[j].x1 + reach <= r.x0 {
            j += 1;
        }
        for (k, p) in runs.iter().enumerate().take(prev_end).skip(j) {
            if p.x0 >= r.x1 + reach {
                break;
            }
            union(&mut parent, i, k);
        }
    }
    parent
}

/// The components (8-connected with `diagonal`, else 4-connected) whose bounding box `keep`
/// accepts, each as its runs (row order).
pub(crate) fn components(runs: &[Run], diagonal: bool, keep: impl Fn(&Blob) -> bool) -> Vec<Vec<Run>> {
    let mut parent = link(runs, diagonal);
    let mut blob: Vec<Blob> = runs.iter().map(|r| Blob { x0: r.x0, y0: r.y, x1: r.x1, y1: r.y + 1 }).collect();
    let mut root = vec![0u32; runs.len()];
    for i in 0..runs.len() {
        let k = find(&mut parent, i);
        root[i] = k as u32;
        if k != i {
            let (a, b) = (blob[k], blob[i]);
            blob[k] = Blob { x0: a.x0.min(b.x0), y0: a.y0.min(b.y0), x1: a.x1.max(b.x1), y1: a.y1.max(b.y1) };
        }
    }
    // slot of each kept root in the output
    let mut slot = vec![u32::MAX; runs.len()];
    let mut out: Vec<Vec<Run>> = Vec::new();
    for i in 0..runs.len() {
        if root[i] as usize == i && keep(&blob[i]) {
            slot[i] = out.len() as u32;
            out.push(Vec::new());
        }
    }
    for (r, k) in runs.iter().zip(&root) {
        if let Some(o) = out.get_mut(slot[*k as usize] as usize) {
            o.push(*r);
        }
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;

    fn run(y: u32, x0: u32, x1: u32) -> Run {
        Run { y, x0, x1 }
    }

    #[test]
    fn runs_join_by_connectivity() {
        // a ring, a diagonal neighbour of it, and a separate blob two rows down
        let runs = [run(0, 0, 3), run(1, 0, 1), run(1, 2, 3), run(2, 0, 3), run(3, 3, 4), run(5, 0, 2)];
        let c = components(&runs, true, |_| true);
        assert_eq!(c.len(), 2);
        assert_eq!(c[0].len(), 5);
        let c = components(&runs, false, |_| true);
        assert_eq!(c.len(), 3);
        assert_eq!(c[0].len(), 4);
        assert_eq!(c[1], vec![run(3, 3, 4)]);
        assert_eq!(c[2], vec![run(5, 0, 2)]);
        let c = components(&runs, false, |b| b.y1 - b.y0 > 1);
        assert_eq!(c.len(), 1);
        // runs sharing one column join, a gap of one column does not
        assert_eq!(components(&[run(0, 0, 2), run(1, 1, 4)], false, |_| true).len(), 1);
        assert_eq!(components(&[run(0, 0, 2), run(1, 2, 4)], false, |_| true).len(), 2);
        assert_eq!(components(&[run(0, 0, 2), run(1, 2, 4)], true, |_| true).len(), 1);
        assert_eq!(components(&[run(0, 0, 2), run(1, 3, 4)], true, |_| true).len(), 2);
    }
}
