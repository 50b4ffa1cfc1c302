//! Indexing S-path dots by the path's known 3-D shape.
//!
//! The chain from the start dot ([`super::s_path_order`]) indexes the dots only up to the first
//! stretch it cannot bridge, and not at all when the start dot is hidden. The path's points are
//! known in 3-D (the course's S on its sphere), so a labelled stretch fixes a projective camera:
//!
//! 1. *Seed*: the chain from the start dot when there is one; otherwise chains grown from any dot
//!    ([`anonymous_chains`], longest first), each tried at every index offset and in both
//!    directions. A direct linear transform (DLT) from its dots to the path points gives a
//!    reprojection RMS per labelling; the best must be small and clearly better than the runner-up
//!    (the S is nearly point-symmetric, so the reversed labelling is the usual runner-up).
//!    When no whole chain labels unambiguously, windows of 15 chain dots are labelled and grown
//!    (`search_windows`), and the grown labelling that fits best wins if no disagreeing one
//!    comes close.
//! 2. *Grow*: project all path points with the fitted camera, keep those on the side of the sphere
//!    the camera sees, match each to the nearest detected dot within a fraction of the local
//!    projected spacing (one dot per point, nearest pairs first), refit, repeat until stable; then
//!    fill in the points next to the labelled ones from DLTs fitted to their nearest labelled
//!    stretch (`extend_locally`: lens distortion bends the image of a long path away from any
//!    single projective camera).
//! 3. *Check*: drop blobs far larger than their path neighbours (dots merged into one blob) and
//!    dots whose reprojection residual jumps against their neighbours' (`drop_outliers`).
//!
//! 4. *Strays*: where the strict chains leave dots unplaced, all of this runs again on chains
//!    grown for dots that stray from the nominal path ([`ChainGrowth::Strays`], up to a fifth of
//!    the spacing: 5 mm on the course's target), with each chain's open index increments decided
//!    by the path's shape for every placement along the path before the placements are ranked
//!    (`label`, `resolve`), a short start chain ruling out the labellings of the other chains
//!    that contradict its first steps, or the two longest chains labelling each other (`strays`).
//! 5. *Stepped over*: an unplaced dot between the dots of two consecutive indices takes the
//!    index, the stretch after it moving up by one (`skipped`).
//! 6. *Assign*: the labellings of steps 1-5 are only seeds (with their shifts along the path, the
//!    first steps from the start dot and the best placements of the longest chains): each fixes
//!    a camera, and all dots are assigned to the projected path points at once by a
//!    minimum-cost assignment gated by the tolerated deviation
//!    ([`SPathFitParams::max_deviation_m`]), refitted until stable; the assignment explaining the
//!    dots best wins only where no shift of it (whole, or beyond any of its stretches) comes
//!    close, and a start dot it contradicts rules it out (`assign`). Blobs that are no
//!    measurement ([`unmeasured()`]) are left to the caller.
//! 7. *Lens*: without a camera, where the image centre is given
//!    ([`SPathFitParams::image_centre_px`]), the result is checked by a DLT with one radial term
//!    (the division model): a beam search over its shifts along the path replaces it by one that
//!    fits clearly better, and where the lens term is significant the undistorted dots are
//!    assigned afresh (`radial`); where the assignment's contenders dispute its dots, those
//!    this camera fits far worse than the best of them drop out (`assign`). Without a camera, a
//!    labelling whose reversal (the S is nearly
//!    point-symmetric) the assignment explains better is refused as ambiguous
//!    (`checks::reversal_explains_better`).
//!
//! No intrinsics are needed: the DLT's 3 x 4 matrix stands for any pinhole camera. But its 11
//! degrees of freedom absorb much of a shift of the path along itself: where dots stray from
//! their nominal points (7 mm of the 25.7 mm spacing), a placement one index off, or the S run
//! backwards (it is nearly point-symmetric), fits a projective camera about as well as the right
//! one, and views showing only part of the path are refused. Where the camera is known
//! ([`SPathFitParams::camera`], `detect --camera`), the dots are undistorted and every fit is a
//! pose behind the known intrinsics (6 degrees of freedom, `pose.rs`: SQPnP, then
//! Levenberg-Marquardt), which tells those placements apart; there, in addition, a seed's matches
//! are grown under the wider matching radius before the tight assignment, the best assignment is
//! challenged by its reversals too, and where the usual seeds fall short, every placement of
//! windows of consecutive chain dots is verified against all the dots (hypothesise and verify),
//! each window's pose also turned about its chord (`sweep`: the rotation a nearly straight
//! stretch leaves open), and the best become seeds (`seeds::verified_windows`); a start dot
//! recognised by its area alone (larger than two merged dots can be) has the best labellings'
//! shifts and mirror images that put it at index 0 compete too (`start`).
//!
//! Reference: Hartley and Zisserman, *Multiple View Geometry*, 2nd ed., section 7.1 (normalised
//! DLT for camera resectioning).

