//! The S-path's start dot in the assignment ([`super::assign::best_assignment`]): the larger
//! first dot (10 mm against 6 mm) tells a placement from its shifts along the path and from its
//! reversal (the S is nearly point-symmetric).

use super::assign::{mirror, shift, REVERSAL_REACH};
use super::dlt::Dlt;
use super::{correspondences, Labels, SPathFitParams};
use crate::dots::Dot;
use synthcam_core::target::SPath;

/// The start dot as [`super::assign::best_assignment`] weighs it.
#[derive(Debug, Clone, Copy, PartialEq)]
pub(super) enum StartDot {
    /// None recognised.
    Unknown,
    /// Recognised with the chain from it ([`super::seeds::start_dot`]): among the contenders, one
    /// placing it at index 0 rules out those placing it elsewhere ([`start_agrees`]).
    Breaks(usize),
    /// Recognised by its area alone where the camera is known ([`super::seeds::start_by_area`]):
    /// as [`StartDot::Breaks`], and the best few labellings' shifts and mirror images that put
    /// it at index 0 are tried too ([`anchored_at_start`]).
    Anchors(usize),
}

impl StartDot {
    /// The dot recognised, if any.
    pub(super) fn dot(self) -> Option<usize> {
        match self {
            Self::Unknown => None,
            Self::Breaks(s) | Self::Anchors(s) => Some(s),
        }
    }
}

/// Labellings whose placements that put a start dot recognised by its area at 0 are tried
/// ([`StartDot::Anchors`]).
pub(super) const ANCHORED: usize = 3;

/// Placements of `labels` moved to put the dot `start` at index 0: where `labels` places it at
/// `l` (or, where it leaves it unplaced, where its camera projects path point `l` nearest to it:
/// a dot beyond the end of a reversed placement is a few indices past it), for every `m` within
/// [`REVERSAL_REACH`] of `l`, the labelling moved by `-m` and its mirror image about `m` (index
/// `i` to `m - i`: the reversal a nearly point-symmetric S is mistaken for), each with the start
/// dot at 0.
pub(super) fn anchored_at_start(labels: &[(usize, usize)], start: usize, dots: &[Dot], path: &SPath, params: &SPathFitParams) -> Vec<Labels> {
    let placed = labels.iter().find(|e| e.1 == start).map(|e| e.0);
    let Some(l) = placed.or_else(|| nearest_projected(labels, dots[start].centre_px, dots, path, params)) else { return Vec::new() };
    let with_start = |mut moved: Labels| {
        moved.retain(|e| e.0 != 0 && e.1 != start);
        moved.push((0, start));
        moved.sort_unstable();
        moved
    };
    let reach = REVERSAL_REACH as usize;
    (l.saturating_sub(reach)..=l + reach)
        .filter(|&m| m > 0)
        .flat_map(|m| [with_start(shift(labels, -(m as i64), path.len())), with_start(mirror(labels, m, path.len()))])
        .collect()
}

/// The path point whose projection by the camera of `labels` lies nearest `u`.
fn nearest_projected(labels: &[(usize, usize)], u: nalgebra::Point2<f64>, dots: &[Dot], path: &SPath, params: &SPathFitParams) -> Option<usize> {
    let (world, image) = correspondences(labels, dots, path);
    let cam = Dlt::fit(&world, &image, params.pinhole())?;
    let dist = |i: &usize| cam.project(&path.points_m[*i]).map_or(f64::INFINITY, |q| (q - u).norm());
    (0..path.len()).min_by(|a, b| dist(a).total_cmp(&dist(b)))
}

/// What a labelling says about the start dot (the dot recognised as it by its area, `start`):
/// `Some(false)` where it places that dot at another index or another dot at index 0 (the S
/// placed shifted along itself), `Some(true)` where it places it at 0, `None` where there is no
/// such dot.
pub(super) fn start_agrees(labels: &[(usize, usize)], start: Option<usize>) -> Option<bool> {
    let s = start?;
    let at0 = labels.iter().find(|l| l.0 == 0).map(|l| l.1);
    let placed = labels.iter().find(|l| l.1 == s).map(|l| l.0);
    match (at0, placed) {
        (None, None) => None,
        (at0, placed) => Some(at0 == Some(s) && placed == Some(0)),
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::s_path_fit::START_RADIUS_RATIO;
    use synthcam_core::target::spherical_s;

    #[test]
    fn a_reversed_placement_anchored_at_the_start_dot_is_the_right_one() {
        // Dots 0-44 of the course's desired view, labelled as the S's closest reversal (index i
        // taken for 104 - i, dots 0-3 left out: beyond the path's end): among the placements
        // moved to put the start dot (unplaced there) at 0 is the right one.
        let path = spherical_s();
        let k = synthcam_core::camera::CameraModel::sxga_1500px();
        let (r, t) = (
            nalgebra::Rotation3::from_matrix_unchecked(nalgebra::Matrix3::new(0.0, -1.0, 0.0, 0.0, 0.0, 1.0, -1.0, 0.0, 0.0)),
            nalgebra::Vector3::new(0.0, -0.55, 1.8),
        );
        let dots: Vec<Dot> = path.points_m[..45]
            .iter()
            .enumerate()
            .map(|(i, x)| {
                let c = r * x.coords + t;
                let area = if i == 0 { 30.0 * START_RADIUS_RATIO.powi(2) } else { 30.0 };
                Dot {
                    centre_px: nalgebra::Point2::new(640.0 + 1500.0 * c.x / c.z, 512.0 + 1500.0 * c.y / c.z),
                    area_px: area,
                    spread_px: 1.5,
                    core_px: 4,
                    contrast: 200.0,
                    touching: false,
                }
            })
            .collect();
        assert_eq!(super::super::seeds::start_by_area(&dots), Some(0));
        // Two dots merged into one blob (twice a dot's area) never pass for the start.
        let merged: Vec<Dot> = dots.iter().enumerate().map(|(i, d)| Dot { area_px: [30.0, 60.0][usize::from(i == 20)], ..*d }).collect();
        assert_eq!(super::super::seeds::start_by_area(&merged), None);
        let params = SPathFitParams { camera: Some(k), ..SPathFitParams::default() };
        let reversed: Labels = (4..45).map(|j| (104 - j, j)).collect();
        let right: Labels = (0..45).filter(|&j| j == 0 || j >= 4).map(|j| (j, j)).collect();
        let anchored = anchored_at_start(&reversed, 0, &dots, &path, &params);
        assert!(anchored.contains(&right), "{} placements, none the right one", anchored.len());
    }
}
