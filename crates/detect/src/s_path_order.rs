//! Ordering the S-path's dots along the path.
//!
//! The first dot of the S-path target is larger (10 mm against 6 mm): the start is the dot whose
//! area is largest relative to its two nearest neighbours (seen at about the same obliquity), and it
//! must exceed them by `start_area_ratio`. From there the chain follows the curve with a
//! constant-curvature prediction (the last step turned by the angle between the last two steps,
//! or with [`ChainGrowth::Strays`] the same on means of the last few steps), accepting the nearest
//! unused dot within `tolerance` of the step length; dots missing from the image (occluded, out of
//! view) are bridged by predicting up to [`MAX_SKIP`] steps ahead, so the visible dots
//! keep their path index.
//! The chain counts as the path when it holds at least `min_chain` dots and `min_chain_share` of
//! all detected dots (random clutter chains a few dots by chance, never most of them).
//! Reference: the course's S-path target (shared/spec/course-scenario.md 1.4, 3.4).

use nalgebra::Point2;

use super::dots::Dot;
use super::DetectError;
use ahead::Ahead;
pub(crate) use steps::ambiguous_steps;
use steps::reindex_steps;

mod ahead;
mod steps;

/// Most steps a prediction may bridge (one missing dot). Bridging three (for painted discs that
/// thin to slivers) let random clutter chain into a path in the robustness test.
pub const MAX_SKIP: usize = 2;

/// Parameters of [`order_s_path`].
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct SPathOrderParams {
    /// Number of points on the path (course: 101).
    pub points: usize,
    /// The start dot's area over the mean of its two nearest neighbours' (beads: (10/6)^2 = 2.8).
    pub start_area_ratio: f64,
    /// Search radius around a prediction, as a fraction of the last step.
    pub tolerance: f64,
    /// Fewest dots a chain must hold to count as the path.
    pub min_chain: usize,
    /// Smallest share of the detected dots the chain must hold (the rest are taken as clutter).
    pub min_chain_share: f64,
    /// How the chain follows the dots ([`ChainGrowth`]).
    pub growth: ChainGrowth,
}

/// How a chain follows the S-path's dots.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub enum ChainGrowth {
    /// Dots on the nominal curve: each step predicted from the last one (its length and the turn
    /// between the last two), the next dot within 40 degrees of it.
    #[default]
    Strict,
    /// Dots that stray from the nominal curve by up to a fifth of their spacing (a painted or
    /// printed-and-glued target: 5 mm on the course's 25.7 mm): direction and length from the mean
    /// of the last few steps, a 50-degree cone, and each step's index increment re-decided against
    /// the centred local step length once the chain is grown (see `steps`). Looser, so
    /// [`crate::s_path_fit::index_s_path`] tries it where the strict chains leave dots
    /// unplaced.
    Strays,
}

impl ChainGrowth {
    /// Half-angle of the cone ahead in which the next dot is looked for, degrees: a stray dot's
    /// step leaves the mean direction by up to about 25 degrees, on top of the path's own turn.
    fn cone_deg(self) -> f64 {
        match self {
            Self::Strict => 40.0,
            Self::Strays => 50.0,
        }
    }
}

impl SPathOrderParams {
    /// Fewest dots a path must hold among `detected` dots: `min_chain` (at most `points`), and
    /// `min_chain_share` of them.
    pub fn needed(&self, detected: usize) -> usize {
        self.min_chain.min(self.points).max((self.min_chain_share * detected as f64).ceil() as usize)
    }
}

impl Default for SPathOrderParams {
    fn default() -> Self {
        Self { points: 101, start_area_ratio: 1.8, tolerance: 0.45, min_chain: 10, min_chain_share: 0.8, growth: ChainGrowth::Strict }
    }
}

/// A dot with its index along the path.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct IndexedDot {
    /// Index along the path, 0 = start.
    pub index: usize,
    /// Centre, pixels.
    pub centre_px: Point2<f64>,
}

/// Two nearest other dots of dot `i`: (index, distance) pairs, nearest first.
fn two_nearest(dots: &[Dot], i: usize) -> Vec<(usize, f64)> {
    let mut d: Vec<(usize, f64)> = dots.iter().enumerate().filter(|(j, _)| *j != i).map(|(j, o)| (j, (o.centre_px - dots[i].centre_px).norm())).collect();
    d.sort_by(|a, b| a.1.total_cmp(&b.1));
    d.truncate(2);
    d
}

