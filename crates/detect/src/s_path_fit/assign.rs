//! Labelling S-path dots by an optimal assignment to the projected path, gated by the deviation
//! a dot may have from its nominal path point ([`SPathFitParams::max_deviation_m`]).
//!
//! A dot lies on the sphere within `max_deviation_m` of its path point: seen through a camera,
//! inside the image of the tangent disc of that radius around the point, an ellipse (the
//! disc's projection to first order, [`Gate`]). The discs of two path points are disjoint while
//! twice the deviation stays below the spacing (15 mm against 25.7 mm on the course), and so are
//! their images on the side of the sphere the camera sees: given a camera, each dot belongs to at
//! most one path point, whatever the pose and the foreshortening. The camera comes from a seed
//! labelling (a DLT, [`super::dlt`]); every dot is then assigned to the path point whose ellipse
//! it is nearest to (image distance, 0 inside), all dots at once by a minimum-cost assignment
//! ([`min_cost_assignment`]) with a column per dot for "unplaced" at the gate's cost
//! ([`SPathFitParams::model_error_px`]: how far the camera model may miss, lens distortion and
//! the fit's own error); the camera is refitted to the assignment until it is stable. A dot is
//! kept only where it is unambiguous: every other path point's ellipse, and every other dot
//! to its own, lies [`SEPARATION`] of the gate further away.
//!
//! Reference: Hartley and Zisserman, *Multiple View Geometry*, 2nd ed., 7.1 (DLT) and 4.8
//! (first-order propagation through a projection: the ellipse as the Jacobian's image of the
//! disc); the assignment as in [`super::hungarian`].

use super::dlt::Dlt;
use super::gate::{gates, Gate};
use super::hungarian::min_cost_assignment;
use super::start::{anchored_at_start, start_agrees, StartDot, ANCHORED};
use super::{correspondences, Labels, Pinhole, SPathFitParams};
use crate::dots::Dot;
use synthcam_core::target::SPath;

/// Share of the gate ([`SPathFitParams::model_error_px`]) by which a dot's second-nearest
/// ellipse (or the second-nearest dot to its ellipse) must be further than its own.
pub(super) const SEPARATION: f64 = 0.5;

/// Tie-break between candidates inside their ellipses (0 px away): pixels per unit of the
/// normalised tangent offset (offset over the deviation radius).
const TIE_PX: f64 = 0.01;

/// Camera refits per assignment.
const ROUNDS: usize = 8;

/// Image distances (pixels) from each dot to each gate within `reach` px, as (dot, point,
/// distance, normalised offset).
fn candidates(dots: &[Dot], gates: &[Option<Gate>], r: f64, height: f64, reach: f64) -> Vec<(usize, usize, f64, f64)> {
    let mut out = Vec::new();
    for (j, d) in dots.iter().enumerate() {
        for (i, g) in gates.iter().enumerate() {
            let Some(g) = g.as_ref().filter(|g| g.may_reach(&d.centre_px, r, height, reach)) else { continue };
            let (e, t) = g.distance(&d.centre_px, r, height);
            if e <= reach {
                out.push((j, i, e, t));
            }
        }
    }
    out
}

/// One assignment of `dots` to the gates ([`candidates`] within the gate `model_error_px`),
/// each kept only where unambiguous ([`SEPARATION`]): (path index, dot) pairs, sorted, and the
/// squared tangent offsets of the placed dots over the deviation radius (0 to 1 inside).
pub(super) fn assign_once(dots: &[Dot], gates: &[Option<Gate>], params: &SPathFitParams, height: f64) -> (Labels, Vec<f64>) {
    let gate = params.model_error_px;
    let cand = candidates(dots, gates, params.max_deviation_m, height, (1.0 + SEPARATION) * gate);
    let (n, m) = (dots.len(), gates.len());
    let within: Vec<(usize, usize, f64)> = cand.iter().filter(|c| c.2 <= gate).map(|&(j, i, e, t)| (j, i, e + TIE_PX * t.min(10.0))).collect();
    let mut col = vec![usize::MAX; n];
    for (rows, cols) in components(&within, n, m) {
        // Rows: the component's dots; columns: its path points, then one "unplaced" per dot.
        let unplaced = 2.0 * gate + 1.0;
        let mut cost = vec![vec![4.0 * unplaced; cols.len() + rows.len()]; rows.len()];
        for &(j, i, c) in &within {
            if let (Ok(r), Ok(k)) = (rows.binary_search(&j), cols.binary_search(&i)) {
                cost[r][k] = c;
            }
        }
        for (r, row) in cost.iter_mut().enumerate() {
            row[cols.len() + r] = unplaced;
        }
        for (r, k) in min_cost_assignment(&cost).into_iter().enumerate() {
            col[rows[r]] = cols.get(k).copied().unwrap_or(usize::MAX);
        }
    }
    let (mut labels, mut offsets) = (Labels::new(), Vec::new());
    for (j, &i) in col.iter().enumerate().filter(|(_, &i)| i < m) {
        let Some(own) = cand.iter().find(|c| c.0 == j && c.1 == i) else { continue };
        let rival = cand.iter().filter(|c| (c.0 == j) != (c.1 == i)).map(|c| c.2).fold(f64::INFINITY, f64::min);
        if own.2 <= gate && rival >= own.2 + SEPARATION * gate {
            labels.push((i, j));
            offsets.push((own.3 * own.3).min(UNPLACED_COST));
        }
    }
    labels.sort_unstable();
    (labels, offsets)
}

