//! The last checks on placed S-path dots: merged blobs, residuals that jump, chains placed
//! elsewhere by their own shape, and the S run backwards.

use super::dlt::Dlt;
use super::label::label_chain;
use super::{correspondences, Labels, SPathFitParams};
use crate::dots::Dot;
use crate::filters::median_by;
use crate::s_path_order::{anonymous_chains, ChainGrowth, SPathOrderParams};
use synthcam_core::target::SPath;

/// Blobs smaller than this (px^2) are held to [`SMALL_BLOB_DEVIATION_PX`] by [`drop_outliers`].
const SMALL_BLOB_PX: f64 = 20.0;
/// Largest deviation of a small blob's residual from its neighbours', pixels.
const SMALL_BLOB_DEVIATION_PX: f64 = 0.6;

/// A residual's jump is an outlier beyond this many robust standard deviations of all jumps.
const JUMP_SIGMAS: f64 = 4.0;

/// Drop matches whose reprojection residual differs from the median residual of their path
/// neighbours (up to 3 indices either side) by more than `max_px` (small blobs: see
/// [`SMALL_BLOB_DEVIATION_PX`]). The residuals of good dots vary smoothly along the path (the
/// blob-centroid bias of beads, lens distortion); a blob that lost part of itself (a sliver
/// along the outline) jumps. On a target whose dots stray from the nominal path (painted or
/// glued by hand) every residual jumps: the bound widens to [`JUMP_SIGMAS`] robust standard
/// deviations (1.4826 median absolute jumps) of all the jumps.
pub(super) fn drop_outliers(dots: &[Dot], path: &SPath, labels: Vec<(usize, usize)>, params: &SPathFitParams) -> Vec<(usize, usize)> {
    let max_px = params.max_local_deviation_px;
    let (world, image) = correspondences(&labels, dots, path);
    let Some(dlt) = Dlt::fit(&world, &image, params.pinhole()) else { return labels };
    let residual: Vec<Option<nalgebra::Vector2<f64>>> = world.iter().zip(&image).map(|(x, u)| dlt.project(x).map(|q| u - q)).collect();
    // Each residual's jump against its path neighbours' median (None: behind the camera; 0 with
    // fewer than two neighbours, which are always kept).
    let jumps: Vec<Option<f64>> = (0..labels.len())
        .map(|k| {
            let r = residual[k]?;
            let near: Vec<nalgebra::Vector2<f64>> =
                (0..labels.len()).filter(|&m| m != k && labels[m].0.abs_diff(labels[k].0) <= 3).filter_map(|m| residual[m]).collect();
            if near.len() < 2 {
                return Some(0.0);
            }
            let med = |f: fn(&nalgebra::Vector2<f64>) -> f64| median_by(&mut near.iter().map(f).collect::<Vec<_>>(), f64::total_cmp).unwrap_or(0.0);
            Some((r - nalgebra::Vector2::new(med(|v| v.x), med(|v| v.y))).norm())
        })
        .collect();
    let sigma = 1.4826 * median_by(&mut jumps.iter().flatten().copied().collect::<Vec<_>>(), f64::total_cmp).unwrap_or(0.0);
    let spread = JUMP_SIGMAS * sigma;
    log::debug!("s-path residual jumps: robust sigma {sigma:.3} px");
    let keep = jumps.iter().zip(&labels).map(|(jump, &(_, j))| {
        // Small blobs (slivers, far dots) carry little centroid bias: a tighter bound.
        let base = if dots[j].area_px < SMALL_BLOB_PX { SMALL_BLOB_DEVIATION_PX.min(max_px) } else { max_px };
        jump.is_some_and(|d| d <= base.max(spread))
    });
    let keep: Vec<bool> = keep.collect();
    labels.into_iter().zip(keep).filter_map(|(l, k)| k.then_some(l)).collect()
}

