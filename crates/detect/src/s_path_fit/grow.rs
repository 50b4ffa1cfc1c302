//! Growing a labelling over the dots: the projection of a fitted camera matched to the dots, and
//! local fits that follow lens distortion beyond any single projective camera.

use nalgebra::{Point2, Point3};

use super::dlt::Dlt;
use super::{correspondences, SPathFitParams};
use crate::dots::Dot;
use synthcam_core::target::SPath;

/// Each path point's image under `dlt`, `None` where the camera cannot see it (behind it, or on
/// the far side of the sphere: [`facing`]).
pub(super) fn facing_projections(dlt: &Dlt, path: &SPath) -> Vec<Option<Point2<f64>>> {
    let centre = dlt.centre();
    (0..path.len()).map(|i| facing(path, i, centre).then(|| dlt.project(&path.points_m[i])).flatten()).collect()
}

/// Does path point `i` face a camera centred at `centre` (every point where the centre is at
/// infinity)? Dots on the far side of the sphere are hidden.
pub(super) fn facing(path: &SPath, i: usize, centre: Option<Point3<f64>>) -> bool {
    centre.is_none_or(|c| path.normal_at(i).dot(&(c - path.points_m[i])) > 0.0)
}

/// Match projected path points to dots: (path index, dot) pairs, nearest first, one each.
pub(super) fn match_projection(dlt: &Dlt, dots: &[Dot], path: &SPath, fraction: f64) -> Vec<(usize, usize)> {
    let proj = facing_projections(dlt, path);
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
pub(super) const TRIM_KEEP: f64 = 0.8;

/// Pairs a trimmed fit keeps of `n`: the [`TRIM_KEEP`] share, at least 12.
pub(super) fn trimmed_count(n: usize) -> usize {
    ((TRIM_KEEP * n as f64).ceil() as usize).max(12)
}

/// Fit to labelled pairs (trimmed), then alternate projection matching and refitting until stable.
pub(super) fn grow(dots: &[Dot], path: &SPath, mut labels: Vec<(usize, usize)>, params: &SPathFitParams) -> Vec<(usize, usize)> {
    for _ in 0..6 {
        let (world, image) = correspondences(&labels, dots, path);
        let Some(dlt) = Dlt::fit_trimmed(&world, &image, params.pinhole()) else { break };
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
fn predict_locally(labels: &[(usize, usize)], dots: &[Dot], path: &SPath, i: usize, params: &SPathFitParams) -> Option<(Point2<f64>, f64)> {
    let mut near: Vec<(usize, usize)> = labels.to_vec();
    near.sort_by_key(|&(k, _)| k.abs_diff(i));
    near.truncate(LOCAL_FIT);
    let (world, image) = correspondences(&near, dots, path);
    let dlt = Dlt::fit(&world, &image, params.pinhole())?;
    // No visibility test here: a short stretch of the sphere is nearly planar, and its DLT's
    // camera centre is poorly determined.
    let q = dlt.project(&path.points_m[i])?;
    let projected = dlt.spacing_at(path, i, &q);
    let observed =
        near.iter().filter_map(|&(k, j)| near.iter().find(|&&(k2, _)| k2 == k + 1).map(|&(_, j2)| (dots[j2].centre_px - dots[j].centre_px).norm())).next()?;
    Some((q, params.match_fraction * projected.min(1.5 * observed)))
}

/// Fill in path points next to the labelled ones (up to [`LOCAL_REACH`] steps beyond) by local
/// prediction, frontier by frontier: where lens distortion bends the image of the path away from
/// any single projective camera, each prediction comes from the nearest labelled stretch.
pub(super) fn extend_locally(dots: &[Dot], path: &SPath, mut labels: Vec<(usize, usize)>, params: &SPathFitParams) -> Vec<(usize, usize)> {
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
            let Some((q, tol)) = predict_locally(&labels, dots, path, i, params) else { continue };
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