/// The connected components of the candidate pairs (dot, point, cost) as sorted (dots, points):
/// the assignment separates into them, each solved on its own (most hold one dot and one point).
fn components(pairs: &[(usize, usize, f64)], dots: usize, points: usize) -> Vec<(Vec<usize>, Vec<usize>)> {
    // Union-find over dots 0..dots and points dots..dots + points.
    let mut parent: Vec<usize> = (0..dots + points).collect();
    fn root(p: &mut [usize], mut x: usize) -> usize {
        while p[x] != x {
            p[x] = p[p[x]];
            x = p[x];
        }
        x
    }
    for &(j, i, _) in pairs {
        let (a, b) = (root(&mut parent, j), root(&mut parent, dots + i));
        parent[a] = b;
    }
    let mut groups: std::collections::BTreeMap<usize, (Vec<usize>, Vec<usize>)> = Default::default();
    for &(j, i, _) in pairs {
        let g = groups.entry(root(&mut parent, j)).or_default();
        g.0.push(j);
        g.1.push(i);
    }
    groups
        .into_values()
        .map(|(mut r, mut c)| {
            r.sort_unstable();
            r.dedup();
            c.sort_unstable();
            c.dedup();
            (r, c)
        })
        .collect()
}

/// Cost of a detected dot left unplaced in [`Assignment::cost`]: that of a dot on the rim of its
/// disc.
const UNPLACED_COST: f64 = 1.0;

/// A seed's assignment: labels, and the squared normalised offsets of their dots.
#[derive(Debug, Clone)]
pub(super) struct Assignment {
    pub(super) labels: Labels,
    offsets: Vec<f64>,
}

/// Root mean square of the placed dots' offsets from their points, over the deviation radius, up
/// to which an assignment's dots count as on their points ([`Assignment::on_their_points`]).
const ON_POINTS_RMS: f64 = 0.5;

impl Assignment {
    /// An assignment of `labels` whose offsets are not known (tests of its users).
    #[cfg(test)]
    pub(super) fn from_labels(labels: Labels) -> Self {
        Self { labels, offsets: Vec::new() }
    }

    /// Whether the placed dots lie on their path points (RMS offset at most [`ON_POINTS_RMS`] of
    /// the deviation radius): a stretch one index off beyond a split point fits the camera of the
    /// rest only where the dots stray by a good part of the radius (its dots would otherwise lie a
    /// whole spacing, 3.4 radii, from the points the camera projects), so such an assignment's
    /// split rivals ([`shifted_rivals`]) need no test; its whole shifts are still tested.
    fn on_their_points(&self) -> bool {
        let n = self.offsets.len().max(1) as f64;
        self.offsets.iter().sum::<f64>() / n <= ON_POINTS_RMS * ON_POINTS_RMS
    }

    /// How badly the labelling explains the dots: the placed dots' squared offsets over the
    /// deviation radius, plus [`UNPLACED_COST`] per detected dot left unplaced (a robust
    /// negative log-likelihood of dots spread over their discs).
    pub(super) fn cost(&self, detected: usize) -> f64 {
        self.offsets.iter().sum::<f64>() + UNPLACED_COST * detected.saturating_sub(self.labels.len()) as f64
    }
}