/// Drop blobs far larger than their path neighbours (up to 5 indices either side, the start dot
/// left out of the comparison): beads squeezed together along the sphere's outline merge into
/// one blob, whose centroid is no dot's. The start dot itself may be `start_ratio` times larger.
pub(super) fn drop_merged(dots: &[Dot], labels: Vec<(usize, usize)>, start_ratio: f64) -> Vec<(usize, usize)> {
    const MAX_RATIO: f64 = 2.0;
    let keep: Vec<bool> = labels
        .iter()
        .map(|&(i, j)| {
            let mut near: Vec<f64> = labels.iter().filter(|&&(k, _)| k != i && k != 0 && k.abs_diff(i) <= 5).map(|&(_, m)| dots[m].area_px).collect();
            let Some(typical) = median_by(&mut near, f64::total_cmp) else { return true };
            let limit = MAX_RATIO * if i == 0 { start_ratio.max(1.0) * 1.5 } else { 1.0 };
            dots[j].area_px <= limit * typical
        })
        .collect();
    labels.into_iter().zip(keep).filter_map(|(l, k)| k.then_some(l)).collect()
}

/// `labels` less the dots of every chain (strict growth, at least [`SPathFitParams::min_seed`]
/// dots) whose own shape places it clearly elsewhere ([`label_chain`]: its best placement, by a
/// projective camera fitted to the chain alone, beats the runner-up by
/// [`SPathFitParams::ambiguity_ratio`]) on most of its dots. The assignment's single camera, fitted
/// to the whole view, can carry a stretch it extrapolates to (through lens distortion it cannot
/// model) one index off; a chain of nominal dots knows its own place.
pub(super) fn drop_contradicted(dots: &[Dot], path: &SPath, labels: Labels, params: &SPathFitParams, order: &SPathOrderParams) -> Labels {
    let strict = SPathOrderParams { growth: ChainGrowth::Strict, ..*order };
    let mut out = labels;
    for chain in anonymous_chains(dots, &strict, params.min_seed) {
        let Some(own) = label_chain(&chain, dots, path, params, false, &[], false) else { continue };
        let disagree = own.iter().filter(|&&(i, j)| out.iter().any(|&(k, m)| m == j && k != i)).count();
        if 2 * disagree > own.len() {
            log::debug!("s-path: a chain of {} dots placed elsewhere by its own shape ({disagree} disagree): left out", own.len());
            out.retain(|&(_, j)| own.iter().all(|&(_, m)| m != j));
        }
    }
    out
}

/// Reversals of a labelling, fitting a projective camera best, whose assignments
/// [`reversal_explains_better`] compares with the labelling's own.
const REVERSALS_TRIED: usize = 2;

/// Does the labelling run backwards explain the dots better than the labelling itself: a lower
/// assignment cost ([`super::assign::assign`], the measure the assignment itself minimises) for one
/// of its [`REVERSALS_TRIED`] reversals that fit a projective camera best
/// ([`super::assign::best_reversals`], mirrored within 8 indices, keeping all its dots)? The S is
/// nearly point-symmetric: where its dots stray from the nominal path, a placement and its
/// reversal fit a camera about equally, and a view whose labelling its own reversal explains
/// better is ambiguous, not found: reported, it would be wholly wrong. On independent 7 mm renders
/// (`benches/spath_independent.py`, five seeds, 92 views found rightly) the right labellings cost
/// at most 0.87 times their best reversal's; the two views found reversed (seed 22600 A_03, 652380 A_11:
/// 64 and 88 dots) cost 1.01 and 1.21 times theirs (a plain DLT preferred the wrong one on the
/// second: 3.91 against 4.33 px). The camera path tells them apart by the pose.
pub(super) fn reversal_explains_better(dots: &[Dot], path: &SPath, labels: &[(usize, usize)], params: &SPathFitParams) -> bool {
    let n = dots.len();
    let cost = |l: &[(usize, usize)]| super::assign::assign(dots, path, l, params).map(|a| a.cost(n));
    let Some(own) = cost(labels) else { return false };
    super::assign::best_reversals(labels, dots, path, None, labels.len(), REVERSALS_TRIED).iter().filter_map(|l| cost(l)).any(|c| c < own)
}