use nalgebra::{Point2, Point3};

use super::dots::Dot;
use super::s_path_order::{anonymous_chains, indexed, start_chain, start_dot_chain, ChainGrowth, IndexedDot, SPathOrderParams, MAX_SKIP};
use super::DetectError;
use dlt::Dlt;
pub use residuals::{path_residuals, PathResidual};
pub use track::{SPathTrack, TRACK_FRACTION};
pub use unmeasured::{unmeasured, MERGED_SPREAD, START_RADIUS_RATIO};

mod anchor;
mod assign;
mod checks;
mod dlt;
mod gate;
mod grow;
mod hungarian;
mod label;
mod pose;
mod radial;
mod residuals;
mod resolve;
mod seeds;
mod skipped;
mod start;
mod strays;
mod sweep;
mod track;
mod unmeasured;
use checks::{drop_merged, drop_outliers};
use grow::{extend_locally, grow, match_projection};
use label::{label_chain, labellings};
use resolve::{chain_labels, resolve_steps, Head};
use synthcam_core::camera::{CameraModel, Intrinsics};
use synthcam_core::target::SPath;

/// Parameters of [`index_s_path`].
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct SPathFitParams {
    /// Chain growing and acceptance (start dot, tolerances, minimum chain and share).
    pub order: SPathOrderParams,
    /// Fewest dots of a chain to try labellings on.
    pub min_seed: usize,
    /// Largest reprojection RMS of an accepted seed labelling, pixels.
    pub max_seed_rms_px: f64,
    /// The runner-up labelling's RMS must exceed the best's by this factor.
    pub ambiguity_ratio: f64,
    /// Matching radius around a projected point, as a fraction of the projected spacing there.
    pub match_fraction: f64,
    /// A dot whose reprojection residual differs from its path neighbours' by more is dropped, px.
    pub max_local_deviation_px: f64,
    /// Largest distance of a dot from its nominal path point on the target, metres (painted or
    /// glued by hand; default 7.5 mm, the course's dots 25.7 mm apart): the final labelling
    /// (`assign`) places a dot only inside the image of this disc around its point. Below half
    /// the spacing the discs are disjoint.
    pub max_deviation_m: f64,
    /// How far the dots' centres may stand off the sphere along its normal, metres (a bead's
    /// centre: its radius, 6 mm on the course; a painted disc's: 0): the height is fitted to
    /// the placed dots within 0 and this, and the tolerance disc raised by it.
    pub max_height_m: f64,
    /// How far the fitted camera (a DLT: lens distortion included) may miss a point's image, pixels: a dot up to
    /// this far outside its disc's image is still placed, if no other is nearly as near.
    pub model_error_px: f64,
    /// The camera, where known (calibrated): dots are then placed by its pose (6 degrees of
    /// freedom) behind its intrinsics and lens, not by a projective camera (11).
    pub camera: Option<CameraModel>,
    /// The image centre, pixels (`((width - 1) / 2, (height - 1) / 2)`): where the camera is
    /// unknown, the final labelling is checked by a projective camera with one radial lens term
    /// about it (the division model, `radial`); `None` leaves the check out.
    pub image_centre_px: Option<Point2<f64>>,
}

impl Default for SPathFitParams {
    fn default() -> Self {
        Self {
            order: SPathOrderParams::default(),
            min_seed: 10,
            max_seed_rms_px: 4.0,
            ambiguity_ratio: 2.5,
            match_fraction: 0.4,
            max_local_deviation_px: 1.5,
            max_deviation_m: 0.0075,
            max_height_m: 0.006,
            model_error_px: 2.0,
            camera: None,
            image_centre_px: None,
        }
    }
}