/// The height off the sphere (metres, 0 to `max`) at which the dots of `labels` stand, least
/// squares along the projected normals: a bead's centre stands its radius off the surface, and
/// seen obliquely its image lies that far outside the image of the tangent disc.
fn fit_height(dots: &[Dot], gates: &[Option<Gate>], labels: &[(usize, usize)], max: f64) -> f64 {
    let (num, den) = labels
        .iter()
        .filter_map(|&(i, j)| gates[i].map(|g| (g.up.dot(&(dots[j].centre_px - g.q)), g.up.norm_squared())))
        .fold((0.0, 0.0), |a, b| (a.0 + b.0, a.1 + b.1));
    if den > 0.0 {
        (num / den).clamp(0.0, max)
    } else {
        0.0
    }
}

/// A seed labelling's assignment, refitted until stable: the one of least [`Assignment::cost`]
/// over the rounds ([`ROUNDS`]); `None` where the seed fits no camera.
pub(super) fn assign(dots: &[Dot], path: &SPath, seed: &[(usize, usize)], params: &SPathFitParams) -> Option<Assignment> {
    // A known camera's gates are tight: a seed's camera grows its matches first under the wider
    // matching radius (see seeds::consensus), so that a camera fitted to part of the view
    // reaches the rest.
    let grown = params.camera.and_then(|_| super::seeds::consensus(dots, path, seed, params)).filter(|g| g.len() > seed.len());
    let (world, image) = correspondences(grown.as_deref().unwrap_or(seed), dots, path);
    let mut dlt = Dlt::fit_trimmed(&world, &image, params.pinhole())?;
    let mut best: Option<Assignment> = None;
    let mut height = 0.0;
    for _ in 0..ROUNDS {
        let g = gates(&dlt, path);
        let (labels, offsets) = assign_once(dots, &g, params, height);
        height = fit_height(dots, &g, &labels, params.max_height_m);
        let same = best.as_ref().is_some_and(|b| b.labels == labels);
        let now = Assignment { labels, offsets };
        if best.as_ref().is_none_or(|b| now.cost(dots.len()) < b.cost(dots.len())) {
            best = Some(now.clone());
        }
        if same {
            break;
        }
        let (world, image) = correspondences(&now.labels, dots, path);
        let Some(next) = Dlt::fit(&world, &image, params.pinhole()) else { break };
        dlt = next;
    }
    best
}

/// Robust standard deviations of a placed dot's cost the margin between the best assignment and
/// a disagreeing rival must exceed, times the square root of the dots placed: the chance part
/// of a cost sum (squared offsets uniform on 0..1 for dots spread evenly over their discs: 0.29
/// per dot) stays within it.
pub(super) const RIVAL_SIGMAS: f64 = 2.0;

/// Smallest margin between the best assignment's cost and a disagreeing rival's: a tenth of a
/// dot left unplaced (on a target whose dots sit on their path points the best costs about 0,
/// a placement shifted along the path 0.6 and more).
const MIN_MARGIN: f64 = 0.1 * UNPLACED_COST;

/// Shifts along the path (indices either way) of the best assignment tried as its rivals.
const SHIFTS: usize = 3;

/// `labels` moved by `k` indices along a path of `len` points (those leaving it dropped).
pub(super) fn shift(labels: &[(usize, usize)], k: i64, len: usize) -> Labels {
    labels.iter().filter_map(|&(i, j)| usize::try_from(i as i64 + k).ok().filter(|&m| m < len).map(|m| (m, j))).collect()
}

/// `labels` mirrored about index `m` (index `i` to `m - i`; those leaving a path of `len` points
/// dropped): the S run backwards.
pub(super) fn mirror(labels: &[(usize, usize)], m: usize, len: usize) -> Labels {
    labels.iter().filter_map(|&(i, j)| m.checked_sub(i).filter(|&k| k < len).map(|k| (k, j))).collect()
}

/// Rounds of [`best_assignment`] in which a new best is challenged by its own shifts.
const RECHALLENGES: usize = 3;

/// Path indices between the split points of [`shifted_rivals`] in the assignment's challenge.
const SPLIT_STEP: usize = 5;

