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
//! No intrinsics are needed: the DLT's 3 x 4 matrix stands for any pinhole camera.
//!
//! Reference: Hartley and Zisserman, *Multiple View Geometry*, 2nd ed., section 7.1 (normalised
//! DLT for camera resectioning).

use nalgebra::{Matrix3x4, Matrix4, Point2, Point3, SMatrix, SymmetricEigen, Vector3, Vector4};

use super::dots::Dot;
use super::filters::median_by;
use super::s_path_order::{anonymous_chains, indexed, start_chain, start_dot_chain, IndexedDot, SPathOrderParams, MAX_SKIP};
use super::DetectError;
use crate::target::SPath;

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
}

impl Default for SPathFitParams {
    fn default() -> Self {
        Self { order: SPathOrderParams::default(), min_seed: 10, max_seed_rms_px: 4.0, ambiguity_ratio: 2.5, match_fraction: 0.4, max_local_deviation_px: 1.5 }
    }
}

/// A projective camera fitted by the DLT.
#[derive(Debug, Clone, Copy)]
struct Dlt {
    p: Matrix3x4<f64>,
}

impl Dlt {
    /// Normalised DLT from at least 6 correspondences; `None` when they are degenerate.
    fn fit(world: &[Point3<f64>], image: &[Point2<f64>]) -> Option<Self> {
        let n = world.len();
        if n < 6 || image.len() != n {
            return None;
        }
        let m2 = image.iter().fold(Vector3::zeros(), |a, p| a + p.coords.push(1.0)) / n as f64;
        let s2 = image.iter().map(|p| (p.coords - m2.xy()).norm()).sum::<f64>() / n as f64;
        let m3 = world.iter().fold(Vector3::zeros(), |a, p| a + p.coords) / n as f64;
        let s3 = world.iter().map(|p| (p.coords - m3).norm()).sum::<f64>() / n as f64;
        if !(s2 > 1e-9 && s3 > 1e-12) {
            return None;
        }
        let (k2, k3) = (std::f64::consts::SQRT_2 / s2, 3f64.sqrt() / s3);
        let mut ata = SMatrix::<f64, 12, 12>::zeros();
        for (x, u) in world.iter().zip(image) {
            let xs = ((x.coords - m3) * k3).push(1.0);
            let us = (u.coords - m2.xy()) * k2;
            let mut r1 = SMatrix::<f64, 1, 12>::zeros();
            let mut r2 = SMatrix::<f64, 1, 12>::zeros();
            for c in 0..4 {
                r1[c] = xs[c];
                r1[8 + c] = -us.x * xs[c];
                r2[4 + c] = xs[c];
                r2[8 + c] = -us.y * xs[c];
            }
            ata += r1.transpose() * r1 + r2.transpose() * r2;
        }
        let eig = SymmetricEigen::new(ata);
        let mut order: Vec<usize> = (0..12).collect();
        order.sort_by(|a, b| eig.eigenvalues[*a].total_cmp(&eig.eigenvalues[*b]));
        let (l0, l1, lmax) = (eig.eigenvalues[order[0]], eig.eigenvalues[order[1]], eig.eigenvalues[order[11]]);
        // A one-dimensional null space: the second-smallest eigenvalue well above round-off.
        if !(l1 > 1e-10 * lmax) || !l0.is_finite() {
            return None;
        }
        let v = eig.eigenvectors.column(order[0]);
        let ps = Matrix3x4::from_row_slice(v.as_slice());
        let t2_inv = nalgebra::Matrix3::new(1.0 / k2, 0.0, m2.x, 0.0, 1.0 / k2, m2.y, 0.0, 0.0, 1.0);
        let t3 = Matrix4::new(k3, 0.0, 0.0, -k3 * m3.x, 0.0, k3, 0.0, -k3 * m3.y, 0.0, 0.0, k3, -k3 * m3.z, 0.0, 0.0, 0.0, 1.0);
        let mut p = t2_inv * ps * t3;
        // Points in front: positive third coordinate for most of them.
        let front = world.iter().filter(|x| (p * x.to_homogeneous())[2] > 0.0).count();
        if 2 * front < n {
            p = -p;
        }
        p.iter().all(|v| v.is_finite()).then_some(Self { p })
    }

