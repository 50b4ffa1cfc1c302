//! Seed labellings of the S-path's dots for the assignment ([`super::assign`]).

use super::assign;
use super::label::labellings;
use super::resolve::chain_labels;
use super::{more_placed, place_labels, skipped, Labels, SPathFitParams};
use crate::dots::Dot;
use crate::s_path_order::{anonymous_chains, start_dot_chain, ChainGrowth, SPathOrderParams};
use synthcam_core::target::SPath;

/// The dot recognised as the start ([`start_dot_chain`]'s first), if any.
pub(super) fn start_dot(dots: &[Dot], order: &SPathOrderParams) -> Option<usize> {
    start_dot_chain(dots, order).ok().and_then(|c| c.first().map(|e| e.1))
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
            out.extend(labellings(chain, dots, path).into_iter().take(SEED_CHAINS).map(|(_, l)| l));
        }
    }
    (chained, out)
}