/// Rivals of a labelling that a camera fitted to it may also take: the labelling moved by one to
/// [`SHIFTS`] indices along the path, and its part beyond each split point (every `split_step`
/// indices; none where `None`), or its part before it, moved by one either way (a labelling right
/// up to a missed or stray dot and one index off beyond it fits one projective camera nearly as
/// well where the dots stray by a quarter of their spacing).
pub(super) fn shifted_rivals(labels: &[(usize, usize)], len: usize, split_step: Option<usize>) -> Vec<Labels> {
    let mut out: Vec<Labels> = (1..=SHIFTS as i64).flat_map(|k| [-k, k]).map(|k| shift(labels, k, len)).collect();
    let Some(step) = split_step.filter(|&s| s > 0) else {
        return out;
    };
    let (lo, hi) = labels.iter().fold((usize::MAX, 0), |(a, b), l| (a.min(l.0), b.max(l.0)));
    for split in (lo + step..hi).step_by(step) {
        let (head, tail): (Labels, Labels) = labels.iter().partition(|l| l.0 < split);
        for k in [-1i64, 1] {
            // The part beyond the split moved, then the part before it.
            let mut moved = shift(&tail, k, len);
            moved.retain(|l| head.last().is_none_or(|h| l.0 > h.0));
            out.push(head.iter().copied().chain(moved).collect());
            let mut moved = shift(&head, k, len);
            moved.retain(|l| tail.first().is_none_or(|t| l.0 < t.0));
            out.push(moved.into_iter().chain(tail.iter().copied()).collect());
        }
    }
    out
}

/// Offsets of the reversed labelling tried by [`reversed_rivals`], either way from the exact
/// reversal.
pub(super) const REVERSAL_REACH: i64 = 8;

/// Reversed placements kept as rivals by [`reversed_rivals`].
const REVERSALS: usize = 2;

/// The S is nearly point-symmetric: turned half a turn about its middle it lies close to itself
/// run backwards, so a labelling's reversal (index `i` to `n - 1 - i`, moved by up to
/// [`REVERSAL_REACH`] indices) explains the dots nearly as well where they stray. The
/// [`REVERSALS`] reversals whose camera fits them best are the labelling's rivals where the
/// camera is known: where a seed placed the path backwards (the verified windows of
/// [`super::seeds::verified_windows`] offer such placements), its reversal is the right one.
/// A projective camera absorbs much of the reversal, and there its rivalry cost recall on renders
/// without changing a label (`benches/spath_independent.py`, seed 34805, 7 mm: 53.1 -> 45.5 %).
fn reversed_rivals(labels: &[(usize, usize)], dots: &[Dot], path: &SPath, params: &SPathFitParams) -> Vec<Labels> {
    if params.camera.is_none() {
        return Vec::new();
    }
    best_reversals(labels, dots, path, params.pinhole(), 6, REVERSALS)
}

/// The labelling's `n` reversals (mirrored about the path's last index, moved by up to
/// [`REVERSAL_REACH`] either way, keeping at least `min_len` of its dots) whose fitted camera
/// reprojects them best, best first.
pub(super) fn best_reversals(labels: &[(usize, usize)], dots: &[Dot], path: &SPath, pinhole: Pinhole, min_len: usize, n: usize) -> Vec<Labels> {
    let last = path.len() as i64 - 1;
    let mut fits: Vec<(f64, Labels)> = (-REVERSAL_REACH..=REVERSAL_REACH)
        .filter_map(|k| usize::try_from(last + k).ok())
        .map(|m| mirror(labels, m, path.len()))
        .filter(|l| l.len() >= min_len.max(6))
        .filter_map(|l| Some((super::fit_rms(dots, path, &l, pinhole)?, l)))
        .collect();
    fits.sort_by(|a, b| a.0.total_cmp(&b.0));
    fits.into_iter().take(n).map(|(_, l)| l).collect()
}

