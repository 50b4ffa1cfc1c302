//! Where OpenCV's radial map `r -> r g(r)` stops increasing: the first radial fold, beyond which
//! the model is not invertible (see [`Distortion::max_monotonic_radius`]).

use nalgebra::Vector2;

use super::{Distortion, MONOTONIC_SEARCH_RADIUS};

impl Distortion {
    /// Slope of the radial map `r -> r g(r)`: `d(r g)/dr = g + 2 s dg/ds`, `s = r^2` (for the
    /// polynomial model `1 + 3 k1 s + 5 k2 s^2 + 7 k3 s^3`). Negative where the rational
    /// denominator is not positive (a pole: nothing beyond it is invertible).
    pub(super) fn radial_slope(&self, s: f64) -> f64 {
        let t = self.terms(&Vector2::new(s.max(0.0).sqrt(), 0.0));
        if !(t.den > 0.0) {
            return -1.0;
        }
        t.g + 2.0 * s * t.dg
    }

    /// Smallest undistorted radius `r > 0` where the radial map `r -> r g(r)`
    /// stops increasing (`d(r g)/dr = 0`), or `None` if it is increasing for
    /// all `r <= MONOTONIC_SEARCH_RADIUS` (10).
    ///
    /// `d(r g)/dr` is a cubic in `s = r^2` with value 1 at `s = 0`. It is
    /// monotonic between its critical points (roots of a quadratic, solved in
    /// closed form), so checking the sign at those points and bisecting the
    /// first bracket finds the first root exactly (to ~1e-15 in `s`).
    /// Non-finite coefficients give `Some(0.0)` (nothing is invertible).
    pub fn max_monotonic_radius(&self) -> Option<f64> {
        // Remembered per thread for the last coefficients seen: every `undistort` needs it, and
        // the corner rays of one 1280 x 1024 frame undistort 21 000 times (22 ms of bisections).
        thread_local! {
            static LAST: std::cell::Cell<Option<([u64; 14], Option<f64>)>> = const { std::cell::Cell::new(None) };
        }
        let key = self.coefficients().map(f64::to_bits);
        LAST.with(|last| match last.get() {
            Some((k, fold)) if k == key => fold,
            _ => {
                let fold = self.find_max_monotonic_radius();
                last.set(Some((key, fold)));
                fold
            }
        })
    }

    /// [`Distortion::max_monotonic_radius`], computed.
    fn find_max_monotonic_radius(&self) -> Option<f64> {
        if !self.coefficients().iter().all(|c| c.is_finite()) {
            return Some(0.0);
        }
        let s_max = MONOTONIC_SEARCH_RADIUS * MONOTONIC_SEARCH_RADIUS;
        if self.k4 != 0.0 || self.k5 != 0.0 || self.k6 != 0.0 {
            // The rational slope has no closed-form critical points: bracket its first sign
            // change on a grid dense near the centre (512 knots), then bisect.
            let knots: Vec<f64> = (1..=512).map(|i| s_max * (f64::from(i) / 512.0).powi(2)).collect();
            return self.first_fold(&knots);
        }
        // p'(s) = a + 2 b s + 3 c s^2 with p(s) = 1 + a s + b s^2 + c s^3.
        let (a, b, c) = (3.0 * self.k1, 5.0 * self.k2, 7.0 * self.k3);
        let mut knots: Vec<f64> = Vec::with_capacity(4);
        if c != 0.0 {
            let disc = 4.0 * b * b - 12.0 * a * c;
            if disc >= 0.0 {
                let sq = disc.sqrt();
                knots.push((-2.0 * b + sq) / (6.0 * c));
                knots.push((-2.0 * b - sq) / (6.0 * c));
            }
        } else if b != 0.0 {
            knots.push(-a / (2.0 * b));
        }
        knots.retain(|&s| s > 0.0 && s < s_max);
        knots.sort_by(f64::total_cmp);
        knots.push(s_max);
        self.first_fold(&knots)
    }

    /// The first root of the radial slope on `(0, knots.last]`, the slope being monotonic (or
    /// sampled densely enough) between consecutive knots.
    pub(super) fn first_fold(&self, knots: &[f64]) -> Option<f64> {
        let mut lo = 0.0;
        for &hi in knots {
            if self.radial_slope(hi) <= 0.0 {
                // p(lo) > 0 >= p(hi), p monotonic on [lo, hi]: bisect.
                let (mut l, mut h) = (lo, hi);
                for _ in 0..200 {
                    let m = 0.5 * (l + h);
                    if m <= l || m >= h {
                        break;
                    }
                    if self.radial_slope(m) > 0.0 {
                        l = m;
                    } else {
                        h = m;
                    }
                }
                return Some(h.sqrt());
            }
            lo = hi;
        }
        None
    }
}