/// Extend `chain` ((path index, dot) pairs, at least two, in path order) forward from its end:
/// a constant-curvature prediction of the next step ([`ChainGrowth`]: from the last steps or
/// their means), the nearest unused dot ahead, or within `tolerance` of the step length of a
/// prediction bridging up to [`MAX_SKIP`] steps, at the distance its index implies; stops at
/// `index_limit` or when no dot fits. Marks the dots it takes in `used`.
pub fn grow_chain(dots: &[Dot], used: &mut [bool], chain: &mut Vec<(i64, usize)>, tolerance: f64, index_limit: i64, growth: ChainGrowth) {
    let radius = |d: &Dot| (d.area_px / std::f64::consts::PI).sqrt();
    let nearest_unused = |p: Point2<f64>, used: &[bool]| {
        dots.iter().enumerate().filter(|(j, _)| !used[*j]).map(|(j, d)| (j, (d.centre_px - p).norm())).min_by(|a, b| a.1.total_cmp(&b.1))
    };
    let cos_cone = growth.cone_deg().to_radians().cos();
    while chain.len() >= 2 {
        let (i_cur, j_cur) = chain[chain.len() - 1];
        let cur = dots[j_cur].centre_px;
        let Some(ahead) = Ahead::of(growth, dots, chain) else { break };
        let (step, step_len, rot) = (ahead.step, ahead.step.norm(), nalgebra::Rotation2::new(ahead.turn));
        let steps_to = |j: usize| (dots[j].centre_px - cur).norm() / step_len;
        // Path dots do not overlap (25.7 mm apart, 12 mm beads): two blobs closer than most of
        // their radii are clutter, not consecutive dots.
        let apart = |j: usize| (dots[j].centre_px - cur).norm() >= 0.8 * (radius(&dots[j]) + radius(&dots[j_cur]));
        // The next dot: the nearest unused one ahead (within the cone around the predicted
        // direction, one step away). Nearest-to-prediction alone takes every other dot when the
        // last step is too long (the start dot's centroid is off its path point).
        // Strict growth takes the nearest and rejects it when it is too close (clutter); with
        // strays, too-close blobs are passed over for the next one out.
        let towards = rot * step;
        let pass_over = growth == ChainGrowth::Strays;
        let next = (0..dots.len())
            .filter(|&j| !used[j] && ahead.next_band().is_some_and(|b| b.contains(&steps_to(j))) && (!pass_over || apart(j)))
            .map(|j| (j, dots[j].centre_px - cur))
            .filter(|(_, v)| v.dot(&towards) >= v.norm() * step_len * cos_cone)
            .min_by(|a, b| a.1.norm().total_cmp(&b.1.norm()));
        let mut found = next.filter(|(j, _)| apart(*j)).map(|(j, _)| (j, i_cur + 1));
        let mut pred = cur;
        let mut s = step;
        for skip in 1..=MAX_SKIP {
            if found.is_some() {
                break;
            }
            // Predict skip steps ahead along the arc.
            s = rot * s;
            pred += s;
            if let Some((j, dist)) = nearest_unused(pred, used) {
                let far_enough = ahead.bridge_band(skip).is_some_and(|b| b.contains(&steps_to(j)));
                if apart(j) && far_enough && dist <= tolerance * step_len * skip as f64 + 1.0 {
                    found = Some((j, i_cur + skip as i64));
                }
            }
        }
        let Some((j, index)) = found else { break };
        log::trace!("chain {i_cur} -> {index}: {:.2} steps of {step_len:.1} px, turn {:.1} deg", steps_to(j), rot.angle().to_degrees());
        if index >= index_limit {
            break;
        }
        used[j] = true;
        chain.push((index, j));
    }
}

