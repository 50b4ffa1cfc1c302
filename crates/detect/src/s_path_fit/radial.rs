//! A projective camera with one radial lens term, for the path where the camera is unknown.
//!
//! The default path fits a DLT (11 degrees of freedom, [`super::dlt`]) to the whole view, and a
//! DLT has no lens: through a lens with barrel distortion, the image of the long path bends away
//! from every projective camera by a pixel or more, and a labelling with a stretch one index off
//! beyond some dot can then fit about as well as the right one. So the final labelling is checked
//! against a camera that does model the lens: Fitzgibbon's one-parameter division model about the
//! image centre (undistorted = c + d / (1 + lambda |d|^2), d the offset from c), whose parameter is
//! found by a one-dimensional search (the DLT of each lambda is linear). On independent renders
//! through k1 = -0.1 (`benches/spath_lens_check.py`) right labellings fit at 0.01-0.11 px, their
//! one-index split rivals 10 to 100 times worse; every wrong default-path labelling found there
//! fits worse than its right rival.
//!
//! [`best_rival`]: a beam search over the labelling's shifts along the path (whole, and beyond
//! or before any of its indices: [`super::assign::shifted_rivals`]) for the one the radial camera
//! fits best; it replaces the labelling only where it fits clearly better
//! ([`super::SPathFitParams::ambiguity_ratio`]). Where the lens term is significant (an F test:
//! with dots straying by millimetres lambda fits the strays, not the lens) the dots, undistorted
//! by it, are then assigned afresh ([`super::assign`]) with the chosen labelling as the seed, so
//! that the gates follow the lens. [`lens_settled`]: where the assignment's contenders dispute
//! its dots, those this camera fits far worse than the best of them drop out.
//!
//! Reference: A. W. Fitzgibbon, "Simultaneous linear estimation of multiple view geometry and lens
//! distortion", CVPR 2001 (the division model); Hartley and Zisserman, *Multiple View Geometry*,
//! 2nd ed., 7.1 (the normalised DLT).

use nalgebra::{Point2, Point3};
use synthcam_core::math::golden::grid_then_golden_min;

use super::assign::{shifted_rivals, Assignment};
use super::dlt::Dlt;
use super::grow::trimmed_count;
use super::{correspondences, Labels};
pub(super) use crate::division::Division;
use crate::dots::Dot;
use synthcam_core::target::SPath;

/// Largest |lambda r^2| searched at the dot farthest from the centre (a strong wide-angle lens's
/// barrel distortion reaches about 0.3 there).
const KAPPA_REACH: f64 = 0.6;
/// Grid steps of the coarse search over lambda r^2, either way.
const KAPPA_STEPS: i32 = 6;
/// Golden-section steps refining the best grid cell (each shrinks it by 0.618).
const GOLDEN_STEPS: usize = 16;

impl Division {
    /// The DLT fitted to the undistorted points; `None` where they are degenerate.
    fn camera(&self, world: &[Point3<f64>], image: &[Point2<f64>]) -> Option<Dlt> {
        let ideal: Vec<Point2<f64>> = image.iter().map(|p| self.undistort(p)).collect();
        Dlt::fit(world, &ideal, None)
    }

    /// Reprojection errors of `camera`, image pixels: each undistorted residual scaled back by the
    /// model's local magnification (1 + lambda r^2, first order); 1e6 behind the camera.
    fn residuals(&self, camera: &Dlt, world: &[Point3<f64>], image: &[Point2<f64>]) -> Vec<f64> {
        let residual = |(x, p): (&Point3<f64>, &Point2<f64>)| {
            let scale = 1.0 + self.lambda * (p - self.centre).norm_squared();
            camera.project(x).map_or(1e6, |q| (q - self.undistort(p)).norm() * scale)
        };
        world.iter().zip(image).map(residual).collect()
    }

    /// Reprojection RMS, image pixels, of the DLT fitted to the undistorted points
    /// ([`Division::residuals`]); `None` where the DLT is degenerate.
    fn rms(&self, world: &[Point3<f64>], image: &[Point2<f64>]) -> Option<f64> {
        let camera = self.camera(world, image)?;
        let ss: f64 = self.residuals(&camera, world, image).iter().map(|r| r * r).sum();
        Some((ss / world.len().max(1) as f64).sqrt())
    }
}

