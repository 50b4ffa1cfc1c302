//! Labels known from elsewhere (an anchor: the start chain's first steps) against a labelling:
//! where they agree, their union, and the step length a chain's fit is judged by. Shared by the
//! chain labelling (`label`), the stray-dot labelling (`strays`) and the step resolution
//! (`resolve`).

use super::Labels;
use crate::dots::Dot;
use crate::filters::median_by;

/// Does `labels` agree with `anchor` (labels known otherwise) wherever they share a path index
/// or a dot?
pub(super) fn compatible(labels: &[(usize, usize)], anchor: &[(usize, usize)]) -> bool {
    labels.iter().all(|&(i, j)| anchor.iter().all(|&(ia, ja)| (i == ia) == (j == ja)))
}

/// Reprojection RMS, in image steps, up to which a chain holding most of the dots may fit: dots
/// that stray by up to a fifth of their spacing fit at about 0.14 steps RMS (uniform in a disc
/// of 0.19 steps), and a long chain at close range has steps of 30 px.
pub(super) const STRAY_RMS_STEPS: f64 = 0.25;

/// The median image distance per path index between consecutive chain entries, pixels.
pub(super) fn median_step_px(chain: &[(i64, usize)], dots: &[Dot]) -> f64 {
    let mut steps: Vec<f64> =
        chain.windows(2).map(|w| (dots[w[1].1].centre_px - dots[w[0].1].centre_px).norm() / (w[1].0 - w[0].0).unsigned_abs().max(1) as f64).collect();
    median_by(&mut steps, f64::total_cmp).unwrap_or(0.0)
}

/// `labels` joined by the `anchor` labels compatible with them ([`compatible`]).
pub(super) fn with_anchor(mut labels: Labels, anchor: &[(usize, usize)]) -> Labels {
    let extra: Labels = anchor.iter().copied().filter(|a| compatible(&[*a], &labels)).collect();
    labels.extend(extra);
    labels.sort_unstable();
    labels.dedup();
    labels
}

/// The entries of `anchor` (a start chain's labels) in path order up to the first that
/// contradicts `labels`: beyond a step the start chain miscounted, every entry is one index off,
/// also where `labels` do not reach to contradict it.
pub(super) fn agreeing_prefix(mut anchor: Labels, labels: &[(usize, usize)]) -> Labels {
    anchor.sort_unstable();
    let n = anchor.iter().take_while(|a| compatible(&[**a], labels)).count();
    anchor.truncate(n);
    anchor
}
