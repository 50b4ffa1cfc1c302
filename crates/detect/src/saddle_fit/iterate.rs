//! The damped Gauss-Newton (Levenberg-Marquardt) iterations of the saddle fit: fast profile
//! first, then a few exact-profile steps.

use nalgebra::{SMatrix, SVector};

use super::{Normal, SaddleFitParams, NP};

/// Where the damped iterations end.
pub(super) struct Outcome {
    pub(super) x: SVector<f64, NP>,
    pub(super) cost: f64,
    pub(super) cost_pixels: usize,
    pub(super) iterations: usize,
    /// J^T J at the last linearisation point (for the covariance of the estimate).
    pub(super) jtj: Option<SMatrix<f64, NP, NP>>,
}

/// The normal equations at a parameter vector: J^T J, J^T r, cost.
pub(super) type Accumulated = (SMatrix<f64, NP, NP>, SVector<f64, NP>, f64);

/// Levenberg-Marquardt from `x` (normal equations `first` there): fast-profile iterations until
/// the corner moves less than `fast_epsilon_px`, then at most `exact_iterations` on the exact
/// profile. `sizes`: the window's and the fast window's side, pixels.
pub(super) fn iterate(
    mut x: SVector<f64, NP>,
    first: Accumulated,
    accumulate: &dyn Fn(&SVector<f64, NP>, bool) -> Accumulated,
    params: &SaddleFitParams,
    (n, fast_n): (usize, usize),
) -> Outcome {
    let mut lambda: f64 = 1e-3;
    let mut pending = Some(first);
    // Fast-profile iterations until converged, then exact-profile iterations (at most 3).
    let mut exact = false;
    let mut exact_iters = 0;
    let mut converged = false;
    let mut saved: Option<Normal> = None;
    let mut iterations = 0;
    let mut cost = f64::INFINITY;
    let mut cost_pixels = n * n;
    let max_total = params.max_iterations + 3;
    while iterations < max_total {
        iterations += 1;
        let (jtj, jtr, c) = match pending.take() {
            Some(normal) => normal,
            None => accumulate(&x, exact),
        };
        let base = match &saved {
            Some((xs, js, rs, cs)) if !(c <= *cs) => {
                // last step made it worse: back to the saved point, more damping
                lambda *= 10.0;
                if lambda > 1e6 {
                    x = *xs;
                    break;
                }
                (*xs, *js, *rs, *cs)
            }
            _ => {
                lambda = (lambda * 0.3).max(1e-7);
                (x, jtj, jtr, c)
            }
        };
        saved = Some(base);
        cost = base.3;
        cost_pixels = if exact { n * n } else { fast_n * fast_n };
        let mut m = base.1;
        for a in 0..NP {
            m[(a, a)] *= 1.0 + lambda;
        }
        let Some(chol) = m.cholesky() else {
            lambda *= 10.0;
            continue;
        };
        let delta = chol.solve(&base.2);
        x = base.0 + delta;
        x[6] = x[6].clamp(if exact { -3.0 } else { -1.2 }, 1.6);
        let step_q = (delta[0] * delta[0] + delta[1] * delta[1]).sqrt();
        if exact {
            exact_iters += 1;
        }
        let fast_done = !exact && (step_q < params.fast_epsilon_px.max(params.epsilon_px) || iterations >= params.max_iterations);
        if fast_done || exact {
            if exact && (step_q < params.epsilon_px || exact_iters >= params.exact_iterations) {
                // the last exact step is a Gauss-Newton correction from a verified point; accept
                // it unverified when small (typical: the fast/exact optima differ by < 0.1 px)
                converged = step_q < 0.25;
                break;
            }
            if !exact {
                exact = true;
                // total spread -> blur beyond the pixel footprint (variance 1/12 of a unit box)
                let sf2 = (2.0 * x[6]).exp();
                x[6] = 0.5 * (sf2 - 1.0 / 12.0).max(0.15 * 0.15).ln();
                saved = None;
            }
        }
    }
    let jtj = saved.map(|s| s.1);
    if let (false, Some((xs, _, _, _))) = (converged, saved) {
        x = xs;
    }
    Outcome { x, cost, cost_pixels, iterations, jtj }
}
