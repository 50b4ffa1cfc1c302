//! Unbiased sub-pixel chessboard-corner position by fitting a model of a blurred, pixel-sampled
//! saddle: I(p) = m + b.(p - p0) + a * S(d1) * S(d2), where d_k is the signed distance of p to
//! edge line k through the corner (with an optional quadratic bend for lens distortion) and
//! S(d) = erf(d / (sqrt(2) sigma)) the blurred step. For axis-aligned edges the area-sampled
//! checker corner is exactly separable, so the product model has no structural bias; the fit is
//! a damped Gauss-Newton (Levenberg-Marquardt) on a small square window.
//!
//! Reference: D. Lucchese, S. Mitra, "Using saddle points for subpixel feature detection in camera
//! calibration targets", APCCAS 2002; A. Geiger et al., "Automatic camera and range sensor
//! calibration using a single shot", ICRA 2012 (edge-model corner refinement).

use nalgebra::{Point2, SMatrix, SVector, Vector2};

use super::{DetectError, GreyWindow};
use iterate::{iterate, Outcome};
use profile::{profile, profile_fast_pair};

mod iterate;
mod profile;

/// Number of model parameters: qx, qy, theta1, theta2, m, a, sigma, kappa1, kappa2, bx, by.
const NP: usize = 11;

/// Parameters of [`refine_saddle`].
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct SaddleFitParams {
    /// Half-size of the square fit window, pixels (keep it below ~0.45 of the square size).
    pub half_window: usize,
    /// Maximum Levenberg-Marquardt iterations.
    pub max_iterations: usize,
    /// Stop when the corner moves less than this in one iteration, pixels.
    pub epsilon_px: f64,
    /// Fit a quadratic bend of each edge line (lens distortion); costs ~30 % more time.
    pub fit_curvature: bool,
    /// Fit a linear illumination gradient in the window.
    pub fit_gradient: bool,
    /// The fast-profile stage stops when the corner moves less than this, pixels.
    pub fast_epsilon_px: f64,
    /// Half-size of the window of the fast-profile stage (at most `half_window`): it only has to
    /// bring the corner within `fast_epsilon_px`; the exact stage then fits the whole window.
    pub fast_half_window: usize,
    /// Iterations with the exact pixel-footprint profile after the fast-profile stage converged
    /// (1 is usually enough: the two optima differ by a few hundredths of a pixel).
    pub exact_iterations: usize,
    /// Reject the fit when the corner ends farther than this from the seed, pixels.
    pub max_shift_px: f64,
}

impl Default for SaddleFitParams {
    fn default() -> Self {
        Self {
            half_window: 4,
            max_iterations: 10,
            epsilon_px: 1e-3,
            fit_curvature: false,
            fit_gradient: false,
            fast_epsilon_px: 0.05,
            fast_half_window: 3,
            exact_iterations: 1,
            max_shift_px: 2.0,
        }
    }
}

/// Result of [`refine_saddle`].
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct SaddleFit {
    /// Corner position, pixels (OpenCV convention: centre of the top-left pixel is (0, 0)).
    pub point: Point2<f64>,
    /// Edge directions (radians) of the two lines through the corner.
    pub angles: [f64; 2],
    /// Half the intensity difference between the light and dark squares (signed).
    pub amplitude: f64,
    /// Fitted edge blur (sigma of the erf profile), pixels.
    pub sigma_px: f64,
    /// RMS residual of the fit, grey levels.
    pub rms_residual: f64,
    /// Standard deviation of the corner position, pixels: the square root of the larger
    /// eigenvalue of its 2 x 2 block of s^2 (J^T J)^-1, s^2 the residual variance (cost over
    /// pixels minus parameters). A model that does not hold in the window (clutter, a
    /// neighbouring corner, clipped and blurred junctions) leaves large residuals and so a large
    /// sigma; infinite when the fit is not determined.
    pub position_sigma_px: f64,
    /// Iterations used.
    pub iterations: usize,
}

/// Per-iteration constants of the model (edge directions, pixel footprints, blur).
struct Geo {
    s1: f64,
    c1: f64,
    s2: f64,
    c2: f64,
    wa1: f64,
    wb1: f64,
    wa2: f64,
    wb2: f64,
    a_: f64,
    /// erf scale of both lines for the fast profile (there sigma is the total edge spread,
    /// footprint included).
    ae: f64,
}

