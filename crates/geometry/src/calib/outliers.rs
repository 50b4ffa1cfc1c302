//! Outlier rejection: points whose residual is far beyond the noise the fit implies are dropped
//! and the fit run again, until no point is left beyond the threshold.
//!
//! The noise is estimated robustly, from the median absolute residual component of every point
//! (`sigma = 1.4826 median |r|`, the normal distribution's consistent MAD scale, so that a few
//! gross errors do not inflate the yardstick they are measured with); a point is an outlier where
//! `|r| > k sigma` (`k` = [`super::CalibParams::outlier_threshold`], 5 by default: Gaussian noise
//! reaches it with probability 4e-6 per point). Each round flags afresh under the current fit (a
//! point flagged while gross errors still bent the fit comes back once they are gone) and refits
//! from the previous state, until the set of outliers no longer changes; when anything was
//! dropped, the global search of [`super::global`] runs once more on the points kept (gross
//! errors can pull the first fit into another basin) and the lower optimum is kept. A view
//! always keeps its [`MIN_KEPT`] best points (its pose stays determined). mrcal never re-admits
//! a point; this does, so the result does not depend on the order the errors were found in.
//!
//! Reference: mrcal's outlier rejection (<https://mrcal.secretsauce.net/formulation.html>,
//! "Outlier rejection": drop, re-solve, repeat); P. J. Rousseeuw, C. Croux, "Alternatives to the
//! median absolute deviation", JASA 88(424), 1993 (the MAD scale and its 1.4826 factor).

use nalgebra::Vector2;

use super::refine::{camera_of, refine, Refined, State, View};
use super::{residuals, CalibError, CalibParams};
use synthcam_core::camera::ImageSize;

/// A view keeps at least this many points (its best ones).
pub const MIN_KEPT: usize = 4;

/// Rounds of drop-and-refit at most.
const MAX_ROUNDS: usize = 10;

/// Floor of the noise estimate, px: below it the residuals are the detector's bias, not noise
/// (on exact renders the corner detectors' errors against the truth are 0.004-0.02 px RMS with
/// tails to 0.04, deterministic and correlated across neighbours), and a threshold scaled from
/// them would flag good corners; with the default `k` no point within 0.05 px of the fit is ever
/// an outlier. Exact (noise-free) data stay clear too.
pub const SIGMA_FLOOR_PX: f64 = 0.01;

/// What the outlier rejection did.
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct Rejection {
    /// The threshold in robust standard deviations; `None`: rejection off.
    pub threshold_sigmas: Option<f64>,
    /// The robust standard deviation of a residual component at the end, px.
    pub sigma_px: f64,
    /// The threshold in pixels at the end (`threshold_sigmas x sigma_px`).
    pub threshold_px: f64,
    /// Rounds of drop-and-refit run.
    pub rounds: usize,
    /// Points dropped over all views.
    pub dropped: usize,
    /// RMS reprojection error of the fit with every point, before anything was dropped, px.
    pub rms_before_px: f64,
}

/// `view` without the points at the indices `drop`.
pub fn without(view: &View, drop: &[usize]) -> View {
    view.iter().enumerate().filter(|(j, _)| !drop.contains(j)).map(|(_, p)| *p).collect()
}

