//! Dots the labelling stepped over: a detected dot between two placed dots of consecutive
//! indices means the step between them was two.

use nalgebra::Point2;

use super::Labels;
use crate::dots::Dot;

/// Where an unplaced dot lies between the dots of consecutive indices `i` and `i + 1` (a short
/// detour from one to the other, [`between`], and at least [`SKIPPED_AREA`] of the smaller one's
/// area), it takes
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

/// Longest detour through a skipped dot, over the direct step: `|ac| + |cb| <= SKIPPED_DETOUR |ab|`.
/// A dot that strays sideways and back (5 mm strays at the sphere's outline: 5.8 px from its
/// predecessor, 5.2 px off the 13.1 px step) makes a detour of 1.33.
const SKIPPED_DETOUR: f64 = 1.4;

/// Is `c` between `a` and `b`: within the ellipse of foci `a` and `b` whose string is
/// [`SKIPPED_DETOUR`] times their distance, and at least a sixth of that distance from each?
fn between(a: Point2<f64>, b: Point2<f64>, c: Point2<f64>) -> bool {
    let (ab, ac, cb) = ((b - a).norm(), (c - a).norm(), (b - c).norm());
    ab > 0.0 && ac + cb <= SKIPPED_DETOUR * ab && ac.min(cb) >= ab / 6.0
}

/// Largest distance between the two pieces of one split sliver, over the local step per index.
/// Two dots straying by up to a fifth of their spacing towards each other stay 0.6 steps apart
/// (0.33 seen at the sphere's outline, where the steps shorten quickly).
const SPLIT_FRACTION: f64 = 0.25;

/// Where two touching dots hold consecutive indices `i` and `i + 1` but lie closer than
/// [`SPLIT_FRACTION`] of the local step (from the labelled dots within two indices), they are
/// the two pieces of one sliver (its middle too light to join them: 3.8 px apart against 20 px
/// steps): the second gives its index up and the stretch after it moves down by one, up to the
/// first unplaced index. Both stay touching dots (no measurement) for the caller.
pub(super) fn join_split(dots: &[Dot], mut labels: Labels) -> Labels {
    labels.sort_unstable();
    while let Some(k) = first_split(dots, &labels) {
        let end = (k + 1..labels.len()).find(|&m| m + 1 == labels.len() || labels[m + 1].0 > labels[m].0 + 1).unwrap_or(k);
        labels.remove(k + 1);
        for l in &mut labels[k + 1..end] {
            l.0 -= 1;
        }
    }
    labels
}

/// The first label `k` (of `labels`, sorted) whose dot and the next index's are the pieces of
/// one split sliver ([`join_split`]).
fn first_split(dots: &[Dot], labels: &Labels) -> Option<usize> {
    let at = |m: usize| dots[labels[m].1].centre_px;
    (0..labels.len().saturating_sub(1)).find(|&k| {
        let (a, b) = (&dots[labels[k].1], &dots[labels[k + 1].1]);
        if labels[k + 1].0 != labels[k].0 + 1 || !(a.touching && b.touching) {
            return false;
        }
        // Local step per index: the labelled neighbours within two indices, the pair excluded.
        let near: Vec<usize> = (k.saturating_sub(2)..(k + 4).min(labels.len())).filter(|&m| m != k + 1).collect();
        let step =
            near.windows(2).map(|w| ((at(w[1]) - at(w[0])).norm(), (labels[w[1]].0 - labels[w[0]].0) as f64)).fold((0.0, 0.0), |s, (d, n)| (s.0 + d, s.1 + n));
        step.1 >= 2.0 && (a.centre_px - b.centre_px).norm() < SPLIT_FRACTION * step.0 / step.1
    })
}