    /// Fit, then refit to the [`TRIM_KEEP`] share of the pairs it fits best: a few mislabelled
    /// dots (a skip miscounted where dots stray from the nominal curve) then cannot drag the
    /// camera, and the matching that follows relabels them.
    fn fit_trimmed(world: &[Point3<f64>], image: &[Point2<f64>]) -> Option<Self> {
        let dlt = Self::fit(world, image)?;
        let keep = ((TRIM_KEEP * world.len() as f64).ceil() as usize).max(12);
        if keep >= world.len() {
            return Some(dlt);
        }
        let mut err: Vec<(f64, usize)> =
            world.iter().zip(image).enumerate().map(|(k, (x, u))| (dlt.project(x).map_or(f64::INFINITY, |q| (q - u).norm()), k)).collect();
        err.sort_by(|a, b| a.0.total_cmp(&b.0));
        let (w, i): (Vec<Point3<f64>>, Vec<Point2<f64>>) = err[..keep].iter().map(|&(_, k)| (world[k], image[k])).unzip();
        Self::fit(&w, &i).or(Some(dlt))
    }

    fn project(&self, x: &Point3<f64>) -> Option<Point2<f64>> {
        let y = self.p * x.to_homogeneous();
        (y[2] > 0.0).then(|| Point2::new(y[0] / y[2], y[1] / y[2]))
    }

    /// Reprojection RMS, pixels (points behind the camera count as 1e6 px).
    fn rms(&self, world: &[Point3<f64>], image: &[Point2<f64>]) -> f64 {
        let ss: f64 = world.iter().zip(image).map(|(x, u)| self.project(x).map_or(1e12, |q| (q - u).norm_squared())).sum();
        (ss / world.len().max(1) as f64).sqrt()
    }

    /// Image distance from `q` (the projection of path point `i`) to the projection of the
    /// nearer path neighbour (hidden neighbours projected anyway).
    fn spacing_at(&self, path: &SPath, i: usize, q: &Point2<f64>) -> f64 {
        [i.checked_sub(1), Some(i + 1)]
            .into_iter()
            .flatten()
            .filter(|&k| k < path.len())
            .filter_map(|k| self.project(&path.points_m[k]).map(|p| (p - q).norm()))
            .fold(f64::INFINITY, f64::min)
    }

    /// The camera centre (homogeneous null vector of P), when finite.
    fn centre(&self) -> Option<Point3<f64>> {
        let col = |i: usize| self.p.column(i).into_owned();
        let det = |a: usize, b: usize, c: usize| nalgebra::Matrix3::from_columns(&[col(a), col(b), col(c)]).determinant();
        let c = Vector4::new(det(1, 2, 3), -det(0, 2, 3), det(0, 1, 3), -det(0, 1, 2));
        (c[3].abs() > 1e-12).then(|| Point3::new(c[0] / c[3], c[1] / c[3], c[2] / c[3]))
    }
}

/// (path index, dot index) pairs.
type Labels = Vec<(usize, usize)>;

/// The path points and dot centres of labelled pairs.
fn correspondences(labels: &[(usize, usize)], dots: &[Dot], path: &SPath) -> (Vec<Point3<f64>>, Vec<Point2<f64>>) {
    (labels.iter().map(|&(i, _)| path.points_m[i]).collect(), labels.iter().map(|&(_, j)| dots[j].centre_px).collect())
}

/// Every labelling of an unlabelled chain ((relative index, dot) pairs), at every index offset
/// and in both directions, with its DLT reprojection RMS (px): best first.
fn labellings(chain: &[(i64, usize)], dots: &[Dot], path: &SPath) -> Vec<(f64, Labels)> {
    let n = path.len() as i64;
    let image: Vec<Point2<f64>> = chain.iter().map(|&(_, j)| dots[j].centre_px).collect();
    let (lo, hi) = chain.iter().fold((i64::MAX, i64::MIN), |(a, b), &(i, _)| (a.min(i), b.max(i)));
    let mut fits: Vec<(f64, Labels)> = Vec::new();
    for dir in [1i64, -1] {
        // Absolute index = offset + dir * relative, all in 0..n.
        let (omin, omax) = if dir == 1 { (-lo, n - 1 - hi) } else { (hi, n - 1 + lo) };
        for offset in omin..=omax {
            let labels: Labels = chain.iter().map(|&(i, j)| ((offset + dir * i) as usize, j)).collect();
            let world: Vec<Point3<f64>> = labels.iter().map(|&(i, _)| path.points_m[i]).collect();
            if let Some(dlt) = Dlt::fit(&world, &image) {
                fits.push((dlt.rms(&world, &image), labels));
            }
        }
    }
    fits.sort_by(|a, b| a.0.total_cmp(&b.0));
    fits
}