/// Chains of dots without a known start: from each unused dot (largest first) and its nearest
/// unused neighbour, grown both ways with [`grow_chain`]. Indices are relative to the seed dot
/// (0) and may be negative; `params` gives the tolerance, the number of path points and the
/// growth. Chains of fewer than `min_len` dots are dropped; longest first.
pub fn anonymous_chains(dots: &[Dot], params: &SPathOrderParams, min_len: usize) -> Vec<Vec<(i64, usize)>> {
    let (tolerance, points, growth) = (params.tolerance, params.points, params.growth);
    let mut used = vec![false; dots.len()];
    let mut seeds: Vec<usize> = (0..dots.len()).collect();
    seeds.sort_by(|a, b| dots[*b].area_px.total_cmp(&dots[*a].area_px));
    let mut chains = Vec::new();
    for seed in seeds {
        if used[seed] {
            continue;
        }
        let next = dots
            .iter()
            .enumerate()
            .filter(|(j, _)| *j != seed && !used[*j])
            .map(|(j, d)| (j, (d.centre_px - dots[seed].centre_px).norm()))
            .min_by(|a, b| a.1.total_cmp(&b.1));
        let Some((next, _)) = next else { break };
        used[seed] = true;
        used[next] = true;
        let limit = points as i64;
        let mut forward = vec![(0, seed), (1, next)];
        grow_chain(dots, &mut used, &mut forward, tolerance, limit, growth);
        // Backward: the same growth on the reversed chain (indices negated).
        let mut backward: Vec<(i64, usize)> = forward.iter().rev().map(|&(i, j)| (-i, j)).collect();
        grow_chain(dots, &mut used, &mut backward, tolerance, limit, growth);
        let mut chain: Vec<(i64, usize)> = backward.iter().rev().map(|&(i, j)| (-i, j)).collect();
        if growth == ChainGrowth::Strays {
            reindex_steps(dots, &mut chain, points);
        }
        if chain.len() >= min_len {
            chains.push(chain);
        } else {
            // Too short to place: free its dots for other chains (the seed stays used).
            for &(_, j) in chain.iter().filter(|(_, j)| *j != seed) {
                used[j] = false;
            }
        }
    }
    chains.sort_by_key(|c| std::cmp::Reverse(c.len()));
    chains
}

/// The chain from the start dot: (path index, dot) pairs in path order.
///
/// # Errors
/// As [`order_s_path`].
pub fn start_chain(dots: &[Dot], params: &SPathOrderParams) -> Result<Vec<(i64, usize)>, DetectError> {
    let chain = start_dot_chain(dots, params)?;
    let need = params.needed(dots.len());
    if chain.len() < need {
        return Err(DetectError::NotFound {
            reason: format!("the chain from the start dot holds {} of {} dots (at least {need} needed)", chain.len(), dots.len()),
        });
    }
    Ok(chain)
}

/// The dot whose area is largest relative to the mean of its two nearest neighbours' (seen at
/// about the same obliquity: the start dot's candidate), and that ratio; `None` without dots.
pub(crate) fn largest_relative_area(dots: &[Dot]) -> Option<(usize, f64)> {
    let ratio = |i: usize| {
        let nn = two_nearest(dots, i);
        let mean = nn.iter().map(|(j, _)| dots[*j].area_px).sum::<f64>() / nn.len().max(1) as f64;
        dots[i].area_px / mean.max(1e-9)
    };
    (0..dots.len()).map(|i| (i, ratio(i))).max_by(|a, b| a.1.total_cmp(&b.1))
}

/// The chain grown from the start dot, however short: (path index, dot) pairs in path order.
///
/// # Errors
/// [`DetectError::NotFound`] when fewer than 3 dots are given or no dot is recognised as the start.
pub fn start_dot_chain(dots: &[Dot], params: &SPathOrderParams) -> Result<Vec<(i64, usize)>, DetectError> {
    if dots.len() < 3 {
        return Err(DetectError::NotFound { reason: format!("{} dots, at least 3 needed to order a path", dots.len()) });
    }
    let (start, best) = largest_relative_area(dots).unwrap_or((0, 0.0));
    if best < params.start_area_ratio {
        return Err(DetectError::NotFound { reason: format!("start dot not recognised (largest relative area {best:.2} < {})", params.start_area_ratio) });
    }
    let mut used = vec![false; dots.len()];
    used[start] = true;
    let Some(&(second, _)) = two_nearest(dots, start).first() else { return Ok(vec![(0, start)]) };
    used[second] = true;
    let mut chain = vec![(0, start), (1, second)];
    grow_chain(dots, &mut used, &mut chain, params.tolerance, params.points as i64, params.growth);
    if params.growth == ChainGrowth::Strays {
        reindex_steps(dots, &mut chain, params.points);
    }
    Ok(chain)
}

/// Order detected dots along the S-path.
///
/// # Errors
/// [`DetectError::NotFound`] when fewer than 3 dots are given, the start dot is not recognised,
/// or its chain holds too few of the dots ([`SPathOrderParams::needed`]).
pub fn order_s_path(dots: &[Dot], params: &SPathOrderParams) -> Result<Vec<IndexedDot>, DetectError> {
    Ok(indexed(dots, &start_chain(dots, params)?))
}

/// (path index, dot) pairs as [`IndexedDot`]s.
pub fn indexed<I: Copy + TryInto<usize>>(dots: &[Dot], pairs: &[(I, usize)]) -> Vec<IndexedDot> {
    pairs.iter().filter_map(|&(i, j)| Some(IndexedDot { index: i.try_into().ok()?, centre_px: dots[j].centre_px })).collect()
}

#[cfg(test)]
mod tests;