impl Geo {
    fn new(x: &SVector<f64, NP>) -> Self {
        let (s1, c1) = x[2].sin_cos();
        let (s2, c2) = x[3].sin_cos();
        let (ac1, as1) = (c1.abs(), s1.abs());
        let (ac2, as2) = (c2.abs(), s2.abs());
        Self {
            s1,
            c1,
            s2,
            c2,
            wa1: ac1.max(as1),
            wb1: ac1.min(as1),
            wa2: ac2.max(as2),
            wb2: ac2.min(as2),
            a_: std::f64::consts::SQRT_2 * x[6].exp(),
            ae: std::f64::consts::SQRT_2 * x[6].exp(),
        }
    }
}

/// Model value and Jacobian row at one pixel for parameter vector `x` (offsets `dx`, `dy` of the
/// pixel from the window centre).
#[inline(always)]
fn model(x: &SVector<f64, NP>, g: &Geo, dx: f64, dy: f64, jac: &mut SVector<f64, NP>, exact: bool) -> f64 {
    let (px, py) = (dx - x[0], dy - x[1]);
    let (s1, c1, s2, c2) = (g.s1, g.c1, g.s2, g.c2);
    let sigma = x[6].exp();
    let (k1, k2) = (x[7], x[8]);

    // normal n = (-sin, cos), along e = (cos, sin)
    let t1 = c1 * px + s1 * py;
    let t2 = c2 * px + s2 * py;
    let n1 = -s1 * px + c1 * py;
    let n2 = -s2 * px + c2 * py;
    let d1 = n1 + k1 * t1 * t1;
    let d2 = n2 + k2 * t2 * t2;
    let a_ = g.a_;
    let (p1, p2) = if exact {
        (profile(d1, g.wa1, g.wb1, a_), profile(d2, g.wa2, g.wb2, a_))
    } else {
        let [p1, p2] = profile_fast_pair([d1, d2], g.ae);
        (p1, p2)
    };
    let (e1, e2) = (p1.p, p2.p);
    let a = x[5];
    let ad1 = a * e2 * p1.dp_dd; // dI/dd1
    let ad2 = a * e1 * p2.dp_dd; // dI/dd2
                                 // dd/dq = -n - 2 k t e
    jac[0] = ad1 * (s1 - 2.0 * k1 * t1 * c1) + ad2 * (s2 - 2.0 * k2 * t2 * c2);
    jac[1] = ad1 * (-c1 - 2.0 * k1 * t1 * s1) + ad2 * (-c2 - 2.0 * k2 * t2 * s2);
    jac[2] = ad1 * (-t1 + 2.0 * k1 * t1 * n1);
    jac[3] = ad2 * (-t2 + 2.0 * k2 * t2 * n2);
    jac[4] = 1.0;
    jac[5] = e1 * e2;
    jac[6] = a * std::f64::consts::SQRT_2 * sigma * (e2 * p1.dp_da + e1 * p2.dp_da); // parameter is ln(sigma)
    jac[7] = ad1 * t1 * t1;
    jac[8] = ad2 * t2 * t2;
    jac[9] = dx;
    jac[10] = dy;
    x[4] + x[9] * dx + x[10] * dy + a * e1 * e2
}

/// A linearisation point: parameters, J^T J, J^T r, cost.
type Normal = (SVector<f64, NP>, SMatrix<f64, NP, NP>, SVector<f64, NP>, f64);