/// The labelling of a whole chain, when it is clearly the best.
fn label_chain(chain: &[(i64, usize)], dots: &[Dot], path: &SPath, params: &SPathFitParams) -> Option<Labels> {
    let mut fits = labellings(chain, dots, path);
    let best = fits.first()?.0;
    let runner_up = fits.get(1).map_or(f64::INFINITY, |f| f.0);
    log::debug!("s-path chain of {} dots: best RMS {best:.3} px, runner-up {runner_up:.3} px", chain.len());
    (best <= params.max_seed_rms_px && runner_up > params.ambiguity_ratio * best.max(0.05)).then(|| fits.swap_remove(0).1)
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
            for (rms, labels) in labellings(&chain[s..s + WINDOW], dots, path).into_iter().take(TOP_PER_WINDOW) {
                if rms > params.max_seed_rms_px {
                    continue;
                }
                let g = extend_locally(dots, path, grow(dots, path, labels, params), params);
                if let Some(r) = fit_rms(dots, path, &g) {
                    grown.push((g.len(), r, g));
                }
            }
        }
    }
    let most = grown.iter().map(|g| g.0).max()?;
    grown.retain(|g| g.0 * 5 >= most * 4 && g.1 <= params.max_seed_rms_px);
    grown.sort_by(|a, b| a.1.total_cmp(&b.1));
    let (_, best_rms, best) = grown.first()?;
    // Unambiguous: every labelling that disagrees with the best on most of its dots fits worse
    // by the ambiguity ratio (an arc of clutter fits many stretches of the S about equally).
    let index_of: std::collections::HashMap<usize, usize> = best.iter().map(|&(i, j)| (j, i)).collect();
    let agrees = |g: &Labels| 2 * g.iter().filter(|&&(i, j)| index_of.get(&j) == Some(&i)).count() >= g.len();
    let rival = grown.iter().skip(1).filter(|g| !agrees(&g.2)).map(|g| g.1).fold(f64::INFINITY, f64::min);
    log::debug!("s-path window search: best {} dots at RMS {best_rms:.3} px, rival RMS {rival:.3} px", best.len());
    (rival > params.ambiguity_ratio * best_rms.max(0.05)).then(|| grown.swap_remove(0).2)
}

/// Reprojection RMS of the DLT fitted to labelled dots.
fn fit_rms(dots: &[Dot], path: &SPath, labels: &[(usize, usize)]) -> Option<f64> {
    let (world, image) = correspondences(labels, dots, path);
    Dlt::fit(&world, &image).map(|d| d.rms(&world, &image))
}

/// Match projected path points to dots: (path index, dot) pairs, nearest first, one each.
fn match_projection(dlt: &Dlt, dots: &[Dot], path: &SPath, fraction: f64) -> Vec<(usize, usize)> {
    let centre = dlt.centre();
    let proj: Vec<Option<Point2<f64>>> = (0..path.len())
        .map(|i| {
            let x = path.points_m[i];
            // Dots on the far side of the sphere are hidden.
            let facing = centre.is_none_or(|c| path.normal_at(i).dot(&(c - x)) > 0.0);
            if facing {
                dlt.project(&x)
            } else {
                None
            }
        })
        .collect();
    let mut pairs: Vec<(f64, usize, usize)> = Vec::new();
    for (i, q) in proj.iter().enumerate() {
        let Some(q) = q else { continue };
        let tol = fraction * dlt.spacing_at(path, i, q);
        for (j, d) in dots.iter().enumerate() {
            let e = (d.centre_px - q).norm();
            if e <= tol {
                pairs.push((e, i, j));
            }
        }
    }
    pairs.sort_by(|a, b| a.0.total_cmp(&b.0));
    let (mut point_used, mut dot_used) = (vec![false; path.len()], vec![false; dots.len()]);
    let mut out = Vec::new();
    for (_, i, j) in pairs {
        if !point_used[i] && !dot_used[j] {
            point_used[i] = true;
            dot_used[j] = true;
            out.push((i, j));
        }
    }
    out.sort_unstable();
    out
}

/// Share of the labelled pairs [`Dlt::fit_trimmed`] refits to.
const TRIM_KEEP: f64 = 0.8;

/// Fit to labelled pairs (trimmed), then alternate projection matching and refitting until stable.
fn grow(dots: &[Dot], path: &SPath, mut labels: Vec<(usize, usize)>, params: &SPathFitParams) -> Vec<(usize, usize)> {
    for _ in 0..6 {
        let (world, image) = correspondences(&labels, dots, path);
        let Some(dlt) = Dlt::fit_trimmed(&world, &image) else { break };
        let next = match_projection(&dlt, dots, path, params.match_fraction);
        if next.len() < labels.len() || next == labels {
            break;
        }
        labels = next;
    }
    labels
}

