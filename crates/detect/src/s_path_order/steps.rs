//! Step lengths, directions and index increments of a chain of S-path dots.

use crate::dots::Dot;

/// Path steps a chain's direction is averaged over. A dot that strays from the nominal path (by
/// up to a fifth of the 25.7 mm spacing on a painted or glued target) turns a single step by up to
/// 50 degrees and makes it up to twice as long as the next; the mean over a few steps does not.
pub(super) const MEAN_STEPS: i64 = 3;

/// Path steps a chain's step length is measured over, along the chain (the sum of its steps: the
/// strays' shifts along the path cancel in the sum, and unlike a chord it follows the turns).
/// Over six steps 5 mm strays move the mean by at most 1/15 of it, so one step (at most 1.4
/// nominal steps long) and two (at least 1.6) stay apart.
pub(super) const LENGTH_STEPS: i64 = 6;

/// Distances from the last dot, in mean steps, of a dot taken `skip` path indices on: one step
/// up to 1.6, two from 1.6 to 2.6 (see [`LENGTH_STEPS`]). Until the chain spans [`MEAN_STEPS`]
/// its mean step is one jittered step: a single step may then be 0.45 to 2.2 of it, and no dot
/// is bridged.
pub(super) fn step_band(skip: usize, established: bool) -> Option<std::ops::RangeInclusive<f64>> {
    match (skip, established) {
        (1, true) => Some(0.45..=1.6),
        (1, false) => Some(0.45..=2.2),
        (k, true) => Some(k as f64 - 0.4..=k as f64 + 0.6),
        (_, false) => None,
    }
}

/// The mean step ending at chain entry `end`: from the earliest entry at most [`MEAN_STEPS`]
/// path indices before it (its path index and the step per index), `None` at the chain's start.
pub(super) fn mean_step(dots: &[Dot], chain: &[(i64, usize)], end: usize) -> Option<(i64, nalgebra::Vector2<f64>)> {
    let (i_end, j_end) = chain[end];
    let first = chain[..end].iter().position(|&(i, _)| i_end - i <= MEAN_STEPS)?;
    let (i0, j0) = chain[first];
    Some((i0, (dots[j_end].centre_px - dots[j0].centre_px) / (i_end - i0) as f64))
}

/// The chain's step length near its end (per path index, along the chain over the last
/// [`LENGTH_STEPS`]) and whether it spans [`MEAN_STEPS`] indices yet.
pub(super) fn step_length(dots: &[Dot], chain: &[(i64, usize)]) -> (f64, bool) {
    let i_end = chain[chain.len() - 1].0;
    let first = chain.iter().position(|&(i, _)| i_end - i <= LENGTH_STEPS).unwrap_or(0);
    let length: f64 = steps(dots, &chain[first..]).0.iter().sum();
    let span = i_end - chain[first].0;
    (length / span.max(1) as f64, span >= MEAN_STEPS)
}

/// Turn per step ahead of the chain's end (radians): the angle between its last two mean steps
/// ([`mean_step`]), carried from the middle of the last one to the step ahead; 0 on a chain too
/// short for two.
pub(super) fn turn_ahead(dots: &[Dot], chain: &[(i64, usize)], i_mid: i64, step: nalgebra::Vector2<f64>) -> f64 {
    let i_cur = chain[chain.len() - 1].0;
    let mid = chain.iter().rposition(|&(i, _)| i == i_mid).unwrap_or(0);
    let Some((i_old, before)) = mean_step(dots, chain, mid) else { return 0.0 };
    let ang = (before.x * step.y - before.y * step.x).atan2(before.dot(&step));
    let per_step = ang / ((i_cur - i_old) as f64 / 2.0).max(1.0);
    (per_step * ((i_cur - i_mid) as f64 / 2.0 + 0.5)).clamp(-0.6, 0.6)
}

/// Steps on each side of a chain step that its local step length is measured on
/// ([`reindex_steps`]).
const REINDEX_STEPS: usize = 4;