/// Normal equations J^T J, J^T r and the cost over the central `2 hu + 1` square of the window of
/// half-size `h` for the `N` active parameters `idx` (packed so the inner loops have
/// compile-time bounds).
fn accumulate_n<const N: usize>(
    x: &SVector<f64, NP>,
    exact: bool,
    jac: &mut SVector<f64, NP>,
    idx: &[usize],
    vals: &[f64],
    (h, hu): (i64, i64),
) -> (SMatrix<f64, NP, NP>, SVector<f64, NP>, f64) {
    let mut acc = [[0.0f64; N]; N];
    let mut jr = [0.0f64; N];
    let mut pk = [0.0f64; N];
    let mut c = 0.0;
    let geo = Geo::new(x);
    let n = 2 * h + 1;
    for j in -hu..=hu {
        for i in -hu..=hu {
            let r = vals[((j + h) * n + i + h) as usize] - model(x, &geo, i as f64, j as f64, jac, exact);
            c += r * r;
            for (t, &p) in pk.iter_mut().zip(idx.iter()) {
                *t = jac[p];
            }
            for a in 0..N {
                let ja = pk[a];
                jr[a] += ja * r;
                for b in a..N {
                    acc[a][b] += ja * pk[b];
                }
            }
        }
    }
    let mut jtj = SMatrix::<f64, NP, NP>::identity();
    let mut jtr = SVector::<f64, NP>::zeros();
    for a in 0..N.min(idx.len()) {
        jtr[idx[a]] = jr[a];
        for b in a..N.min(idx.len()) {
            jtj[(idx[a], idx[b])] = acc[a][b];
            jtj[(idx[b], idx[a])] = acc[a][b];
        }
    }
    (jtj, jtr, c)
}

/// Parameters whose Jacobian columns carry the amplitude a as a factor (edge geometry, blur,
/// bends).
const A_SCALED: [bool; NP] = [true, true, true, true, false, false, true, true, true, false, false];

/// Given the normal equations `(J^T J, J^T r, r^T r)` linearised at m = 0, a = 1 (so the columns
/// of m and a are 1 and the product profile f, and r = v - f), set `x[4]` = m and `x[5]` = a to
/// their linear least-squares values for this geometry and return the normal equations at the
/// updated `x`: with r' = r - m + (1 - a) f the sums are linear combinations of the given ones,
/// the `a`-scaled columns scale by a. `None` when m and a are not determined (flat geometry).
fn solve_linear_part(
    x: &mut SVector<f64, NP>,
    normal: (SMatrix<f64, NP, NP>, SVector<f64, NP>, f64),
    active: &[bool; NP],
) -> Option<(SMatrix<f64, NP, NP>, SVector<f64, NP>, f64)> {
    let (mut jtj, mut jtr, c) = normal;
    let (cnt, sf, sff) = (jtj[(4, 4)], jtj[(4, 5)], jtj[(5, 5)]);
    let (sv, sfv) = (jtr[4] + sf, jtr[5] + sff);
    let det = cnt * sff - sf * sf;
    if !(det.abs() > 1e-9) {
        return None;
    }
    let a = (cnt * sfv - sf * sv) / det;
    let m = (sv - a * sf) / cnt;
    let b = 1.0 - a;
    let cost = c + m * m * cnt + b * b * sff - 2.0 * m * jtr[4] + 2.0 * b * jtr[5] - 2.0 * m * b * sf;
    let scale = |p: usize| if A_SCALED[p] { a } else { 1.0 };
    let col_m = jtj.column(4).into_owned();
    let col_a = jtj.column(5).into_owned();
    for p in (0..NP).filter(|&p| active[p]) {
        jtr[p] = scale(p) * (jtr[p] - m * col_m[p] + b * col_a[p]);
        for q in (0..NP).filter(|&q| active[q]) {
            jtj[(p, q)] *= scale(p) * scale(q);
        }
    }
    x[4] = m;
    x[5] = a;
    Some((jtj, jtr, cost))
}