/// Labelled dots a local prediction is fitted to: the nearest along the path.
const LOCAL_FIT: usize = 15;
/// Farthest a local prediction reaches beyond the labelled dots, in path steps.
const LOCAL_REACH: usize = 3;

/// Where path point `i` should appear, from a DLT fitted to the [`LOCAL_FIT`] labelled dots
/// nearest to it along the path, and the matching radius there: `fraction` of the projected
/// spacing, at most `fraction` of 1.5 times the image distance of the nearest labelled pair of
/// path neighbours. `None` when the point faces away from the camera or the fit fails.
fn predict_locally(labels: &[(usize, usize)], dots: &[Dot], path: &SPath, i: usize, fraction: f64) -> Option<(Point2<f64>, f64)> {
    let mut near: Vec<(usize, usize)> = labels.to_vec();
    near.sort_by_key(|&(k, _)| k.abs_diff(i));
    near.truncate(LOCAL_FIT);
    let (world, image) = correspondences(&near, dots, path);
    let dlt = Dlt::fit(&world, &image)?;
    // No visibility test here: a short stretch of the sphere is nearly planar, and its DLT's
    // camera centre is poorly determined.
    let q = dlt.project(&path.points_m[i])?;
    let projected = dlt.spacing_at(path, i, &q);
    let observed =
        near.iter().filter_map(|&(k, j)| near.iter().find(|&&(k2, _)| k2 == k + 1).map(|&(_, j2)| (dots[j2].centre_px - dots[j].centre_px).norm())).next()?;
    Some((q, fraction * projected.min(1.5 * observed)))
}

/// Fill in path points next to the labelled ones (up to [`LOCAL_REACH`] steps beyond) by local
/// prediction, frontier by frontier: where lens distortion bends the image of the path away from
/// any single projective camera, each prediction comes from the nearest labelled stretch.
fn extend_locally(dots: &[Dot], path: &SPath, mut labels: Vec<(usize, usize)>, params: &SPathFitParams) -> Vec<(usize, usize)> {
    let (mut point_used, mut dot_used) = (vec![false; path.len()], vec![false; dots.len()]);
    for &(i, j) in &labels {
        point_used[i] = true;
        dot_used[j] = true;
    }
    let mut tried = vec![false; path.len()];
    loop {
        // The unlabelled, untried points nearest (along the path) to a labelled one, within reach.
        let dist = |i: usize| labels.iter().map(|&(k, _)| k.abs_diff(i)).min().unwrap_or(usize::MAX);
        let Some(d_min) = (0..path.len()).filter(|&i| !point_used[i] && !tried[i]).map(dist).min() else { break };
        if d_min > LOCAL_REACH {
            break;
        }
        let frontier: Vec<usize> = (0..path.len()).filter(|&i| !point_used[i] && !tried[i] && dist(i) == d_min).collect();
        let mut added = Vec::new();
        for i in frontier {
            tried[i] = true;
            let Some((q, tol)) = predict_locally(&labels, dots, path, i, params.match_fraction) else { continue };
            let best = dots.iter().enumerate().filter(|(j, _)| !dot_used[*j]).map(|(j, d)| (j, (d.centre_px - q).norm())).min_by(|a, b| a.1.total_cmp(&b.1));
            if let Some((j, _)) = best.filter(|b| b.1 <= tol) {
                point_used[i] = true;
                dot_used[j] = true;
                added.push((i, j));
            }
        }
        if !added.is_empty() {
            labels.extend(added);
            // New labels open new frontiers: points tried before may now be within reach again.
            tried.iter_mut().for_each(|t| *t = false);
        }
    }
    labels.sort_unstable();
    labels
}

/// Blobs smaller than this (px^2) are held to [`SMALL_BLOB_DEVIATION_PX`] by [`drop_outliers`].
const SMALL_BLOB_PX: f64 = 20.0;
/// Largest deviation of a small blob's residual from its neighbours', pixels.
const SMALL_BLOB_DEVIATION_PX: f64 = 0.6;

/// A residual's jump is an outlier beyond this many robust standard deviations of all jumps.
const JUMP_SIGMAS: f64 = 4.0;

