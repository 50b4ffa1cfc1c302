//! Golden-section search for the minimum of a unimodal function of one variable on an interval.
//! Hand-written: a bounded scalar minimisation of a few dozen evaluations does not warrant an
//! optimisation crate.
//!
//! Reference: J. Kiefer, "Sequential minimax search for a maximum", Proc. AMS 4 (1953); Press et
//! al., *Numerical Recipes*, 3rd ed., 10.2.

/// The minimiser of a unimodal `f` on `[a, b]` after `steps` golden-section steps (each shrinks
/// the bracket by 0.618): the midpoint of the last bracket.
pub fn golden_section_min(f: impl Fn(f64) -> f64, mut a: f64, mut b: f64, steps: usize) -> f64 {
    let g = (5f64.sqrt() - 1.0) / 2.0;
    let (mut c, mut d) = (b - g * (b - a), a + g * (b - a));
    let (mut fc, mut fd) = (f(c), f(d));
    for _ in 0..steps {
        if fc < fd {
            (b, d, fd) = (d, c, fc);
            c = b - g * (b - a);
            fc = f(c);
        } else {
            (a, c, fc) = (c, d, fd);
            d = a + g * (b - a);
            fd = f(d);
        }
    }
    (a + b) / 2.0
}

/// The minimiser of `cost` over the grid `candidates` (spacing `step`) refined by
/// [`golden_section_min`] (`steps` steps) in the best candidate's two neighbouring cells, and its
/// cost: the refinement unless the grid's best is lower (a cost that is not unimodal there can
/// make it so; on a tie, the refinement). `None` without candidates.
pub fn grid_then_golden_min(cost: impl Fn(f64) -> f64, candidates: impl IntoIterator<Item = f64>, step: f64, steps: usize) -> Option<(f64, f64)> {
    let (best, _) = candidates.into_iter().map(|x| (x, cost(x))).min_by(|a, b| a.1.total_cmp(&b.1))?;
    let refined = golden_section_min(&cost, best - step, best + step, steps);
    [(refined, cost(refined)), (best, cost(best))].into_iter().min_by(|a, b| a.1.total_cmp(&b.1))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn finds_pi_as_the_minimum_of_the_cosine() {
        // cos has its minimum on [2, 4] at pi; 40 steps shrink the bracket 2 -> 2 * 0.618^40 ~ 9e-9
        let x = golden_section_min(f64::cos, 2.0, 4.0, 40);
        assert!((x - std::f64::consts::PI).abs() < 1e-8, "{x}");
    }

    #[test]
    fn a_grid_then_golden_finds_the_minimum_between_grid_points() {
        // (x - 0.37)^2 + 2 on a grid of step 0.25: the best grid point is 0.25 or 0.5, the
        // refinement lands on 0.37
        let (x, f) = grid_then_golden_min(|x| (x - 0.37).powi(2) + 2.0, (0..=8).map(|k| f64::from(k) * 0.25), 0.25, 40).expect("candidates");
        assert!((x - 0.37).abs() < 1e-7 && (f - 2.0).abs() < 1e-12, "{x} {f}");
        assert_eq!(grid_then_golden_min(f64::cos, std::iter::empty(), 0.1, 10), None);
    }
}
