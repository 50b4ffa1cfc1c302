//! Seed labellings of the S-path's dots for the assignment ([`super::assign`]).

use super::assign;
use super::dlt::Dlt;
use super::label::labellings;
use super::resolve::chain_labels;
use super::START_RADIUS_RATIO;
use super::{correspondences, match_projection, more_placed, place_labels, skipped, Labels, SPathFitParams, WINDOW};
use crate::dots::Dot;
use crate::s_path_order::{anonymous_chains, largest_relative_area, start_dot_chain, ChainGrowth, SPathOrderParams};
use synthcam_core::target::SPath;

/// The dot recognised as the start ([`start_dot_chain`]'s first), if any.
pub(super) fn start_dot(dots: &[Dot], order: &SPathOrderParams) -> Option<usize> {
    start_dot_chain(dots, order).ok().and_then(|c| c.first().map(|e| e.1))
}

/// A dot's area over its two nearest neighbours' from which it is the start dot by its area alone:
/// the geometric mean of the largest ratio two dots merged into one blob can show (2) and the
/// start dot's own ([`START_RADIUS_RATIO`] squared, 2.78 on the course), 2.36.
const UNMISTAKABLE_START_AREA: f64 = START_RADIUS_RATIO * std::f64::consts::SQRT_2;

/// The start dot recognised by its area alone, without the chain from it that [`start_dot`]
/// needs ([`UNMISTAKABLE_START_AREA`]; a blob touching another is never it). Where the camera is
/// known, the best labellings moved to place this dot at index 0 compete too
/// ([`super::assign::best_assignment`]): the S is nearly point-symmetric, and the start dot is
/// what tells a view's placement from its reversal where only a few dots follow it.
pub(super) fn start_by_area(dots: &[Dot]) -> Option<usize> {
    // Two neighbours to compare with, as for the chain's start.
    if dots.len() < 3 {
        return None;
    }
    largest_relative_area(dots).filter(|&(j, r)| r >= UNMISTAKABLE_START_AREA && !dots[j].touching).map(|(j, _)| j)
}

/// Lengths of the stretches of the start dot's chain tried as seeds.
const START_STEPS: [usize; 2] = [12, 24];

/// Chains placed and labellings of the longest chains tried as seeds, per growth.
const SEED_CHAINS: usize = 2;

/// The labelling by chains, and the seed labellings for [`super::assign::best_assignment`]: it (strict growth
/// first; where that leaves detected dots unplaced, [`ChainGrowth::Strays`] too, the one placing
/// more kept), that labelling shifted by one to four indices either way (a projective camera
/// absorbs such a shift along a smooth stretch: the shifted seeds are its rivals), and the best
/// [`SEED_CHAINS`] placements of the [`SEED_CHAINS`] longest chains of each growth, and the
/// first [`START_STEPS`] of the chain from the start dot.
pub(super) fn seeds(dots: &[Dot], path: &SPath, params: &SPathFitParams, order: &SPathOrderParams) -> (Option<Labels>, Vec<Labels>) {
    let strict = (order.growth == ChainGrowth::Strict).then(|| place_labels(dots, path, params, order)).flatten();
    let chained = match strict {
        Some(l) if l.len() == dots.len() => Some(l),
        strict => more_placed(strict, place_labels(dots, path, params, &SPathOrderParams { growth: ChainGrowth::Strays, ..*order })),
    };
    let mut out = Vec::new();
    let chained = chained.map(|l| skipped::join_split(dots, skipped::insert_skipped(dots, l, path.len())));
    if let Some(l) = &chained {
        out.push(l.clone());
        out.extend([-4i64, -3, -2, -1, 1, 2, 3, 4].map(|k| assign::shift(l, k, path.len())));
    }
    for growth in [ChainGrowth::Strict, ChainGrowth::Strays] {
        // The first steps from the start dot hold where a longer chain strays off the path.
        if let Ok(chain) = start_dot_chain(dots, &SPathOrderParams { growth, ..*order }) {
            out.extend(START_STEPS.iter().filter(|&&k| chain.len() >= k).map(|&k| chain_labels(&chain[..k])));
        }
        for chain in anonymous_chains(dots, &SPathOrderParams { growth, ..*order }, params.min_seed).iter().take(SEED_CHAINS) {
            out.extend(labellings(chain, dots, path, params.pinhole()).into_iter().take(SEED_CHAINS).map(|(_, l)| l));
        }
    }
    (chained, out)
}