/// Drop outliers from `first` (the fit of every point of `views`) and refit: the final fit, the
/// indices dropped per view, and the report.
///
/// # Errors
/// [`CalibError::Degenerate`] where a refit's normal equations are singular.
pub(super) fn reject(
    first: Refined,
    views: &[View],
    size: ImageSize,
    params: &CalibParams,
    free: &[usize],
) -> Result<(Refined, Vec<Vec<usize>>, Rejection), CalibError> {
    let n_points: usize = views.iter().map(Vec::len).sum();
    let mut report =
        Rejection { threshold_sigmas: params.outlier_threshold, rms_before_px: (first.cost / n_points.max(1) as f64).sqrt(), ..Default::default() };
    let mut dropped = vec![Vec::new(); views.len()];
    let Some(k) = params.outlier_threshold else { return Ok((first, dropped, report)) };
    let mut fit = first;
    for pass in 0..2 {
        fit = drop_and_refit(fit, views, size, params, free, (k, &mut dropped, &mut report))?;
        if dropped.iter().all(Vec::is_empty) || pass == 1 {
            break;
        }
        // Gross errors can have pulled the first fit into another basin, and the points flagged
        // there are not all bad: the global search on the points kept, then (if it ends lower)
        // the flags afresh under its optimum.
        let (again, _) = super::global::fit(&kept_views(views, &dropped), size, params, free)?;
        if !(again.cost < fit.cost * (1.0 - 1e-9)) {
            break;
        }
        fit = again;
    }
    report.dropped = dropped.iter().map(Vec::len).sum();
    Ok((fit, dropped, report))
}

/// Flag afresh under `fit` and refit on the points kept until the flags stop changing (at most
/// [`MAX_ROUNDS`] rounds in all); `dropped` and `report` follow.
fn drop_and_refit(
    mut fit: Refined,
    views: &[View],
    size: ImageSize,
    params: &CalibParams,
    free: &[usize],
    (k, dropped, report): (f64, &mut Vec<Vec<usize>>, &mut Rejection),
) -> Result<Refined, CalibError> {
    while report.rounds < MAX_ROUNDS {
        let res = all_residuals(&fit.state, views, size);
        report.sigma_px = robust_sigma(&res).max(SIGMA_FLOOR_PX);
        report.threshold_px = k * report.sigma_px;
        let flagged = flag(&res, report.threshold_px);
        if flagged == *dropped {
            break;
        }
        *dropped = flagged;
        report.rounds += 1;
        fit = refine(size, fit.state, &kept_views(views, dropped), free, params.max_iterations).ok_or_else(singular)?;
    }
    Ok(fit)
}

fn singular() -> CalibError {
    CalibError::Degenerate { reason: "the normal equations are singular after dropping outliers".into() }
}

fn kept_views(views: &[View], dropped: &[Vec<usize>]) -> Vec<View> {
    views.iter().zip(dropped).map(|(v, d)| without(v, d)).collect()
}

/// Every point's residual under the state (all points of every view, dropped ones too).
fn all_residuals(state: &State, views: &[View], size: ImageSize) -> Vec<Vec<Vector2<f64>>> {
    let camera = camera_of(size, state.kind, &state.a);
    views.iter().zip(&state.poses).map(|(v, pose)| residuals(&camera, &state.warp, v, pose)).collect()
}

/// `1.4826 x` the median absolute residual component of every point.
fn robust_sigma(res: &[Vec<Vector2<f64>>]) -> f64 {
    let mut comps: Vec<f64> = res.iter().flatten().flat_map(|e| [e.x.abs(), e.y.abs()]).collect();
    if comps.is_empty() {
        return 0.0;
    }
    let mid = comps.len() / 2;
    let (_, m, _) = comps.select_nth_unstable_by(mid, f64::total_cmp);
    1.4826 * *m
}

/// Per view, the indices (ascending) of the points beyond `threshold_px`, worst first while the
/// view keeps [`MIN_KEPT`] points.
fn flag(res: &[Vec<Vector2<f64>>], threshold_px: f64) -> Vec<Vec<usize>> {
    res.iter()
        .map(|r| {
            let mut beyond: Vec<(usize, f64)> = r.iter().map(|e| e.norm()).enumerate().filter(|(_, n)| !(*n <= threshold_px)).collect();
            beyond.sort_by(|a, b| b.1.total_cmp(&a.1));
            let mut d: Vec<usize> = beyond.into_iter().take(r.len().saturating_sub(MIN_KEPT)).map(|(j, _)| j).collect();
            d.sort_unstable();
            d
        })
        .collect()
}
