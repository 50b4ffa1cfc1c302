//! Index increments a chain's step lengths leave open, decided by the path's shape.

use super::{fit_rms, Labels};
use crate::detect::dots::Dot;
use crate::detect::s_path_order::ambiguous_steps;
use crate::target::SPath;

/// How much better (RMS factor) the other increment of an open step must fit: a wrong increment
/// raises the RMS by a factor 1.3 to 2.3 on 5 mm strays (2.4 against 4.4 px); where one camera
/// fits no labelling well (strong lens distortion over the whole chain), both fit alike.
const RESOLVE_GAIN: f64 = 0.85;

/// Decide the steps of a chain (path indices from 0) whose index increment its lengths leave
/// open ([`ambiguous_steps`]: a stray dot, a missing one, or the projected steps lengthening
/// abruptly where the path turns across the line of sight) by the shape of the path: the
/// increment with which one projective camera fits the whole chain clearly better
/// ([`RESOLVE_GAIN`]) wins. A camera absorbs a shift of a whole chain along the smooth path, but
/// not one of only its part beyond a step. Steps are decided in order, each with the ones before
/// it settled. (Fitted to a window of 25 entries around the step instead, the camera's 11
/// parameters absorb the shift of the strays' half-window: 14 of 40 views ordered, against 34.)
pub(super) fn resolve_steps(dots: &[Dot], path: &SPath, mut chain: Vec<(i64, usize)>) -> Vec<(i64, usize)> {
    let n = path.len() as i64;
    let rms = |c: &[(i64, usize)]| {
        let labels: Labels = c.iter().filter(|&&(i, _)| (0..n).contains(&i)).map(|&(i, j)| (i as usize, j)).collect();
        fit_rms(dots, path, &labels).unwrap_or(f64::INFINITY)
    };
    let mut now = rms(&chain);
    for k in ambiguous_steps(dots, &chain) {
        if k + 1 >= chain.len() {
            break;
        }
        let flip = if chain[k + 1].0 - chain[k].0 == 1 { 1 } else { -1 };
        let mut alt = chain.clone();
        alt[k + 1..].iter_mut().for_each(|e| e.0 += flip);
        let other = rms(&alt);
        log::trace!("s-path step {k} (index {}): RMS {now:.3} px, with the other increment {other:.3} px", chain[k].0);
        if other < RESOLVE_GAIN * now {
            (chain, now) = (alt, other);
        }
    }
    chain.retain(|&(i, _)| i < n);
    chain
}

/// A chain's entries (path indices from 0) as labels.
pub(super) fn chain_labels(chain: &[(i64, usize)]) -> Labels {
    chain.iter().map(|&(i, j)| (i as usize, j)).collect()
}

/// [`resolve_steps`] on a labelling.
pub(super) fn resolve_labels(dots: &[Dot], path: &SPath, mut labels: Labels) -> Labels {
    labels.sort_unstable();
    let chain = labels.iter().map(|&(i, j)| (i as i64, j)).collect();
    chain_labels(&resolve_steps(dots, path, chain))
}