/// Refine a chessboard corner near `seed` by fitting the saddle model. `dir1`, `dir2` are rough
/// directions of the two edges through the corner (e.g. towards the grid neighbours).
///
/// # Errors
/// [`DetectError::RefineFailed`] when the window leaves the image, the seed is not finite, the
/// fit is singular, or the corner ends more than `max_shift_px` from the seed.
pub fn refine_saddle(
    img: &(impl GreyWindow + ?Sized),
    seed: Point2<f64>,
    dir1: Vector2<f64>,
    dir2: Vector2<f64>,
    params: &SaddleFitParams,
) -> Result<SaddleFit, DetectError> {
    let fail = |reason| DetectError::RefineFailed { u: seed.x, v: seed.y, reason };
    if !seed.x.is_finite() || !seed.y.is_finite() || !dir1.iter().chain(dir2.iter()).all(|v| v.is_finite()) {
        return Err(fail("non-finite seed or direction"));
    }
    let h = params.half_window.max(2) as i64;
    let cx = seed.x.round() as i64;
    let cy = seed.y.round() as i64;
    if cx - h < 0 || cy - h < 0 || cx + h >= img.width() as i64 || cy + h >= img.height() as i64 {
        return Err(fail("window leaves the image"));
    }
    let n = (2 * h + 1) as usize;
    let mut vals = Vec::with_capacity(n * n);
    for y in (cy - h)..=(cy + h) {
        img.push_row(y as usize, (cx - h) as usize, n, &mut vals);
    }
    let mut x = SVector::<f64, NP>::zeros();
    x[0] = seed.x - cx as f64;
    x[1] = seed.y - cy as f64;
    x[2] = dir1.y.atan2(dir1.x);
    x[3] = dir2.y.atan2(dir2.x);
    x[6] = 0.7_f64.ln();
    let active: [bool; NP] = [true, true, true, true, true, true, true, params.fit_curvature, params.fit_curvature, params.fit_gradient, params.fit_gradient];
    let idx_store: Vec<usize> = (0..NP).filter(|&p| active[p]).collect();
    let idx = &idx_store[..];
    let mut jac = SVector::<f64, NP>::zeros();
    let hf = (params.fast_half_window.max(2) as i64).min(h);
    let accumulate = |x: &SVector<f64, NP>, exact: bool, jac: &mut SVector<f64, NP>| {
        let hh = (h, if exact { h } else { hf });
        match idx.len() {
            7 => accumulate_n::<7>(x, exact, jac, idx, &vals, hh),
            9 => accumulate_n::<9>(x, exact, jac, idx, &vals, hh),
            _ => accumulate_n::<NP>(x, exact, jac, idx, &vals, hh),
        }
    };
    // First linearisation at m = 0, a = 1; m and a then follow by linear least squares given the
    // geometry, and the normal equations are re-expressed at them (one pass over the window).
    x[4] = 0.0;
    x[5] = 1.0;
    let first = accumulate(&x, false, &mut jac);
    let Some(first) = solve_linear_part(&mut x, first, &active) else {
        return Err(fail("degenerate initial geometry"));
    };
    let Outcome { x, cost, cost_pixels, iterations, jtj } =
        iterate(x, first, &|x: &SVector<f64, NP>, exact: bool| accumulate(x, exact, &mut SVector::zeros()), params, (n, (2 * hf + 1) as usize));
    if !x.iter().all(|v| v.is_finite()) {
        return Err(fail("fit diverged"));
    }
    let point = Point2::new(cx as f64 + x[0], cy as f64 + x[1]);
    if !point.x.is_finite() || !point.y.is_finite() || (point - seed).norm() > params.max_shift_px {
        return Err(fail("fit diverged"));
    }
    let position_sigma_px = jtj.map_or(f64::INFINITY, |m| position_sigma(&m, cost, cost_pixels, idx.len()));
    Ok(SaddleFit {
        point,
        angles: [x[2], x[3]],
        amplitude: x[5],
        sigma_px: x[6].exp(),
        rms_residual: (cost / cost_pixels as f64).sqrt(),
        position_sigma_px,
        iterations,
    })
}

/// Standard deviation of the corner position from the normal matrix `jtj` (inactive parameters
/// carry identity rows) and the cost over `pixels` samples with `active` free parameters.
fn position_sigma(jtj: &SMatrix<f64, NP, NP>, cost: f64, pixels: usize, active: usize) -> f64 {
    let dof = pixels.saturating_sub(active);
    let Some(inv) = jtj.try_inverse() else { return f64::INFINITY };
    if dof == 0 {
        return f64::INFINITY;
    }
    let s2 = cost / dof as f64;
    let (a, b, c) = (inv[(0, 0)] * s2, inv[(0, 1)] * s2, inv[(1, 1)] * s2);
    // larger eigenvalue of [[a, b], [b, c]]
    let l = 0.5 * (a + c) + (0.25 * (a - c) * (a - c) + b * b).sqrt();
    if l.is_finite() && l >= 0.0 {
        l.sqrt()
    } else {
        f64::INFINITY
    }
}

#[cfg(test)]
pub(crate) mod tests;