/// Step length over the centred local length ([`REINDEX_STEPS`] steps on each side, per path
/// index) for a chain's step lengths `len` and index increments `inc`; `None` with fewer than
/// two indices around.
fn centred_ratios(len: &[f64], inc: &[i64]) -> Vec<Option<f64>> {
    (0..len.len())
        .map(|k| {
            let near = (k.saturating_sub(REINDEX_STEPS)..(k + 1 + REINDEX_STEPS).min(len.len())).filter(|&m| m != k);
            let (sum, span) = near.fold((0.0, 0), |(s, n), m| (s + len[m], n + inc[m]));
            (span >= 2).then(|| len[k] * span as f64 / sum.max(1e-12))
        })
        .collect()
}

/// Step lengths and index increments of a chain.
fn steps(dots: &[Dot], chain: &[(i64, usize)]) -> (Vec<f64>, Vec<i64>) {
    chain.windows(2).map(|w| ((dots[w[1].1].centre_px - dots[w[0].1].centre_px).norm(), w[1].0 - w[0].0)).unzip()
}

/// Re-decide each chain step's index increment (1, or 2 where a dot is missing) against the
/// length of the steps around it ([`centred_ratios`]), until stable. Growing, the chain knows
/// only the steps behind it: where foreshortening lengthens the projected steps quickly (the path
/// coming round from the sphere's outline), a stray dot's single step looks like two. Centred,
/// the local length has no such lag: a step of under 1.5 local lengths is one index (strays that
/// leave this open are listed by [`ambiguous_steps`]). A chain spans at most `points - 1`
/// indices ([`fit_span`]). The first entry keeps its index.
pub(super) fn reindex_steps(dots: &[Dot], chain: &mut [(i64, usize)], points: usize) {
    if chain.len() < 3 {
        return;
    }
    let (len, mut inc) = steps(dots, chain);
    for _ in 0..4 {
        let next: Vec<i64> = centred_ratios(&len, &inc).iter().zip(&inc).map(|(r, &i)| r.map_or(i, |r| if r < 1.5 { 1 } else { 2 })).collect();
        if next == inc {
            break;
        }
        inc = next;
    }
    fit_span(&len, &mut inc, points as i64 - 1);
    let mut index = chain[0].0;
    for (entry, d) in chain.iter_mut().skip(1).zip(&inc) {
        index += d;
        entry.0 = index;
    }
}

/// Bring the increments `inc` of steps of lengths `len` down to a span of at most `max_span`
/// indices: the path has no more, so the chain counted some single steps as bridged. The bridged
/// step shortest against its local length ([`centred_ratios`]) counts one index less, one at a
/// time. Where dots stray, foreshortening can make every other step look like two: a 101-dot
/// chain spanning 119 indices of the 101-point course path, which no labelling fits.
pub(super) fn fit_span(len: &[f64], inc: &mut [i64], max_span: i64) {
    while inc.iter().sum::<i64>() > max_span {
        let ratios = centred_ratios(len, inc);
        let bridged = (0..inc.len()).filter(|&k| inc[k] > 1);
        let Some(k) = bridged.min_by(|&a, &b| ratios[a].unwrap_or(f64::INFINITY).total_cmp(&ratios[b].unwrap_or(f64::INFINITY))) else { return };
        inc[k] -= 1;
    }
}

/// Centred length ratios ([`centred_ratios`]) that leave a step's increment open: a stray dot's
/// single step seen obliquely reaches 1.5 local lengths, two steps with one dot missing come down
/// to about 1.6.
const AMBIGUOUS_RATIO: std::ops::RangeInclusive<f64> = 1.3..=1.85;

/// Positions `k` of the chain steps (from entry `k` to `k + 1`) whose increment the step lengths
/// leave open: every bridged step, and single steps at [`AMBIGUOUS_RATIO`] local lengths; the
/// caller decides them by other means (the path's shape).
pub(crate) fn ambiguous_steps(dots: &[Dot], chain: &[(i64, usize)]) -> Vec<usize> {
    let (len, inc) = steps(dots, chain);
    let ratios = centred_ratios(&len, &inc);
    (0..inc.len()).filter(|&k| inc[k] > 1 || ratios[k].is_some_and(|r| AMBIGUOUS_RATIO.contains(&r))).collect()
}
