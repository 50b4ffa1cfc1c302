//! Labelling S-path chains whose dots stray from the nominal path
//! ([`ChainGrowth::Strays`](crate::s_path_order::ChainGrowth::Strays)): labellings checked
//! against each other, prefixes that fit.

use super::anchor::{agreeing_prefix, compatible, median_step_px, with_anchor, STRAY_RMS_STEPS};
use super::label::{label_chain, labellings, ranked_labellings, DOMINANT_AMBIGUITY_RATIO};
use super::resolve::{chain_labels, resolve_labels, Head};
use super::{best_and_rival, extend_locally, fit_rms, grow, relaxed_start_seed, Labels, SPathFitParams};
use crate::dots::Dot;
use crate::s_path_order::SPathOrderParams;
use synthcam_core::target::SPath;

/// Steps by which [`fitting_prefix`] shortens a labelling.
const PREFIX_STEP: usize = 5;

/// The longest prefix (in path order, [`PREFIX_STEP`] entries at a time, at least `min_len`) of
/// a labelling from the start dot whose DLT fits within `max_rms_px`: where the projected steps
/// lengthen abruptly (the path turning across the line of sight) a chain of stray dots can take
/// several steps in a row as bridged, and the count beyond is off; the projection of the known
/// path places those dots again from the part that fits.
fn fitting_prefix(dots: &[Dot], path: &SPath, mut labels: Labels, max_rms_px: f64, params: &SPathFitParams) -> Labels {
    let min_len = params.min_seed;
    labels.sort_unstable();
    while labels.len() > min_len && fit_rms(dots, path, &labels, params.pinhole()).is_none_or(|r| r > max_rms_px) {
        labels.truncate(labels.len().saturating_sub(PREFIX_STEP).max(min_len));
    }
    labels
}

/// Labellings of the longest chain tried against the second chain ([`label_pair`]).
const PAIR_CANDIDATES: usize = 4;

/// The labelling of two chains together, where neither labels alone: each of the first chain's
/// best [`PAIR_CANDIDATES`] labellings (open steps decided, [`ranked_labellings`]) with the second chain's labelling compatible with it that
/// fits best with it; the pair that fits best wins if the runner-up pair fits worse by
/// [`DOMINANT_AMBIGUITY_RATIO`] and the two hold as many dots as a path needs (`need`). A long
/// chain shifted by one index along the smooth path fits almost as well as the right one (3.15
/// against 2.66 px on 5 mm strays), but not beside a second stretch of the path.
fn label_pair(
    first: &[(i64, usize)],
    second: &[(i64, usize)],
    dots: &[Dot],
    path: &SPath,
    params: &SPathFitParams,
    need: usize,
    max_rms_px: f64,
) -> Option<Labels> {
    if first.len() + second.len() < need {
        return None;
    }
    let seconds = labellings(second, dots, path, params.pinhole());
    let mut pairs: Vec<(f64, Labels)> = ranked_labellings(first, dots, path, params, &[], true)
        .into_iter()
        .take(PAIR_CANDIDATES)
        .filter_map(|(_, a)| {
            let joined = seconds.iter().filter(|b| compatible(&b.1, &a)).map(|b| with_anchor(a.clone(), &b.1));
            joined.filter_map(|u| Some((fit_rms(dots, path, &u, params.pinhole())?, u))).min_by(|x, y| x.0.total_cmp(&y.0))
        })
        .collect();
    pairs.sort_by(|a, b| a.0.total_cmp(&b.0));
    let best = pairs.first()?.0;
    let runner_up = pairs.get(1).map_or(f64::INFINITY, |p| p.0);
    log::debug!("s-path chain pair of {} + {} dots: best RMS {best:.3} px, runner-up {runner_up:.3} px", first.len(), second.len());
    (best <= max_rms_px && runner_up > DOMINANT_AMBIGUITY_RATIO * best.max(0.05)).then(|| pairs.swap_remove(0).1)
}

/// The labelling of a chain from the start dot: by the path's shape where that is unambiguous
/// (the shape wins over the count from the start dot: a bead pressed against the start bead, or
/// the first step seen through strong distortion, can leave the count one off from there on),
/// its open steps decided ([`resolve_labels`]), cut to its [`fitting_prefix`].
pub(super) fn label_start_chain(chain: &[(i64, usize)], dots: &[Dot], path: &SPath, params: &SPathFitParams, need: usize) -> Labels {
    let shaped = label_chain(chain, dots, path, params, chain.len() >= need, &[], false).unwrap_or_else(|| chain_labels(chain));
    fitting_prefix(dots, path, resolve_labels(dots, path, shaped, &[], Head::StartDot, params.pinhole()), STRAY_RMS_STEPS * median_step_px(chain, dots), params)
}

