//! Placed S-path dots whose centres are not measurements: they help to order the rest, and are
//! not reported.

use crate::dots::Dot;
use crate::filters::median_by;
use crate::s_path_order::IndexedDot;

/// Major-axis spread (`Dot::spread_px`) against the median of the path neighbours' above which
/// a blob beside an unplaced index holds two dots. A cap's major axis is its diameter across
/// the line of sight, whatever the view angle, so neighbours agree closely: single dots on
/// independent renders of four seeds (23 000 dots, 40-88 degrees from their normals) come to
/// at most 1.02 times the median; the start dot and dot 1 seen as one blob (5 views) to
/// 1.27-1.66.
pub const MERGED_SPREAD: f64 = 1.2;

/// The course's start dot radius over the other dots' (10 mm / 6 mm): the detector's target
/// spec has no radii. A start dot up to [`MERGED_SPREAD`] times larger still passes.
pub const START_RADIUS_RATIO: f64 = 10.0 / 6.0;

/// Path neighbours (indices either side) a blob's spread is compared with.
const NEIGHBOURS: usize = 5;

/// `ordered` split into the dots reported and the indices of those not: dots touching another
/// (`Dot::touching`: two slivers meeting end to end) and blobs next to an index left unplaced
/// whose spread exceeds [`MERGED_SPREAD`] times their neighbours' (two caps seen as one blob,
/// placed 2-4 px from either).
pub fn unmeasured(ordered: Vec<IndexedDot>, dots: &[Dot]) -> (Vec<IndexedDot>, Vec<usize>) {
    let of: Vec<Option<&Dot>> = ordered.iter().map(|o| dots.iter().find(|d| d.centre_px == o.centre_px)).collect();
    let placed = |i: usize| ordered.iter().any(|o| o.index == i);
    let merged = |k: usize, d: &Dot| {
        let i = ordered[k].index;
        if placed(i + 1) && (i == 0 || placed(i - 1)) {
            return false;
        }
        let mut near: Vec<f64> = (0..ordered.len())
            .filter(|&m| m != k && ordered[m].index != 0 && ordered[m].index.abs_diff(i) <= NEIGHBOURS)
            .filter_map(|m| of[m].filter(|n| !n.touching).map(|n| n.spread_px))
            .collect();
        let expected = if i == 0 { START_RADIUS_RATIO } else { 1.0 };
        near.len() >= 2 && median_by(&mut near, f64::total_cmp).is_some_and(|s| d.spread_px > MERGED_SPREAD * expected * s)
    };
    let bad: Vec<bool> = (0..ordered.len()).map(|k| of[k].is_some_and(|d| d.touching || merged(k, d))).collect();
    let out: Vec<usize> = ordered.iter().zip(&bad).filter(|(_, b)| **b).map(|(o, _)| o.index).collect();
    (ordered.into_iter().zip(bad).filter(|(_, b)| !b).map(|(o, _)| o).collect(), out)
}
