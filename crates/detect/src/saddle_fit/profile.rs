//! The edge profile of the saddle model: erf of the signed distance, with its derivatives, and a
//! branch-free erf/exp pair that vectorises.

/// Edge profile value and derivatives (by signed distance `d` and by `a` = sqrt(2) sigma).
pub(super) struct Profile {
    pub(super) p: f64,
    pub(super) dp_dd: f64,
    pub(super) dp_da: f64,
}

/// erf(x / a) and exp(-x^2 / a^2) sharing one exponential; branch-free so that calls on
/// independent arguments vectorise.
#[inline(always)]
pub(super) fn erf_exp(x: f64, inv_a: f64) -> (f64, f64) {
    let z = x * inv_a;
    let e = exp_neg(z * z);
    let t = 1.0 / (1.0 + 0.327_591_1 * z.abs());
    // Abramowitz & Stegun 7.1.26 (|error| < 1.5e-7), the polynomial in Estrin form
    let t2 = t * t;
    let poly = t * ((0.254_829_592 + t * -0.284_496_736) + t2 * ((1.421_413_741 + t * -1.453_152_027) + t2 * 1.061_405_429));
    ((1.0 - poly * e).copysign(z), e)
}

/// [`erf_exp`] on `N` independent arguments (SIMD lanes).
#[inline(always)]
pub(super) fn erf_exp_lanes<const N: usize>(x: [f64; N], inv_a: f64) -> ([f64; N], [f64; N]) {
    let (mut f, mut e) = ([0.0; N], [0.0; N]);
    for k in 0..N {
        (f[k], e[k]) = erf_exp(x[k], inv_a);
    }
    (f, e)
}

/// exp(-y) for y >= 0 by range reduction to 2^n e^f, |f| <= ln 2 / 2, and the degree-8 Taylor
/// polynomial of e^f evaluated in Estrin form (relative error below 1e-9, far below the 1.5e-7
/// of the erf approximation it feeds); about 1e-304 (i.e. 0) beyond y = 700. Branch-free: the
/// nearest integer n comes from the 1.5 * 2^52 rounding constant, whose low mantissa bits then
/// hold n and give 2^n directly.
///
/// Reference: J.-M. Muller, "Elementary Functions: Algorithms and Implementation", 3rd ed., 2016
/// (range reduction, Estrin's scheme).
#[inline(always)]
pub(super) fn exp_neg(y: f64) -> f64 {
    const ROUND: f64 = 6_755_399_441_055_744.0; // 1.5 * 2^52
    let t = -y.min(700.0) * std::f64::consts::LOG2_E;
    let kf = t + ROUND;
    let n = kf - ROUND; // t rounded to the nearest integer, in [-1010, 0]
    let f = (t - n) * std::f64::consts::LN_2; // in [-ln 2 / 2, ln 2 / 2]
    let f2 = f * f;
    let f4 = f2 * f2;
    // Estrin: pairs (c0 + c1 f), (c2 + c3 f), ... combined by f^2 and f^4 (short dependency chains)
    let p01 = 1.0 + f;
    let p23 = 0.5 + f * (1.0 / 6.0);
    let p45 = 1.0 / 24.0 + f * (1.0 / 120.0);
    let p67 = 1.0 / 720.0 + f * (1.0 / 5040.0);
    let p8 = 1.0 / 40320.0;
    let p = (p01 + f2 * p23) + f4 * ((p45 + f2 * p67) + f4 * p8);
    // low mantissa bits of kf are 2^51 + n; adding the bias and shifting keeps n + 1023 mod 2^12
    let bits = kf.to_bits().wrapping_add(1023) << 52;
    p * f64::from_bits(bits)
}

pub(super) const INV_SQRT_PI: f64 = 0.564_189_583_547_756_3;

/// Step of +-1 seen through a pixel whose footprint across the edge is the trapezoid
/// box(wa) * box(wb) (the unit square projected on the edge normal) and a Gaussian of
/// sigma = a / sqrt(2): closed form by the first and second antiderivatives of erf.
#[inline(always)]
pub(super) fn profile(d: f64, wa: f64, wb: f64, a: f64) -> Profile {
    if d.abs() > 0.5 * (wa + wb) + 3.0 * a {
        return Profile { p: d.signum(), dp_dd: 0.0, dp_da: 0.0 };
    }
    let inv_a = 1.0 / a;
    if wb < 1e-3 {
        let h = 0.5 * wa;
        let ([f1, f0], [e1, e0]) = erf_exp_lanes([d + h, d - h], inv_a);
        let big1 = (d + h) * f1 + a * INV_SQRT_PI * e1;
        let big0 = (d - h) * f0 + a * INV_SQRT_PI * e0;
        return Profile { p: (big1 - big0) / wa, dp_dd: (f1 - f0) / wa, dp_da: INV_SQRT_PI * (e1 - e0) / wa };
    }
    let (hp, hm) = (0.5 * (wa + wb), 0.5 * (wa - wb));
    let xs = [d + hp, d + hm, d - hm, d - hp];
    let sg = [1.0, -1.0, -1.0, 1.0];
    let (f, e) = erf_exp_lanes(xs, inv_a);
    let (mut p, mut dd, mut da) = (0.0, 0.0, 0.0);
    for k in 0..4 {
        let x = xs[k];
        let e1 = x * f[k] + a * INV_SQRT_PI * e[k];
        let e2 = (0.5 * x * x + 0.25 * a * a) * f[k] + 0.5 * a * x * INV_SQRT_PI * e[k];
        p += sg[k] * e2;
        dd += sg[k] * e1;
        da += sg[k] * 0.5 * a * f[k];
    }
    let k = 1.0 / (wa * wb);
    Profile { p: p * k, dp_dd: dd * k, dp_da: da * k }
}

/// Cheap approximation of [`profile`] for both edge lines at once: one erf per line whose spread
/// `ae` stands for footprint and blur together (used for the first iterations only; the final
/// ones use the exact footprint). Both erfs are evaluated (SIMD lanes), then lines farther than
/// 3 `ae` are replaced by the flat step.
#[inline(always)]
pub(super) fn profile_fast_pair(d: [f64; 2], ae: f64) -> [Profile; 2] {
    let inv = 1.0 / ae;
    let (f, e) = erf_exp_lanes(d, inv);
    [0, 1].map(|k| {
        if d[k].abs() > 3.0 * ae {
            Profile { p: d[k].signum(), dp_dd: 0.0, dp_da: 0.0 }
        } else {
            let dd = std::f64::consts::FRAC_2_SQRT_PI * inv * e[k];
            // derivative by the spread itself: dP/dae = -d/ae * dP/dd
            Profile { p: f[k], dp_dd: dd, dp_da: -d[k] * inv * dd }
        }
    })
}