/// (path index, dot index) pairs.
type Labels = Vec<(usize, usize)>;

/// The intrinsics of the dots' (undistorted) pixels, where the camera is known.
type Pinhole<'a> = Option<&'a Intrinsics>;

impl SPathFitParams {
    /// The camera's intrinsics, where it is known.
    fn pinhole(&self) -> Pinhole<'_> {
        self.camera.as_ref().map(|c| &c.intrinsics)
    }
}

/// The path points and dot centres of labelled pairs.
fn correspondences(labels: &[(usize, usize)], dots: &[Dot], path: &SPath) -> (Vec<Point3<f64>>, Vec<Point2<f64>>) {
    (labels.iter().map(|&(i, _)| path.points_m[i]).collect(), labels.iter().map(|&(_, j)| dots[j].centre_px).collect())
}

/// Dots per window of [`search_windows`].
const WINDOW: usize = 15;
/// Labellings grown per window.
const TOP_PER_WINDOW: usize = 3;
/// Chains searched.
const CHAINS_SEARCHED: usize = 3;

/// When no whole chain labels unambiguously (a chain that bridged wrongly somewhere, strong lens
/// distortion over a long stretch): windows of [`WINDOW`] consecutive chain dots, their few best
/// labellings each grown over all dots; among the grown labellings placing at least 80 % as many
/// dots as the best, the one with the lowest reprojection RMS wins (a labelling off by one index
/// places as many dots, but fits them worse).
fn search_windows(chains: &[Vec<(i64, usize)>], dots: &[Dot], path: &SPath, params: &SPathFitParams) -> Option<Labels> {
    let mut grown: Vec<(usize, f64, Labels)> = Vec::new();
    for chain in chains.iter().take(CHAINS_SEARCHED) {
        let starts = (0..chain.len().saturating_sub(WINDOW - 1)).step_by(WINDOW / 2);
        for s in starts {
            for (rms, labels) in labellings(&chain[s..s + WINDOW], dots, path, params.pinhole()).into_iter().take(TOP_PER_WINDOW) {
                if rms > params.max_seed_rms_px {
                    continue;
                }
                let g = extend_locally(dots, path, grow(dots, path, labels, params), params);
                if let Some(r) = fit_rms(dots, path, &g, params.pinhole()) {
                    grown.push((g.len(), r, g));
                }
            }
        }
    }
    let most = grown.iter().map(|g| g.0).max()?;
    grown.retain(|g| g.0 * 5 >= most * 4 && g.1 <= params.max_seed_rms_px);
    // Unambiguous: every labelling that disagrees with the best on most of its dots fits worse
    // by the ambiguity ratio (an arc of clutter fits many stretches of the S about equally).
    let (_, best_rms, best, rival) = best_and_rival(grown)?;
    log::debug!("s-path window search: best {} dots at RMS {best_rms:.3} px, rival RMS {rival:.3} px", best.len());
    (rival > params.ambiguity_ratio * best_rms.max(0.05)).then_some(best)
}

/// Grown labellings (dots placed, RMS px, labels): the one that fits best, and the lowest RMS
/// of those that disagree with it on most of their dots (infinite when none does).
fn best_and_rival(mut grown: Vec<(usize, f64, Labels)>) -> Option<(usize, f64, Labels, f64)> {
    grown.sort_by(|a, b| a.1.total_cmp(&b.1));
    let (placed, rms, best) = grown.first()?.clone();
    let rival = grown.iter().skip(1).filter(|g| !mostly_agree(&best, &g.2)).map(|g| g.1).fold(f64::INFINITY, f64::min);
    Some((placed, rms, best, rival))
}

/// Does labelling `other` give most of its dots the index `best` gives them?
fn mostly_agree(best: &[(usize, usize)], other: &[(usize, usize)]) -> bool {
    let index_of: std::collections::HashMap<usize, usize> = best.iter().map(|&(i, j)| (j, i)).collect();
    2 * other.iter().filter(|&&(i, j)| index_of.get(&j) == Some(&i)).count() >= other.len()
}

/// Reprojection RMS of the DLT fitted to labelled dots.
fn fit_rms(dots: &[Dot], path: &SPath, labels: &[(usize, usize)], pinhole: Pinhole) -> Option<f64> {
    let (world, image) = correspondences(labels, dots, path);
    Dlt::fit(&world, &image, pinhole).map(|d| d.rms(&world, &image))
}