/// The assignment of the seed labellings that explains the dots best ([`assign`],
/// [`Assignment::cost`]), less every dot that a contender (an assignment costing less than the
/// best's plus a margin, [`rival_margin`]) places at another index: two placements that explain
/// the dots about equally well (a shift along a stretch of constant curvature is a rotation
/// about the sphere's centre) leave the dots they disagree on unlabelled. Where a contender
/// places the start dot recognised by its area (`start`) at index 0, the contenders placing it
/// elsewhere drop out ([`start_agrees`]); the start dot only breaks ties: where beads squeeze
/// into one blob along the outline, a blob can pass for it. Where the camera is known and the
/// start dot is recognised by its area alone ([`StartDot::Anchors`]), the placements of the best
/// few labellings moved to put it at 0 compete too: a view showing a few dots after the start
/// and a long stretch far from it is otherwise placed reversed (the S is nearly point-symmetric)
/// when no seed offers the right placement.
pub(super) fn best_assignment(dots: &[Dot], path: &SPath, seeds: &[Labels], params: &SPathFitParams, start: StartDot) -> Option<(Labels, Vec<bool>)> {
    let n = dots.len();
    let scored = |s: &Labels| assign(dots, path, s, params).map(|a| (a.cost(n), a));
    let mut results: Vec<(f64, Assignment)> = seeds.iter().filter(|s| s.len() >= 6).filter_map(scored).collect();
    if let StartDot::Anchors(s) = start {
        results.sort_by(|a, b| a.0.total_cmp(&b.0));
        let anchored: Vec<Labels> = results.iter().take(ANCHORED).flat_map(|r| anchored_at_start(&r.1.labels, s, dots, path, params)).collect();
        results.extend(anchored.iter().filter_map(scored));
    }
    let start_dot = start.dot();
    // The best's own shifts along the path, whole and beyond each of its stretches, are always
    // its rivals; where one of them explains the dots better, it is the best, and so on.
    let mut challenged: Vec<Labels> = Vec::new();
    for _ in 0..RECHALLENGES {
        results.sort_by(|a, b| a.0.total_cmp(&b.0));
        results.dedup_by(|a, b| a.1.labels == b.1.labels);
        let first = &results.first()?.1;
        let (best, splits) = (first.labels.clone(), !first.on_their_points());
        if challenged.contains(&best) {
            break;
        }
        results.extend(
            shifted_rivals(&best, path.len(), splits.then_some(SPLIT_STEP)).iter().chain(&reversed_rivals(&best, dots, path, params)).filter_map(scored),
        );
        challenged.push(best);
    }
    results.sort_by(|a, b| a.0.total_cmp(&b.0));
    let (cost, first) = results.first()?;
    let margin = rival_margin(&first.offsets);
    let mut contenders: Vec<&Assignment> = results.iter().filter(|r| r.0 < cost + margin).map(|r| &r.1).collect();
    if contenders.iter().any(|c| start_agrees(&c.labels, start_dot) == Some(true)) {
        contenders.retain(|c| start_agrees(&c.labels, start_dot) != Some(false));
    }
    if let (Some(centre), None, true) = (params.image_centre_px, params.camera, contenders.len() > 1) {
        contenders = super::radial::lens_settled(dots, path, contenders, centre, params.ambiguity_ratio);
    }
    let best = contenders.first()?;
    if !challenged.contains(&best.labels) {
        log::debug!("s-path assignment: the best of {} seeds ({} dots at cost {cost:.2}) kept changing", seeds.len(), best.labels.len());
        return None;
    }
    // Dot -> index of every contender.
    let index_of: Vec<std::collections::HashMap<usize, usize>> = contenders.iter().map(|c| c.labels.iter().map(|&(i, j)| (j, i)).collect()).collect();
    let labels: Labels = best.labels.iter().copied().filter(|&(i, j)| index_of.iter().all(|m| m.get(&j).is_none_or(|&k| k == i))).collect();
    log::debug!(
        "s-path assignment: {} seeds, best {} dots at cost {cost:.2}, {} contenders within {margin:.2}, {} undisputed",
        seeds.len(),
        best.labels.len(),
        contenders.len(),
        labels.len()
    );
    let mut placed = vec![false; n];
    contenders.iter().flat_map(|c| c.labels.iter()).for_each(|&(_, j)| placed[j] = true);
    Some((labels, placed))
}

/// `labels` joined by the entries of `chained` (the chains' own labelling, placed by local fits
/// that follow lens distortion beyond the assignment's single camera) whose dot no contender of
/// the assignment placed (`placed`) and whose index is free, where `chained` gives every dot of
/// `labels` it places the same index (it is the same placement of the path).
pub(super) fn join_chained(mut labels: Labels, chained: &[(usize, usize)], placed: &[bool]) -> Labels {
    let index_of: std::collections::HashMap<usize, usize> = labels.iter().map(|&(i, j)| (j, i)).collect();
    if !chained.iter().all(|&(i, j)| index_of.get(&j).is_none_or(|&k| k == i)) {
        return labels;
    }
    let extra: Labels = chained.iter().copied().filter(|&(i, j)| !placed[j] && labels.iter().all(|l| l.0 != i)).collect();
    labels.extend(extra);
    labels.sort_unstable();
    labels
}

/// The cost margin within which an assignment contends with the best one, whose placed dots'
/// costs are `offsets`: [`RIVAL_SIGMAS`] of their spread, times the square root of their number
/// (at least [`MIN_MARGIN`]).
fn rival_margin(offsets: &[f64]) -> f64 {
    let k = offsets.len().max(1) as f64;
    let mean = offsets.iter().sum::<f64>() / k;
    let sd = (offsets.iter().map(|o| (o - mean).powi(2)).sum::<f64>() / k).sqrt();
    (RIVAL_SIGMAS * sd * k.sqrt()).max(MIN_MARGIN)
}