/// The labelling of chains grown from any dot: a chain from the start dot too short to place the
/// path still rules out the labellings it contradicts (the S is nearly point-symmetric: the
/// reversed labelling of a long chain fits almost as well, 3.9 against 3.2 px on 5 mm strays)
/// and joins the seed; without one (or where it contradicts them all), the two longest chains
/// label each other ([`label_pair`]), or the longest chain's placements are told apart by how far
/// each grows ([`by_growth`]). Each side's open steps are then decided with the other beside it.
pub(super) fn label_chains(chains: &[Vec<(i64, usize)>], dots: &[Dot], path: &SPath, params: &SPathFitParams, order: &SPathOrderParams) -> Option<Labels> {
    let need = order.needed(dots.len());
    let anchor = relaxed_start_seed(dots, path, order, params).unwrap_or_default();
    let labelled = chains.iter().find_map(|c| {
        label_chain(c, dots, path, params, c.len() + anchor.len() >= need, &anchor, true).or_else(|| by_growth(c, dots, path, params, &anchor, need))
    });
    // A start chain miscounted where its dots stray contradicts every labelling: the pair then
    // labels without it (its entries that agree still join below).
    let labelled = labelled.or_else(|| match chains {
        [first, second, ..] => label_pair(first, second, dots, path, params, need, STRAY_RMS_STEPS * median_step_px(first, dots)),
        _ => None,
    });
    let labelled = labelled.or_else(|| chains.first().and_then(|c| by_growth(c, dots, path, params, &[], need)))?;
    let anchor = resolve_labels(dots, path, anchor, &labelled, Head::StartDot, params.pinhole());
    let labels = resolve_labels(dots, path, labelled, &anchor, if anchor.is_empty() { Head::Placed } else { Head::StartDot }, params.pinhole());
    let prefix = agreeing_prefix(anchor, &labels);
    Some(with_anchor(labels, &prefix))
}

/// Placements of the longest chain grown over all dots by [`by_growth`].
const GROWN_CANDIDATES: usize = 3;
/// Dots fewer than the most placed at which a placement no longer contends in [`by_growth`].
const GROWTH_MARGIN: usize = 5;

/// The placement of a chain holding at least half the dots a path needs (`need`), among its best
/// [`GROWN_CANDIDATES`] ([`ranked_labellings`] with `anchor`, whose agreeing entries join it),
/// grown over the other dots (projection and local extension, as the labelling is placed): those
/// placing fewer than [`GROWTH_MARGIN`] dots less than the most contend, and the one that fits
/// best wins if it places as many as a path needs, fits within the strays' RMS, and every
/// contender disagreeing with it on most of its dots fits worse by [`DOMINANT_AMBIGUITY_RATIO`]
/// (grown over the whole path, a placement one index off fits 1.4 to 1.7 times worse on 5 mm
/// strays). Where the start dot is out of view the nearly point-symmetric S reversed fits a
/// 70-dot chain almost as well (2.79 against 2.49 px), but the path it predicts beyond the chain
/// finds no dots (70 placed against 77): it does not contend.
fn by_growth(chain: &[(i64, usize)], dots: &[Dot], path: &SPath, params: &SPathFitParams, anchor: &[(usize, usize)], need: usize) -> Option<Labels> {
    if 2 * chain.len() < need {
        return None;
    }
    let mut grown: Vec<(usize, f64, Labels)> = ranked_labellings(chain, dots, path, params, anchor, true)
        .into_iter()
        .take(GROWN_CANDIDATES)
        .filter_map(|(_, l)| {
            let prefix = agreeing_prefix(anchor.to_vec(), &l);
            let g = extend_locally(dots, path, grow(dots, path, with_anchor(l, &prefix), params), params);
            Some((g.len(), fit_rms(dots, path, &g, params.pinhole())?, g))
        })
        .collect();
    // Contenders place nearly as many as the most; among them the best fit wins.
    let most = grown.iter().map(|g| g.0).max()?;
    grown.retain(|g| g.0 + GROWTH_MARGIN > most);
    let (placed, rms, best, rival) = best_and_rival(grown)?;
    log::debug!("s-path chain of {} dots by growth: {placed} placed at RMS {rms:.3} px, rival contender RMS {rival:.3} px", chain.len());
    let fits = rms <= STRAY_RMS_STEPS * median_step_px(chain, dots);
    (placed >= need && rival > DOMINANT_AMBIGUITY_RATIO * rms && fits).then_some(best)
}
