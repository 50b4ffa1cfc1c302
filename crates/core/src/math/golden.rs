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

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn finds_pi_as_the_minimum_of_the_cosine() {
        // cos has its minimum on [2, 4] at pi; 40 steps shrink the bracket 2 -> 2 * 0.618^40 ~ 9e-9
        let x = golden_section_min(f64::cos, 2.0, 4.0, 40);
        assert!((x - std::f64::consts::PI).abs() < 1e-8, "{x}");
    }
}
