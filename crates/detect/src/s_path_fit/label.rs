//! Labellings of a chain of dots: every placement along the path, ranked by the path's shape.

use nalgebra::{Point2, Point3};

use super::anchor::{agreeing_prefix, median_step_px, with_anchor, STRAY_RMS_STEPS};
use super::dlt::Dlt;
use super::resolve::{resolve_labels, Head};
use super::{fit_rms, Labels, Pinhole, SPathFitParams};
use crate::dots::Dot;
use synthcam_core::target::SPath;

/// Every labelling of an unlabelled chain ((relative index, dot) pairs), at every index offset
/// and in both directions, with its DLT reprojection RMS (px): best first.
pub(super) fn labellings(chain: &[(i64, usize)], dots: &[Dot], path: &SPath, pinhole: Pinhole) -> Vec<(f64, Labels)> {
    let n = path.len() as i64;
    let image: Vec<Point2<f64>> = chain.iter().map(|&(_, j)| dots[j].centre_px).collect();
    let (lo, hi) = chain.iter().fold((i64::MAX, i64::MIN), |(a, b), &(i, _)| (a.min(i), b.max(i)));
    let mut fits: Vec<(f64, Labels)> = Vec::new();
    for dir in [1i64, -1] {
        // Absolute index = offset + dir * relative, all in 0..n.
        let (omin, omax) = if dir == 1 { (-lo, n - 1 - hi) } else { (hi, n - 1 + lo) };
        for offset in omin..=omax {
            let labels: Labels = chain.iter().map(|&(i, j)| ((offset + dir * i) as usize, j)).collect();
            let world: Vec<Point3<f64>> = labels.iter().map(|&(i, _)| path.points_m[i]).collect();
            if let Some(dlt) = Dlt::fit(&world, &image, pinhole) {
                fits.push((dlt.rms(&world, &image), labels));
            }
        }
    }
    fits.sort_by(|a, b| a.0.total_cmp(&b.0));
    fits
}

/// The runner-up labelling's RMS over the best's that a chain holding most of the dots (as many
/// as a path needs) must exceed, in place of [`SPathFitParams::ambiguity_ratio`]: clutter never
/// chains most of the dots, and on a target whose dots stray from the nominal path the strays
/// set both RMS values (2.7 against 4.2 px for a 97-dot chain of 5 mm strays).
pub(super) const DOMINANT_AMBIGUITY_RATIO: f64 = 1.25;

/// Every labelling of a chain that agrees with the first steps of `anchor` (labels known
/// otherwise, e.g. a short chain from the start dot; may be empty: a labelling must agree with
/// its first [`SPathFitParams::min_seed`] entries), ranked by its RMS together with the entries
/// of `anchor` up to the first it contradicts ([`agreeing_prefix`]: where the start chain
/// miscounted a stray step, everything beyond is one index off). `resolve`: each has its open
/// steps decided by the path's shape first ([`resolve_labels`]): where dots stray, one step
/// counted as two sets every labelling off beyond it (4.3 against 4.4 px for the best two of a
/// 98-dot chain, 2.2 against 3.1 once decided; the right placement of a 73-dot chain with four
/// such steps ranked below the fourth before). Identical labellings are listed once.
pub(super) fn ranked_labellings(
    chain: &[(i64, usize)],
    dots: &[Dot],
    path: &SPath,
    params: &SPathFitParams,
    anchor: &[(usize, usize)],
    resolve: bool,
) -> Vec<(f64, Labels)> {
    let first_steps = anchor.len().min(params.min_seed);
    let anchored = |l: &Labels| agreeing_prefix(anchor.to_vec(), l);
    let fits = labellings(chain, dots, path, params.pinhole()).into_iter().filter(|f| anchored(&f.1).len() >= first_steps);
    if anchor.is_empty() && !resolve {
        return fits.collect();
    }
    // Ranked by the fit of the labelling and the anchor together: a labelling shifted along the
    // smooth path fits the chain alone almost as well, but not the anchor beside it.
    let mut ranked: Vec<(f64, Labels)> = fits
        .filter_map(|(_, l)| {
            let a = anchored(&l);
            let head = if a.is_empty() { Head::Placed } else { Head::StartDot };
            let l = if resolve { resolve_labels(dots, path, l, &a, head, params.pinhole()) } else { l };
            Some((fit_rms(dots, path, &with_anchor(l.clone(), &a), params.pinhole())?, l))
        })
        .collect();
    ranked.sort_by(|a, b| a.0.total_cmp(&b.0));
    // Two labellings can settle on the same one: it is no rival of itself.
    ranked.dedup_by(|a, b| a.1 == b.1);
    ranked
}

/// The labelling of a whole chain, when it is clearly the best of its [`ranked_labellings`].
/// `dominant`: the chain holds as many dots as a path needs ([`DOMINANT_AMBIGUITY_RATIO`]).
pub(super) fn label_chain(
    chain: &[(i64, usize)],
    dots: &[Dot],
    path: &SPath,
    params: &SPathFitParams,
    dominant: bool,
    anchor: &[(usize, usize)],
    resolve: bool,
) -> Option<Labels> {
    let mut fits = ranked_labellings(chain, dots, path, params, anchor, resolve);
    let best = fits.first()?.0;
    let runner_up = fits.get(1).map_or(f64::INFINITY, |f| f.0);
    log::debug!("s-path chain of {} dots: best RMS {best:.3} px, runner-up {runner_up:.3} px", chain.len());
    let (ratio, max_rms) = match dominant {
        true => (DOMINANT_AMBIGUITY_RATIO, params.max_seed_rms_px.max(STRAY_RMS_STEPS * median_step_px(chain, dots))),
        false => (params.ambiguity_ratio, params.max_seed_rms_px),
    };
    (best <= max_rms && runner_up > ratio * best.max(0.05)).then(|| fits.swap_remove(0).1)
}