/// Start dots recognised at this share of `start_area_ratio` are tried last: at the course's
/// distances a 10 mm cap covers only about 1.7 times the area of its 6 mm neighbours.
const RELAXED_START: f64 = 0.8;

/// The last resort before giving up: the chain from the start dot, however short of the whole
/// path, with the start dot recognised at [`RELAXED_START`] of the usual area ratio. Where dots
/// stray from the nominal path, a jittered chain's labellings all fit about equally (a projective
/// camera absorbs a shift along a smooth curve), and the start dot is what fixes them; the chain
/// stops where the curve-following growth loses the jittered dots, the projection does the rest.
fn relaxed_start_seed(dots: &[Dot], path: &SPath, order: &SPathOrderParams, params: &SPathFitParams) -> Option<Labels> {
    let relaxed = SPathOrderParams { start_area_ratio: RELAXED_START * order.start_area_ratio, ..*order };
    let chain = start_dot_chain(dots, &relaxed).ok().filter(|c| c.len() >= params.min_seed)?;
    let chain = if order.growth == ChainGrowth::Strays { resolve_steps(dots, path, chain, &[], Head::StartDot, params.pinhole()) } else { chain };
    log::debug!("s-path relaxed start chain: {} dots", chain.len());
    Some(chain_labels(&chain))
}

/// The labelling placing more dots (`first` on a tie), or the one there is.
fn more_placed(first: Option<Labels>, second: Option<Labels>) -> Option<Labels> {
    match (first, second) {
        (Some(a), Some(b)) => Some(if b.len() > a.len() { b } else { a }),
        (a, b) => a.or(b),
    }
}

/// Is the labelling free of index gaps longer than [`MAX_SKIP`]? A fallback labelling from the
/// start dot alone is trusted only then: where dots stray far from the nominal curve, the far
/// part of the path can be placed one index off beyond a stretch it failed to match.
fn without_gaps(labels: &[(usize, usize)]) -> bool {
    let mut idx: Vec<usize> = labels.iter().map(|l| l.0).collect();
    idx.sort_unstable();
    idx.windows(2).all(|w| w[1] - w[0] <= MAX_SKIP)
}

/// Index the S-path's dots: seed labellings from chains of dots (see the module docs), each
/// refined into an optimal assignment of all dots to the projected path within the tolerated
/// deviation (`assign`); the assignment placing clearly the most dots wins.
///
/// # Errors
/// [`DetectError::NotFound`] when no stretch of dots can be labelled unambiguously, or the result
/// holds too few of the detected dots.
pub fn index_s_path(dots: &[Dot], path: &SPath, params: &SPathFitParams) -> Result<Vec<IndexedDot>, DetectError> {
    let Some(camera) = params.camera else { return place_all(dots, path, params).map(|l| indexed(dots, &l)) };
    // Undistorted pixels of the camera's pinhole; dots the lens cannot invert are left out.
    let (ideal, index): (Vec<Dot>, Vec<usize>) = dots
        .iter()
        .enumerate()
        .filter_map(|(j, d)| {
            let ray = camera.unproject(&d.centre_px).ok()?;
            Some((Dot { centre_px: camera.intrinsics.normalized_to_pixel(&ray.xy()), ..*d }, j))
        })
        .unzip();
    let labels: Labels = place_all(&ideal, path, params)?.iter().map(|&(i, j)| (i, index[j])).collect();
    Ok(indexed(dots, &labels))
}