/// Drop matches whose reprojection residual differs from the median residual of their path
/// neighbours (up to 3 indices either side) by more than `max_px` (small blobs: see
/// [`SMALL_BLOB_DEVIATION_PX`]). The residuals of good dots vary smoothly along the path (the
/// blob-centroid bias of beads, lens distortion); a blob that lost part of itself (a sliver
/// along the outline) jumps. On a target whose dots stray from the nominal path (painted or
/// glued by hand) every residual jumps: the bound widens to [`JUMP_SIGMAS`] robust standard
/// deviations (1.4826 median absolute jumps) of all the jumps.
fn drop_outliers(dots: &[Dot], path: &SPath, labels: Vec<(usize, usize)>, max_px: f64) -> Vec<(usize, usize)> {
    let (world, image) = correspondences(&labels, dots, path);
    let Some(dlt) = Dlt::fit(&world, &image) else { return labels };
    let residual: Vec<Option<nalgebra::Vector2<f64>>> = world.iter().zip(&image).map(|(x, u)| dlt.project(x).map(|q| u - q)).collect();
    // Each residual's jump against its path neighbours' median (None: behind the camera; 0 with
    // fewer than two neighbours, which are always kept).
    let jumps: Vec<Option<f64>> = (0..labels.len())
        .map(|k| {
            let r = residual[k]?;
            let near: Vec<nalgebra::Vector2<f64>> =
                (0..labels.len()).filter(|&m| m != k && labels[m].0.abs_diff(labels[k].0) <= 3).filter_map(|m| residual[m]).collect();
            if near.len() < 2 {
                return Some(0.0);
            }
            let med = |f: fn(&nalgebra::Vector2<f64>) -> f64| median_by(&mut near.iter().map(f).collect::<Vec<_>>(), f64::total_cmp).unwrap_or(0.0);
            Some((r - nalgebra::Vector2::new(med(|v| v.x), med(|v| v.y))).norm())
        })
        .collect();
    let sigma = 1.4826 * median_by(&mut jumps.iter().flatten().copied().collect::<Vec<_>>(), f64::total_cmp).unwrap_or(0.0);
    let spread = JUMP_SIGMAS * sigma;
    log::debug!("s-path residual jumps: robust sigma {sigma:.3} px");
    let keep = jumps.iter().zip(&labels).map(|(jump, &(_, j))| {
        // Small blobs (slivers, far dots) carry little centroid bias: a tighter bound.
        let base = if dots[j].area_px < SMALL_BLOB_PX { SMALL_BLOB_DEVIATION_PX.min(max_px) } else { max_px };
        jump.is_some_and(|d| d <= base.max(spread))
    });
    let keep: Vec<bool> = keep.collect();
    labels.into_iter().zip(keep).filter_map(|(l, k)| k.then_some(l)).collect()
}

/// Drop blobs far larger than their path neighbours (up to 5 indices either side, the start dot
/// left out of the comparison): beads squeezed together along the sphere's outline merge into
/// one blob, whose centroid is no dot's. The start dot itself may be `start_ratio` times larger.
fn drop_merged(dots: &[Dot], labels: Vec<(usize, usize)>, start_ratio: f64) -> Vec<(usize, usize)> {
    const MAX_RATIO: f64 = 2.0;
    let keep: Vec<bool> = labels
        .iter()
        .map(|&(i, j)| {
            let mut near: Vec<f64> = labels.iter().filter(|&&(k, _)| k != i && k != 0 && k.abs_diff(i) <= 5).map(|&(_, m)| dots[m].area_px).collect();
            let Some(typical) = median_by(&mut near, f64::total_cmp) else { return true };
            let limit = MAX_RATIO * if i == 0 { start_ratio.max(1.0) * 1.5 } else { 1.0 };
            dots[j].area_px <= limit * typical
        })
        .collect();
    labels.into_iter().zip(keep).filter_map(|(l, k)| k.then_some(l)).collect()
}

/// Start dots recognised at this share of `start_area_ratio` are tried last: at the course's
/// distances a 10 mm cap covers only about 1.7 times the area of its 6 mm neighbours.
const RELAXED_START: f64 = 0.8;