/// The division model about `centre` whose DLT fits the correspondences best, and its RMS (image
/// pixels): a grid over lambda r_max^2 ([`KAPPA_REACH`], r_max the farthest point's distance from
/// the centre), then golden-section search in the best cell ([`grid_then_golden_min`]).
pub(super) fn fit(world: &[Point3<f64>], image: &[Point2<f64>], centre: Point2<f64>) -> Option<(f64, Division)> {
    let r2_max = image.iter().map(|p| (p - centre).norm_squared()).fold(0.0, f64::max);
    if !(r2_max > 0.0 && r2_max.is_finite()) {
        return None;
    }
    let at = |kappa: f64| Division { centre, lambda: kappa / r2_max };
    let cost = |kappa: f64| at(kappa).rms(world, image).unwrap_or(f64::INFINITY);
    let step = KAPPA_REACH / KAPPA_STEPS as f64;
    let (kappa, rms) = grid_then_golden_min(cost, (-KAPPA_STEPS..=KAPPA_STEPS).map(|k| k as f64 * step), step, GOLDEN_STEPS)?;
    rms.is_finite().then_some((rms, at(kappa)))
}

/// [`fit`] to labelled dots.
fn fit_labels(dots: &[Dot], path: &SPath, labels: &[(usize, usize)], centre: Point2<f64>) -> Option<(f64, Division)> {
    let (world, image) = correspondences(labels, dots, path);
    fit(&world, &image, centre)
}

/// Steps of the search of [`best_rival`].
const SEARCH_STEPS: usize = 4;
/// Labellings carried from step to step (a beam search).
const BEAM: usize = 4;
/// Rivals of each labelling refitted with their own lambda after screening at its lambda.
const SCREENED: usize = 3;

/// The labelling that the radial camera fits best, searched from `labels` over rivals: a beam
/// search ([`BEAM`] labellings, [`SEARCH_STEPS`] steps) whose every step takes each labelling's
/// shifts (whole, and beyond or before any of its indices, by one either way:
/// [`shifted_rivals`]), screened at its lambda, the [`SCREENED`] best refitted with their own. A
/// stretch placed wrongly can differ from the right placement by a shift and a miscounted skip
/// inside it (two steps, the first fitting worse: a beam, not a descent). The best found replaces
/// `labels` only where it fits clearly better (by `ratio`). Returned with the division model
/// fitted to the [`super::grow::TRIM_KEEP`] share of the dots the chosen labelling fits best, and that share,
/// where the lens term is significant ([`Checked`]); `None` where `labels` fit no camera.
pub(super) fn best_rival(dots: &[Dot], path: &SPath, labels: Labels, centre: Point2<f64>, ratio: f64) -> Option<Checked> {
    let (own, division) = fit_labels(dots, path, &labels, centre)?;
    let mut seen: std::collections::HashSet<Labels> = std::collections::HashSet::from([labels.clone()]);
    let mut beam = vec![(own, labels.clone(), division)];
    let (mut rms, mut now, mut now_division) = (own, labels.clone(), division);
    for _ in 0..SEARCH_STEPS {
        let mut next: Vec<(f64, Labels, Division)> = Vec::new();
        for (_, from, division) in &beam {
            let mut screened: Vec<(f64, Labels)> = shifted_rivals(from, path.len(), Some(1))
                .into_iter()
                .filter(|r| r.len() == from.len() && seen.insert(r.clone()))
                .filter_map(|r| {
                    let (world, image) = correspondences(&r, dots, path);
                    Some((division.rms(&world, &image)?, r))
                })
                .collect();
            screened.sort_by(|a, b| a.0.total_cmp(&b.0));
            next.extend(screened.into_iter().take(SCREENED).filter_map(|(_, r)| fit_labels(dots, path, &r, centre).map(|(e, d)| (e, r, d))));
        }
        next.sort_by(|a, b| a.0.total_cmp(&b.0));
        next.truncate(BEAM);
        match next.first() {
            Some(first) if first.0 < rms => (rms, now, now_division) = (first.0, first.1.clone(), first.2),
            Some(_) => {}
            None => break,
        }
        beam = next;
    }
    let (chosen, fitted) = if rms * ratio < own {
        log::debug!("s-path radial check: a rival of the labelling fits at {rms:.3} px against its {own:.3} px: taken");
        (now, now_division)
    } else {
        (labels, division)
    };
    let lens = Some(trimmed_division(dots, path, &chosen, centre, fitted)).filter(|(kept, division)| significant(dots, path, kept, division));
    Some(Checked { chosen, lens })
}

/// [`best_rival`]'s result.
#[derive(Debug, Clone)]
pub(super) struct Checked {
    /// The labelling kept: the one given, or its rival that the radial camera fits clearly better.
    pub(super) chosen: Labels,
    /// The share of its dots the radial camera fits best and the division model fitted to them,
    /// where the lens term is significant ([`significant`]).
    pub(super) lens: Option<(Labels, Division)>,
}