fn place_all(dots: &[Dot], path: &SPath, params: &SPathFitParams) -> Result<Labels, DetectError> {
    let order = SPathOrderParams { points: path.len(), ..params.order };
    let need = order.needed(dots.len());
    let (chained, mut seeds) = seeds::seeds(dots, path, params, &order);
    let by_area = params.camera.and_then(|_| seeds::start_by_area(dots));
    let start = match (by_area, seeds::start_dot(dots, &order)) {
        (Some(s), _) => start::StartDot::Anchors(s),
        (None, Some(s)) => start::StartDot::Breaks(s),
        (None, None) => start::StartDot::Unknown,
    };
    let assigned = |dots: &[Dot], seeds: &[Labels]| {
        assign::best_assignment(dots, path, seeds, params, start)
            .map(|(l, placed)| assign::join_chained(l, chained.as_deref().unwrap_or_default(), &placed))
            .map(|l| drop_merged(dots, l, order.start_area_ratio))
    };
    let mut labels = assigned(dots, &seeds);
    if labels.as_ref().is_none_or(|l| l.len() < need) && params.camera.is_some() {
        // The windows' placements verified against all the dots: costlier, only where needed.
        seeds.extend(seeds::verified_windows(dots, path, params, &order));
        labels = assigned(dots, &seeds);
    }
    if let (Some(centre), None) = (params.image_centre_px, params.camera) {
        labels = labels.map(|l| lens_checked(dots, path, l, centre, params, assigned));
    }
    let Some(labels) = labels.map(|l| checks::drop_contradicted(dots, path, l, params, &order)) else {
        return Err(DetectError::NotFound { reason: format!("no stretch of the {} dots could be placed on the S-path", dots.len()) });
    };
    if params.camera.is_none() && checks::reversal_explains_better(dots, path, &labels, params) {
        return Err(DetectError::NotFound { reason: "the S run backwards explains the dots better than the labelling found: ambiguous".into() });
    }
    if labels.len() < need {
        return Err(DetectError::NotFound { reason: format!("{} of {} dots placed on the S-path (at least {need} needed)", labels.len(), dots.len()) });
    }
    Ok(labels)
}

/// Without a camera: the labelling checked by a DLT with one radial lens term about `centre`
/// (`radial`): replaced by a rival that fits clearly better, and where the lens term is
/// significant, the dots undistorted by it assigned afresh (`assigned`: the assignment of
/// [`place_all`] on the dots given, seeded by the labellings given), kept where that places no
/// fewer dots.
fn lens_checked(
    dots: &[Dot],
    path: &SPath,
    labels: Labels,
    centre: Point2<f64>,
    params: &SPathFitParams,
    assigned: impl Fn(&[Dot], &[Labels]) -> Option<Labels>,
) -> Labels {
    match radial::best_rival(dots, path, labels.clone(), centre, params.ambiguity_ratio) {
        Some(radial::Checked { chosen, lens: Some((kept, division)) }) => {
            let undistorted: Vec<Dot> = dots.iter().map(|d| Dot { centre_px: division.undistort(&d.centre_px), ..*d }).collect();
            assigned(&undistorted, &[chosen.clone(), kept]).filter(|a| a.len() >= chosen.len()).unwrap_or(chosen)
        }
        Some(radial::Checked { chosen, lens: None }) => chosen,
        None => labels,
    }
}

/// The labelling of [`index_s_path`] with chains grown as `order.growth` says; `None` where no
/// stretch of dots could be placed.
fn place_labels(dots: &[Dot], path: &SPath, params: &SPathFitParams, order: &SPathOrderParams) -> Option<Labels> {
    let need = order.needed(dots.len());
    let strays = order.growth == ChainGrowth::Strays;
    let place = |seed: Labels| {
        let grown = extend_locally(dots, path, grow(dots, path, seed, params), params);
        drop_outliers(dots, path, drop_merged(dots, grown, order.start_area_ratio), params)
    };
    // Chain indices from the start dot are 0 and up.
    let label_start = |c: Vec<(i64, usize)>| if strays { strays::label_start_chain(&c, dots, path, params, need) } else { chain_labels(&c) };
    if let Some(seed) = start_chain(dots, order).ok().filter(|c| c.len() >= params.min_seed).map(label_start) {
        return Some(place(seed));
    }
    let chains = anonymous_chains(dots, order, params.min_seed);
    let by_chain = match strays {
        true => strays::label_chains(&chains, dots, path, params, order),
        false => chains.iter().find_map(|c| label_chain(c, dots, path, params, false, &[], false)),
    };
    let by_shape = by_chain.or_else(|| search_windows(&chains, dots, path, params)).map(place);
    match by_shape {
        Some(l) if l.len() >= need => Some(l),
        // Where the shape fell short, the start dot's own chain competes (see
        // relaxed_start_seed); the labelling placing more dots wins.
        short => more_placed(short, relaxed_start_seed(dots, path, order, params).map(place).filter(|l| without_gaps(l))),
    }
}

#[cfg(test)]
mod radial_tests;
#[cfg(test)]
mod tests;
