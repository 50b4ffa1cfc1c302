//! Index increments a chain's step lengths leave open, decided by the path's shape.

use super::anchor::with_anchor;
use super::{fit_rms, Labels, Pinhole};
use crate::dots::Dot;
use crate::s_path_order::{ambiguous_steps, MAX_SKIP};
use synthcam_core::target::SPath;

/// How much better (RMS factor) the other increment of an open step must fit: a wrong increment
/// raises the RMS by a factor 1.3 to 2.3 on 5 mm strays (2.4 against 4.4 px); where one camera
/// fits no labelling well (strong lens distortion over the whole chain), both fit alike.
const RESOLVE_GAIN: f64 = 0.85;

/// Largest reprojection RMS (px) of the chain's own fit at which [`resolve_steps`] decides
/// anything: 5 mm strays fit at 2 to 5 px, a chain one index off beyond a step at 10 to 20.
const DECIDABLE_RMS_PX: f64 = 100.0;

/// What a chain's entry at path index 0 is: the start dot (recognised, so its index is known and
/// it may not move) or a dot a labelling merely placed there (it may move up like any other).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub(super) enum Head {
    /// The chain starts at the start dot.
    StartDot,
    /// The chain's placement along the path is a hypothesis.
    Placed,
}

/// Decide the steps of a chain (path indices from 0) whose index increment its lengths leave
/// open ([`ambiguous_steps`]: a stray dot, a missing one, or the projected steps lengthening
/// abruptly where the path turns across the line of sight) by the shape of the path: the
/// increment with which one projective camera fits the whole chain clearly better
/// ([`RESOLVE_GAIN`]) wins. A camera absorbs a shift of a whole chain along the smooth path, but
/// not one of only its part beyond a step. Steps are decided in order, each with the ones before
/// it settled. (Fitted to a window of 25 entries around the step instead, the camera's 11
/// parameters absorb the shift of the strays' half-window: 14 of 40 views ordered, against 34.)
///
/// `beside`: labels fitted together with the chain's (those compatible with it), e.g. a
/// labelled stretch elsewhere on the path that fixes where the chain lies along it (may be empty).
/// `head`: whether an entry at index 0 is the start dot ([`Head`]).
pub(super) fn resolve_steps(
    dots: &[Dot],
    path: &SPath,
    mut chain: Vec<(i64, usize)>,
    beside: &[(usize, usize)],
    head: Head,
    pinhole: Pinhole,
) -> Vec<(i64, usize)> {
    let n = path.len() as i64;
    let rms = |c: &[(i64, usize)]| {
        let labels: Labels = c.iter().filter(|&&(i, _)| (0..n).contains(&i)).map(|&(i, j)| (i as usize, j)).collect();
        fit_rms(dots, path, &with_anchor(labels, beside), pinhole).unwrap_or(f64::INFINITY)
    };
    let mut now = rms(&chain);
    log::trace!(
        "s-path resolve: {} entries, RMS {now:.3} px, open steps {:?}, chain {:?}",
        chain.len(),
        ambiguous_steps(dots, &chain),
        chain.iter().map(|e| e.0).take(12).collect::<Vec<_>>()
    );
    if now > DECIDABLE_RMS_PX {
        // A short stretch of the sphere is nearly planar: its DLT is degenerate, and comparing
        // two of its residuals (6.9e5 against 4.7e5 px on a 23-dot start chain) decides nothing.
        return chain;
    }
    for k in ambiguous_steps(dots, &chain) {
        if k + 1 >= chain.len() {
            break;
        }
        let alts = alternatives(&chain, k, head).into_iter().map(|c| (rms(&c), c));
        let Some((other, alt)) = alts.min_by(|a, b| a.0.total_cmp(&b.0)) else { continue };
        log::trace!("s-path step {k} (index {}): RMS {now:.3} px, with the other increment {other:.3} px", chain[k].0);
        if other < RESOLVE_GAIN * now {
            (chain, now) = (alt, other);
        }
    }
    chain.retain(|&(i, _)| (0..n).contains(&i));
    chain
}

/// The chain with the increment of step `k` (from entry `k` to `k + 1`) one more or one less,
/// as its length leaves open: with the entries after the step moved up to the next gap no bridge
/// explains (longer than [`MAX_SKIP`]), or those before it back to the last such gap (a chain
/// that is not the start dot's, or a stretch of labels after such a gap, is placed along the
/// path by its own fit). Across such a gap the increment may grow or shrink. A head at index 0
/// moves only where it is not the start dot (`head`): a labelling of a chain missing its start
/// dot can place the chain's first dot at index 0 and count a later step as two (one 5 mm
/// stray view: 31 dots one index low, 3.4 px RMS against 2.2 with the head moved up).
fn alternatives(chain: &[(i64, usize)], k: usize, head: Head) -> Vec<Vec<(i64, usize)>> {
    let unbridged = |m: usize| chain[m + 1].0 - chain[m].0 > MAX_SKIP as i64;
    let flips: &[i64] = match chain[k + 1].0 - chain[k].0 {
        1 => &[1],
        2 => &[-1],
        _ => &[-1, 1],
    };
    let start = (0..k).rev().find(|&m| unbridged(m)).map_or(0, |m| m + 1);
    let end = (k + 1..chain.len() - 1).find(|&m| unbridged(m)).map_or(chain.len(), |m| m + 1);
    let head_free = head == Head::Placed || chain[0].0 != 0;
    let mut out = Vec::new();
    // A shift by one leaves an unbridged gap (3 or more) positive: the moved stretch stays in
    // order; only a head reaching the path's start may not move (nor the start dot's).
    for &flip in flips {
        let mut tail = chain.to_vec();
        tail[k + 1..end].iter_mut().for_each(|e| e.0 += flip);
        out.push(tail);
        let mut moved = chain.to_vec();
        moved[start..=k].iter_mut().for_each(|e| e.0 -= flip);
        if start > 0 || (head_free && moved[0].0 >= 0) {
            out.push(moved);
        }
    }
    out
}

/// A chain's entries (path indices from 0) as labels.
pub(super) fn chain_labels(chain: &[(i64, usize)]) -> Labels {
    chain.iter().map(|&(i, j)| (i as usize, j)).collect()
}

/// [`resolve_steps`] on a labelling.
pub(super) fn resolve_labels(dots: &[Dot], path: &SPath, mut labels: Labels, beside: &[(usize, usize)], head: Head, pinhole: Pinhole) -> Labels {
    labels.sort_unstable();
    let chain = labels.iter().map(|&(i, j)| (i as i64, j)).collect();
    chain_labels(&resolve_steps(dots, path, chain, beside, head, pinhole))
}