/// The F statistic above which the lens term counts as significant: the upper 0.001 quantile of
/// F(1, infinity) (chi-square with one degree of freedom, 10.83; with 50 dots' 88 degrees of
/// freedom the exact quantile is 11.6).
const F_SIGNIFICANT: f64 = 10.83;

/// Does the radial term explain the labelled dots significantly better than a DLT without it?
/// An F test for one added parameter (residual sums of squares of the two nested least-squares
/// fits, 2n - 12 degrees of freedom left): where dots stray from the nominal path by millimetres,
/// lambda fits the strays, not the lens, and the test fails.
fn significant(dots: &[Dot], path: &SPath, labels: &[(usize, usize)], division: &Division) -> bool {
    let (world, image) = correspondences(labels, dots, path);
    let flat = Division { lambda: 0.0, ..*division };
    let (Some(rms0), Some(rms1)) = (flat.rms(&world, &image), division.rms(&world, &image)) else { return false };
    // F = ((RSS0 - RSS1) / 1) / (RSS1 / dof), RSS = n rms^2.
    let dof = 2.0 * world.len() as f64 - 12.0;
    let f = (rms0 * rms0 - rms1 * rms1) * dof / (rms1 * rms1).max(1e-300);
    log::trace!("s-path radial: lambda {:.3e} px^-2, RMS {rms0:.3} -> {rms1:.3} px, F {f:.1}", division.lambda);
    dof > 0.0 && f > F_SIGNIFICANT
}

/// Concentration steps of [`trimmed_division`].
const C_STEPS: usize = 6;

/// The division model fitted to the [`super::grow::TRIM_KEEP`] share of the labelled dots it fits best, and
/// that share: a least-trimmed-squares fit by concentration steps (Rousseeuw and Van Driessen,
/// "Computing LTS regression for large data sets", 2006): fit, keep the share with the smallest
/// residuals, refit to it, until the share stops changing ([`C_STEPS`] at most). A stretch one
/// index off drags a fit to all dots its way; the steps shed it. `division`: [`fit`] to all of
/// `labels`, where the steps start.
fn trimmed_division(dots: &[Dot], path: &SPath, labels: &[(usize, usize)], centre: Point2<f64>, mut division: Division) -> (Labels, Division) {
    let (world, image) = correspondences(labels, dots, path);
    let keep = trimmed_count(labels.len()).min(labels.len());
    let mut kept: Labels = labels.to_vec();
    for _ in 0..C_STEPS {
        let (kw, ki) = correspondences(&kept, dots, path);
        let Some(camera) = division.camera(&kw, &ki) else { break };
        let residuals = division.residuals(&camera, &world, &image);
        let mut order: Vec<usize> = (0..labels.len()).collect();
        order.sort_by(|&a, &b| residuals[a].total_cmp(&residuals[b]));
        let mut next: Labels = order[..keep].iter().map(|&k| labels[k]).collect();
        next.sort_unstable();
        if next == kept {
            break;
        }
        kept = next;
        let Some((_, d)) = fit_labels(dots, path, &kept, centre) else { break };
        division = d;
    }
    (kept, division)
}

/// Without a camera, where the image centre is known: the contenders less those that a DLT with
/// a radial lens term fits worse than the best of them by more than `ratio`, unless
/// the first (the least cost) is one of them (then all stay). Through a lens a projective
/// camera's gates cannot tell a labelling from its shift along the path, and their dispute
/// leaves every dot unlabelled (22600 B_07 and B_18, 838346 B_11: "0 undisputed"); the lens term
/// tells them apart (radial RMS 0.08 against 1.75 px on B_07).
pub(super) fn lens_settled<'a>(dots: &[Dot], path: &SPath, contenders: Vec<&'a Assignment>, centre: Point2<f64>, ratio: f64) -> Vec<&'a Assignment> {
    let rms: Vec<f64> = contenders.iter().map(|c| fit_labels(dots, path, &c.labels, centre).map_or(f64::INFINITY, |f| f.0)).collect();
    let least = rms.iter().copied().fold(f64::INFINITY, f64::min);
    log::debug!("s-path assignment: contenders' radial RMS {rms:?}");
    if !rms.first().is_some_and(|&r| r <= ratio * least) {
        return contenders;
    }
    contenders.into_iter().zip(rms).filter(|(_, r)| *r <= ratio * least).map(|(c, _)| c).collect()
}
