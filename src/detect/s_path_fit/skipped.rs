//! Dots the labelling stepped over: a detected dot between two placed dots of consecutive
//! indices means the step between them was two.

use nalgebra::Point2;

use super::Labels;
use crate::detect::dots::Dot;

/// Where an unplaced dot lies between the dots of consecutive indices `i` and `i + 1` (its
/// projection on the segment between them within its middle half, at most a quarter of the
/// segment's length off it, and at least [`SKIPPED_AREA`] of the smaller one's area), it takes
/// index `i + 1` and the stretch after it moves up by one, up to the first unplaced index. A dot
/// that strays towards its predecessor makes a short step and the next one long (8.7 and 19 px
/// against 11-14 px around, 5 mm strays), and the chain took the long one for a single step: the
/// rest of the stretch was one index low, which a projective camera absorbs along the smooth
/// path. `len`: the path's number of points.
pub(super) fn insert_skipped(dots: &[Dot], mut labels: Labels, len: usize) -> Labels {
    // Each round places one more dot.
    for _ in 0..dots.len() {
        labels.sort_unstable();
        let Some((k, c)) = first_skipped(dots, &labels) else { break };
        let end = (k + 1..labels.len()).find(|&m| m + 1 == labels.len() || labels[m + 1].0 > labels[m].0 + 1).unwrap_or(k);
        if labels[end].0 + 1 >= len {
            break;
        }
        for l in &mut labels[k + 1..=end] {
            l.0 += 1;
        }
        labels.push((labels[k].0 + 1, c));
    }
    labels.sort_unstable();
    labels
}

/// Smallest area of a skipped dot against the smaller of its two neighbours'.
const SKIPPED_AREA: f64 = 0.3;

/// The first label `k` (of `labels`, sorted) followed by index `labels[k].0 + 1` with an unplaced
/// dot between the two, and that dot.
fn first_skipped(dots: &[Dot], labels: &Labels) -> Option<(usize, usize)> {
    let placed: std::collections::HashSet<usize> = labels.iter().map(|l| l.1).collect();
    (0..labels.len().saturating_sub(1)).filter(|&k| labels[k + 1].0 == labels[k].0 + 1).find_map(|k| {
        let (a, b) = (&dots[labels[k].1], &dots[labels[k + 1].1]);
        let area = SKIPPED_AREA * a.area_px.min(b.area_px);
        let c = (0..dots.len()).find(|&c| !placed.contains(&c) && dots[c].area_px >= area && between(a.centre_px, b.centre_px, dots[c].centre_px))?;
        Some((k, c))
    })
}

/// Is `c` in the middle half of segment `a`-`b`, within a quarter of its length of it?
fn between(a: Point2<f64>, b: Point2<f64>, c: Point2<f64>) -> bool {
    let ab = b - a;
    let l2 = ab.norm_squared();
    if !(l2 > 0.0) {
        return false;
    }
    let t = (c - a).dot(&ab) / l2;
    (0.25..=0.75).contains(&t) && (c - (a + t * ab)).norm_squared() <= l2 / 16.0
}