/// The last resort before giving up: the chain from the start dot, however short of the whole
/// path, with the start dot recognised at [`RELAXED_START`] of the usual area ratio. Where dots
/// stray from the nominal path, a jittered chain's labellings all fit about equally (a projective
/// camera absorbs a shift along a smooth curve), and the start dot is what fixes them; the chain
/// stops where the curve-following growth loses the jittered dots, the projection does the rest.
fn relaxed_start_seed(dots: &[Dot], order: &SPathOrderParams, params: &SPathFitParams) -> Option<Labels> {
    let relaxed = SPathOrderParams { start_area_ratio: RELAXED_START * order.start_area_ratio, ..*order };
    let chain = start_dot_chain(dots, &relaxed).ok().filter(|c| c.len() >= params.min_seed)?;
    log::debug!("s-path relaxed start chain: {} dots", chain.len());
    Some(chain.iter().map(|&(i, j)| (i as usize, j)).collect())
}

/// Is the labelling free of index gaps longer than [`MAX_SKIP`]? A fallback labelling from the
/// start dot alone is trusted only then: where dots stray far from the nominal curve, the far
/// part of the path can be placed one index off beyond a stretch it failed to match.
fn without_gaps(labels: &[(usize, usize)]) -> bool {
    let mut idx: Vec<usize> = labels.iter().map(|l| l.0).collect();
    idx.sort_unstable();
    idx.windows(2).all(|w| w[1] - w[0] <= MAX_SKIP)
}

/// Index the S-path's dots: the start chain or a labelled chain, grown by projecting the known
/// path (see the module docs).
///
/// # Errors
/// [`DetectError::NotFound`] when no stretch of dots can be labelled unambiguously, or the result
/// holds too few of the detected dots.
pub fn index_s_path(dots: &[Dot], path: &SPath, params: &SPathFitParams) -> Result<Vec<IndexedDot>, DetectError> {
    let order = SPathOrderParams { points: path.len(), ..params.order };
    let need = order.needed(dots.len());
    let place = |seed: Labels| {
        let grown = extend_locally(dots, path, grow(dots, path, seed, params), params);
        drop_outliers(dots, path, drop_merged(dots, grown, order.start_area_ratio), params.max_local_deviation_px)
    };
    // Chain indices from the start dot are 0 and up.
    let start: Option<Labels> =
        start_chain(dots, &order).ok().filter(|c| c.len() >= params.min_seed).map(|c| c.iter().map(|&(i, j)| (i as usize, j)).collect());
    let labels = match start {
        Some(seed) => Some(place(seed)),
        None => {
            let chains = anonymous_chains(dots, order.tolerance, path.len(), params.min_seed);
            let by_shape = chains.iter().find_map(|c| label_chain(c, dots, path, params)).or_else(|| search_windows(&chains, dots, path, params)).map(place);
            match by_shape {
                Some(l) if l.len() >= need => Some(l),
                // Where the shape fell short, the start dot's own chain competes (see
                // relaxed_start_seed); the labelling placing more dots wins.
                short => match (short, relaxed_start_seed(dots, &order, params).map(place).filter(|l| without_gaps(l))) {
                    (Some(a), Some(b)) => Some(if b.len() > a.len() { b } else { a }),
                    (a, b) => a.or(b),
                },
            }
        }
    };
    let Some(labels) = labels else {
        return Err(DetectError::NotFound { reason: format!("no stretch of the {} dots could be placed on the S-path", dots.len()) });
    };
    if labels.len() < need {
        return Err(DetectError::NotFound { reason: format!("{} of {} dots placed on the S-path (at least {need} needed)", labels.len(), dots.len()) });
    }
    Ok(indexed(dots, &labels))
}

/// One indexed dot's residual against the whole path's fit.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct PathResidual {
    /// Detected centre minus the projection of the dot's nominal path point by the projective
    /// camera (DLT) fitted to all the indexed dots, pixels.
    pub residual_px: nalgebra::Vector2<f64>,
    /// The residual's length turned into metres on the target with the local scale along the
    /// path (projected over nominal spacing of the path neighbours): how far the dot seems to
    /// stray from its nominal place.
    pub deviation_m: f64,
}