/// Where the camera is known, the seeds of [`window_seeds`] for the [`SEED_CHAINS`] longest
/// chains of each growth: costlier than [`seeds`], tried where those fall short.
pub(super) fn verified_windows(dots: &[Dot], path: &SPath, params: &SPathFitParams, order: &SPathOrderParams) -> Vec<Labels> {
    if params.pinhole().is_none() {
        return Vec::new();
    }
    let chains = [ChainGrowth::Strict, ChainGrowth::Strays].map(|growth| anonymous_chains(dots, &SPathOrderParams { growth, ..*order }, params.min_seed));
    chains.iter().flat_map(|c| c.iter().take(SEED_CHAINS)).flat_map(|chain| window_seeds(chain, dots, path, params)).collect()
}

/// Placements of each window kept as seeds (by consensus).
const PER_WINDOW: usize = 2;

/// Where the camera is known: each window of [`WINDOW`] consecutive dots of a chain (windows
/// overlapping by half; a shorter chain is one window) at every placement along the path, each
/// placement's camera verified against all the dots (hypothesise and verify: Fischler and
/// Bolles, 1981, [`consensus`]), together with the [`PER_WINDOW`] best turns of the placements'
/// poses about the window's chord ([`super::sweep`]): the [`PER_WINDOW`] of these that grow to the
/// most matched dots give those matches as seeds. A window alone cannot tell its placements apart
/// where dots stray (its placements fit it about equally); the whole view's dots can, and a long
/// chain that counted a stray step wrongly somewhere still has windows clear of that step.
fn window_seeds(chain: &[(i64, usize)], dots: &[Dot], path: &SPath, params: &SPathFitParams) -> Vec<Labels> {
    let window = WINDOW.min(chain.len()).max(1);
    let starts = (0..chain.len().saturating_sub(window - 1)).step_by(WINDOW / 2);
    let mut out = Vec::new();
    for s in starts {
        let placements = labellings(&chain[s..s + window], dots, path, params.pinhole());
        let mut verified: Vec<Labels> = placements.iter().filter_map(|(_, l)| consensus(dots, path, l, params)).collect();
        if let Some(k) = params.pinhole() {
            let turns = super::sweep::best_turns(&placements, dots, path, k, params.match_fraction, PER_WINDOW);
            verified.extend(turns.iter().filter_map(|l| consensus(dots, path, l, params)));
        }
        verified.sort_by_key(|l| std::cmp::Reverse(l.len()));
        out.extend(verified.into_iter().take(PER_WINDOW));
    }
    out
}

/// Refits of [`consensus`] while the matched dots grow.
const CONSENSUS_REFITS: usize = 4;

/// The dots a labelling's camera matches ([`match_projection`]), refitted to them while they
/// grow ([`CONSENSUS_REFITS`]), labelled.
pub(super) fn consensus(dots: &[Dot], path: &SPath, labels: &[(usize, usize)], params: &SPathFitParams) -> Option<Labels> {
    let fit = |l: &[(usize, usize)]| {
        let (world, image) = correspondences(l, dots, path);
        Dlt::fit_trimmed(&world, &image, params.pinhole())
    };
    let mut matched = match_projection(&fit(labels)?, dots, path, params.match_fraction);
    for _ in 0..CONSENSUS_REFITS {
        let Some(next) = fit(&matched).map(|c| match_projection(&c, dots, path, params.match_fraction)) else { break };
        if next.len() <= matched.len() {
            break;
        }
        matched = next;
    }
    Some(matched)
}
