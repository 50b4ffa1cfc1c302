//! The step a growing chain predicts at its end, per [`ChainGrowth`].

use std::ops::RangeInclusive;

use nalgebra::Vector2;

use super::steps::{mean_step, step_band, step_length, turn_ahead};
use super::ChainGrowth;
use crate::dots::Dot;

/// The predicted step at a chain's end.
pub(super) struct Ahead {
    growth: ChainGrowth,
    /// The step per path index (direction and length).
    pub step: Vector2<f64>,
    /// Turn per step ahead, radians (constant curvature).
    pub turn: f64,
    /// [`ChainGrowth::Strays`]: the chain spans enough indices for a mean step.
    established: bool,
}

impl Ahead {
    /// The prediction at the end of `chain` (at least two entries); `None` where it has none.
    pub fn of(growth: ChainGrowth, dots: &[Dot], chain: &[(i64, usize)]) -> Option<Self> {
        match growth {
            ChainGrowth::Strict => Self::strict(dots, chain),
            ChainGrowth::Strays => {
                let (i_mid, mean) = mean_step(dots, chain, chain.len().checked_sub(1)?)?;
                let (step_len, established) = step_length(dots, chain);
                let turn = turn_ahead(dots, chain, i_mid, mean);
                Some(Self { growth, step: mean.normalize() * step_len, turn, established })
            }
        }
    }

    /// The last step, turned by the angle between the last two (clamped to 0.6 rad).
    fn strict(dots: &[Dot], chain: &[(i64, usize)]) -> Option<Self> {
        let n = chain.len();
        let ((i_prev, j_prev), (i_cur, j_cur)) = (*chain.get(n.checked_sub(2)?)?, chain[n - 1]);
        let prev = dots[j_prev].centre_px;
        let step = (dots[j_cur].centre_px - prev) / (i_cur - i_prev) as f64;
        let turn = n.checked_sub(3).map_or(0.0, |k| {
            let (i_before, j_before) = chain[k];
            let before = (prev - dots[j_before].centre_px) / (i_prev - i_before) as f64;
            (before.x * step.y - before.y * step.x).atan2(before.dot(&step)).clamp(-0.6, 0.6)
        });
        Some(Self { growth: ChainGrowth::Strict, step, turn, established: true })
    }

    /// Distances from the chain's end, in steps, of the next dot taken ahead in the cone.
    pub fn next_band(&self) -> Option<RangeInclusive<f64>> {
        match self.growth {
            ChainGrowth::Strict => Some(0.5..=1.6),
            ChainGrowth::Strays => step_band(1, self.established),
        }
    }

    /// Distances from the chain's end, in steps, of a dot taken near the prediction `skip`
    /// indices on. Strict: at least `skip - 0.5` (where dots stray from the curve, the next dot
    /// itself can fall within the widened radius of a two-step prediction, and the chain would
    /// miscount from there on).
    pub fn bridge_band(&self, skip: usize) -> Option<RangeInclusive<f64>> {
        match self.growth {
            ChainGrowth::Strict => Some(skip as f64 - 0.5..=f64::INFINITY),
            ChainGrowth::Strays => step_band(skip, self.established),
        }
    }
}