/// Residuals of the indexed dots against the DLT fitted to all of them: how far each dot sits
/// from where the nominal path puts it (a hand-painted or glued target strays by millimetres).
/// Bead centroids carry the bead's own offset from its path point (about 1.4 px at the course's
/// pose, see the README), lens distortion a smooth part. `None` with fewer than 6 dots or a
/// degenerate fit.
pub fn path_residuals(ordered: &[IndexedDot], path: &SPath) -> Option<Vec<PathResidual>> {
    let valid: Vec<&IndexedDot> = ordered.iter().filter(|d| d.index < path.len()).collect();
    if valid.len() != ordered.len() {
        return None;
    }
    let world: Vec<Point3<f64>> = valid.iter().map(|d| path.points_m[d.index]).collect();
    let image: Vec<Point2<f64>> = valid.iter().map(|d| d.centre_px).collect();
    let dlt = Dlt::fit(&world, &image)?;
    valid
        .iter()
        .map(|d| {
            let q = dlt.project(&path.points_m[d.index])?;
            let scales: Vec<f64> = [d.index.checked_sub(1), Some(d.index + 1)]
                .into_iter()
                .flatten()
                .filter(|&k| k < path.len())
                .filter_map(|k| {
                    let world_m = (path.points_m[k] - path.points_m[d.index]).norm();
                    Some((dlt.project(&path.points_m[k])? - q).norm() / world_m)
                })
                .filter(|s| s.is_finite() && *s > 0.0)
                .collect();
            let px_per_m = scales.iter().sum::<f64>() / scales.len().max(1) as f64;
            let residual_px = d.centre_px - q;
            Some(PathResidual { residual_px, deviation_m: if px_per_m > 0.0 { residual_px.norm() / px_per_m } else { f64::NAN } })
        })
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::target::course_s_path;
    use nalgebra::{Isometry3, Translation3, UnitQuaternion};

    /// The course S-path seen from the course's desired pose (f = 1500 px, 1280 x 1024).
    fn projected() -> (SPath, Vec<Option<Point2<f64>>>) {
        let path = course_s_path();
        let r = nalgebra::Rotation3::from_matrix_unchecked(nalgebra::Matrix3::new(0.0, -1.0, 0.0, 0.0, 0.0, 1.0, -1.0, 0.0, 0.0));
        let cam_from_world = Isometry3::from_parts(Translation3::new(0.0, -0.55, 1.8), UnitQuaternion::from_rotation_matrix(&r));
        let pts = path
            .points_m
            .iter()
            .map(|x| {
                let c = cam_from_world * x;
                (c.z > 0.0).then(|| Point2::new(640.0 + 1500.0 * c.x / c.z, 512.0 + 1500.0 * c.y / c.z))
            })
            .collect();
        (path, pts)
    }

    fn dot(p: Point2<f64>, area: f64) -> Dot {
        Dot { centre_px: p, area_px: area, core_px: 4, contrast: 200.0 }
    }

    #[test]
    fn dlt_recovers_a_projection() {
        let (path, pts) = projected();
        let world: Vec<Point3<f64>> = path.points_m[..30].to_vec();
        let image: Vec<Point2<f64>> = pts[..30].iter().map(|p| p.unwrap()).collect();
        let dlt = Dlt::fit(&world, &image).unwrap();
        assert!(dlt.rms(&world, &image) < 1e-6);
        let q = dlt.project(&path.points_m[80]).unwrap();
        assert!((q - pts[80].unwrap()).norm() < 1e-4, "{q}");
        // The camera centre: world (1.8, 0, 0.55).
        let c = dlt.centre().unwrap();
        assert!((c - Point3::new(1.8, 0.0, 0.55)).norm() < 1e-6, "{c}");
    }

    #[test]
    fn path_residuals_find_the_dot_that_strays() {
        // Every visible dot at its projection, dot 50 moved 3 px across the path: its residual is
        // the 3 px (the fit spreads a little of it), its deviation 3 px over the local scale.
        let (path, pts) = projected();
        let mut ordered: Vec<IndexedDot> = pts.iter().enumerate().filter_map(|(i, p)| p.map(|c| IndexedDot { index: i, centre_px: c })).collect();
        let k = ordered.iter().position(|d| d.index == 50).unwrap();
        ordered[k].centre_px += nalgebra::Vector2::new(0.0, 3.0);
        let r = path_residuals(&ordered, &path).unwrap();
        assert!((r[k].residual_px.norm() - 3.0).abs() < 0.15, "{:?}", r[k]);
        let others = r.iter().enumerate().filter(|(m, _)| *m != k).map(|(_, p)| p.residual_px.norm()).fold(0.0, f64::max);
        assert!(others < 0.3, "{others}");
        let scale = (pts[51].unwrap() - pts[50].unwrap()).norm() / (path.points_m[51] - path.points_m[50]).norm();
        assert!((r[k].deviation_m * scale / 3.0 - 1.0).abs() < 0.2, "{} m at {scale} px/m", r[k].deviation_m);
    }

    #[test]
    fn indexes_the_path_without_its_start_and_across_a_gap() {
        // Start hidden (dots 0-7 gone), a gap of five (40-44), shuffled.
        let (path, pts) = projected();
        let mut dots: Vec<Dot> = (0..101).filter(|i| *i >= 8 && !(40..45).contains(i)).map(|i| dot(pts[i].unwrap(), 30.0)).collect();
        dots.reverse();
        dots.swap(5, 50);
        let out = index_s_path(&dots, &path, &SPathFitParams::default()).unwrap();
        let idx: Vec<usize> = out.iter().map(|d| d.index).collect();
        assert_eq!(idx, (8..101).filter(|i| !(40..45).contains(i)).collect::<Vec<_>>());
        for d in &out {
            assert!((d.centre_px - pts[d.index].unwrap()).norm() < 1e-9);
        }
    }

    /// The course view with every dot moved on the sphere by up to `dev_m` (uniform in a disc,
    /// seeded), the start dot 10/6 times larger in radius than the others.
    fn jittered(dev_m: f64, seed: u64) -> (SPath, Vec<Dot>, Vec<Point2<f64>>) {
        use rand::{Rng, SeedableRng};
        let (path, _) = projected();
        let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(seed);
        let r = nalgebra::Rotation3::from_matrix_unchecked(nalgebra::Matrix3::new(0.0, -1.0, 0.0, 0.0, 0.0, 1.0, -1.0, 0.0, 0.0));
        let cam_from_world = Isometry3::from_parts(Translation3::new(0.0, -0.55, 1.8), UnitQuaternion::from_rotation_matrix(&r));
        let mut image = Vec::new();
        for (i, x) in path.points_m.iter().enumerate() {
            let n = path.normal_at(i);
            let t1 = n.cross(&Vector3::z()).normalize();
            let t2 = n.cross(&t1);
            let (rad, ang) = (dev_m * rng.random::<f64>().sqrt(), rng.random_range(0.0..std::f64::consts::TAU));
            let c = cam_from_world * (x + t1 * rad * ang.cos() + t2 * rad * ang.sin());
            image.push(Point2::new(640.0 + 1500.0 * c.x / c.z, 512.0 + 1500.0 * c.y / c.z));
        }
        let dots = image.iter().enumerate().map(|(i, p)| dot(*p, if i == 0 { 30.0 * (10.0f64 / 6.0).powi(2) } else { 30.0 })).collect();
        (path, dots, image)
    }

    #[test]
    fn dots_straying_from_the_nominal_path_keep_their_indices() {
        // 2 mm (about 1.7 px here, 8 % of the dot spacing): every seed fully and rightly indexed.
        // (At 5 mm most views are not found: see the README; none is mis-indexed.)
        for seed in 0..10 {
            let (path, dots, image) = jittered(0.002, seed);
            let out = index_s_path(&dots, &path, &SPathFitParams::default()).unwrap_or_else(|e| panic!("seed {seed}: {e}"));
            assert_eq!(out.len(), 101, "seed {seed}");
            for d in &out {
                assert!((d.centre_px - image[d.index]).norm() < 1e-9, "seed {seed}: index {}", d.index);
            }
        }
        for seed in 0..10 {
            let (path, dots, image) = jittered(0.005, seed);
            if let Ok(out) = index_s_path(&dots, &path, &SPathFitParams::default()) {
                assert!(out.iter().all(|d| (d.centre_px - image[d.index]).norm() < 1e-9), "5 mm, seed {seed}: a dot mis-indexed");
            }
        }
    }

    #[test]
    fn clutter_is_not_a_path() {
        let (path, _) = projected();
        // A closed ring of 60 dots: the S has an inflection, no view of it closes up. (A shorter
        // circular arc is no test: parts of the S are circular arcs, and a DLT maps a circle to
        // any ellipse, so an arc of evenly spaced dots is a possible view of them.)
        let ring: Vec<Dot> = (0..60)
            .map(|i| {
                let a = f64::from(i) * std::f64::consts::TAU / 60.0;
                dot(Point2::new(500.0 + 150.0 * a.cos(), 400.0 + 150.0 * a.sin()), 30.0)
            })
            .collect();
        assert!(index_s_path(&ring, &path, &SPathFitParams::default()).is_err());
        // Scattered dots.
        let mut state = 12345u64;
        let mut next = || {
            state = state.wrapping_mul(6364136223846793005).wrapping_add(1442695040888963407);
            (state >> 11) as f64 / (1u64 << 53) as f64
        };
        let scatter: Vec<Dot> = (0..80).map(|_| dot(Point2::new(1280.0 * next(), 1024.0 * next()), 30.0)).collect();
        assert!(index_s_path(&scatter, &path, &SPathFitParams::default()).is_err());
    }
}
